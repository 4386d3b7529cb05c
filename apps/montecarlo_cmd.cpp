#include "montecarlo_cmd.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <CLI/CLI.hpp>

#include "gnuplot.hpp"
#include "progress.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/calib/design.hpp"
#include "sph/calib/montecarlo.hpp"
#include "sph/calib/montecarlo_report.hpp"
#include "sph/core/error.hpp"
#include "sph/core/output_files.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph::apps {
namespace {

using internal::Format;

// The study of the options; the plans make no Table 3.
MonteCarloStudyOptions ToSpec(const MonteCarloAppOptions& o) {
  MonteCarloOptions study = o;
  if (o.plan || o.plan_orientations) study.table3 = false;
  return MonteCarloSpecOf(study);
}

// Figure 4: std against eccentricity with the Cramer-Rao curve, and the spread of the estimates:
// the data, the script and the three images, staged in the folder `dir` (PlotFolder::Make()).
void Plot(const std::string& dir, const MonteCarloStudyOptions& spec, const MonteCarloStudy& r, double timeout_s,
          OutputFiles& files) {
  const std::string folder = dir + "/";
  const double e_min = r.rows.front().eccentricity_mm, e_max = r.rows.back().eccentricity_mm;
  files.Stage(folder + "fig4_std.dat", [&](std::ostream& f) { WriteFigure4Std(f, r); });
  files.Stage(folder + "fig4_crlb.dat", [&](std::ostream& f) { WriteFigure4Crlb(f, spec, r); });
  files.Stage(folder + "fig4_spread.dat", [&](std::ostream& f) { WriteFigure4Spread(f, spec, r); });
  const std::string title = Format("%d trials per point, sigma_r %g um", spec.trials, spec.base.noise_r_um);
  std::string xtics;
  for (const auto& row : r.rows) xtics += (xtics.empty() ? "" : ", ") + Format("%g", row.eccentricity_mm);
  std::ostringstream script;
  script << "# Figure 4 of the study; rerun with: gnuplot fig4.gp (in this folder)\n";
  for (const char* name : {"std", "crlb", "spread"}) {
    script << "if (!exists(\"" << name << "_dat\")) " << name << "_dat = 'fig4_" << name << ".dat'\n";
  }
  for (const char* name : {"b_c_std", "beta_epsilon_std", "spread"}) {
    script << "if (!exists(\"" << name << "_png\")) " << name << "_png = 'fig4_" << name << ".png'\n";
  }
  script << "set terminal pngcairo size 900,600 font ',11'\n"
         << "set grid\nset logscale xy\nset key top right\nset xlabel 'eccentricity of the sphere [mm]'\n"
         << "set xrange [" << 0.7 * std::min(e_min, e_max) << ":" << 1.4 * std::max(e_min, e_max) << "]\n"
         << "set xtics (" << xtics << ")\n"
         << "set output b_c_std_png\n"
         << "set title 'Standard deviation of b and c (" << title << ")'\n"
         << "set ylabel 'standard deviation [um]'\n"
         << "plot crlb_dat u 1:2 w l lw 2 lc rgb '#1f77b4' t 'b, Cramer-Rao', "
            "std_dat u 1:2 w p pt 7 ps 1.5 lc rgb '#1f77b4' t 'b, Monte Carlo', "
            "crlb_dat u 1:3 w l lw 2 lc rgb '#d62728' t 'c, Cramer-Rao', "
            "std_dat u 1:3 w p pt 5 ps 1.5 lc rgb '#d62728' t 'c, Monte Carlo'\n"
         << "set output beta_epsilon_std_png\n"
         << "set title 'Standard deviation of beta and epsilon (" << title << ")'\n"
         << "set ylabel 'standard deviation [urad]'\n"
         << "plot crlb_dat u 1:4 w l lw 2 lc rgb '#1f77b4' t 'beta, Cramer-Rao', "
            "std_dat u 1:4 w p pt 7 ps 1.5 lc rgb '#1f77b4' t 'beta, Monte Carlo', "
            "crlb_dat u 1:5 w l lw 2 lc rgb '#d62728' t 'epsilon, Cramer-Rao', "
            "std_dat u 1:5 w p pt 5 ps 1.5 lc rgb '#d62728' t 'epsilon, Monte Carlo'\n"
         << "unset logscale\nset logscale x\nset key top right\n"
         << "set output spread_png\n"
         << "set title 'Spread of the estimates of b and c (every trial)'\n"
         << "set ylabel 'estimate - truth [um]'\n"
         << "plot spread_dat u ($1*0.97):2 w p pt 7 ps 0.3 lc rgb '#801f77b4' t 'b', "
            "spread_dat u ($1*1.03):3 w p pt 7 ps 0.3 lc rgb '#80d62728' t 'c'\n";
  files.Stage(folder + "fig4.gp", [&](std::ostream& f) { f << script.str(); });
  GnuplotRun run;
  run.folder = dir;
  run.script = script.str();
  run.description = "Figure 4";
  run.timeout_s = timeout_s;
  for (const char* name : {"std", "crlb", "spread"}) {
    run.Set(std::string(name) + "_dat", files.StagedName(folder + "fig4_" + name + ".dat"));
  }
  for (const char* name : {"b_c_std", "beta_epsilon_std", "spread"}) {
    run.Draw(std::string(name) + "_png", folder + "fig4_" + name + ".png", files);
  }
  RunGnuplot(run, "--plot-dir " + dir);
}

// --plan: the predicted uncertainties, the table on the report unless the JSON takes standard output.
int RunPlan(const MonteCarloAppOptions& o, const MonteCarloStudyOptions& spec, std::ostream& report,
            OutputFiles& files) {
  std::ostringstream discarded;
  const MachineOptions& m = o.machine;
  const std::string pattern = m.angles_path.empty()
                                  ? Format("%d", m.theta_steps) + " x " + Format("%d", m.phi_steps) + " grid"
                                  : "pattern " + m.angles_path;
  const std::string json =
      PlanStudy(o.json_path == "-" ? discarded : report, spec, pattern, o.target_std_um, m.angles_path.empty());
  if (!o.json_path.empty()) files.Stage(o.json_path, [&](std::ostream& f) { f << json; });
  files.Commit();
  return kExitOk;
}

// --plan-orientations and the options that go with it.
void AddOrientationPlanOptions(CLI::App& app, MonteCarloAppOptions& o) {
  auto* orient = app.add_flag("--plan-orientations", o.plan_orientations,
                              "Propose the orientations of the sphere on its mount that separate its form from the "
                              "machine (--effects, --form-degree-max), at each eccentricity, without simulating noise");
  orient->excludes(app.get_option("--plan"))->excludes(app.get_option("--random-direction"));
  std::string ids;
  std::vector<std::string> all_ids;
  for (const EffectInfo& e : kEffectInfo) {
    ids += (ids.empty() ? "" : ", ") + std::string(e.id);
    all_ids.emplace_back(e.id);
  }
  app.add_option("--effects", o.effects,
                 "With --plan-orientations: the machine's effects beyond the seven errors (comma-separated; default "
                 "the whole library): " +
                     ids)
      ->delimiter(',')
      ->needs(orient)
      ->check(CLI::IsMember(all_ids));
  app.add_option("--form-degree-max", o.form_degree_max,
                 "With --plan-orientations: separate the form's terms of degrees 2 to this")
      ->capture_default_str()
      ->needs(orient)
      ->check(CLI::Range(2, 12));
  app.add_option("--max-orientations", o.max_orientations,
                 "With --plan-orientations: at most this many orientations, the reference one included")
      ->capture_default_str()
      ->needs(orient)
      ->check(CLI::Range(1, 20));
  app.add_option("--candidate-rotation-deg", o.candidate_rotations,
                 "With --plan-orientations: a mount rotation to choose from, a rotation vector rx,ry,rz [deg] "
                 "(axis times angle; repeat the option; default: turns by 90, 180, 270 deg about z, by +-90 and 180 "
                 "deg about x and y, and 120 deg about (1,1,1))")
      ->needs(orient);
  app.add_option("--phi-wobble-pivot-mm", o.phi_wobble_pivot_mm,
                 "With --plan-orientations: the Phi axis wobble's pivot distance along the axis [mm]")
      ->capture_default_str()
      ->needs(orient)
      ->check(InRange(ranges::kPivotMm));
}

}  // namespace

void SetupMonteCarloApp(CLI::App& app, MonteCarloAppOptions& o) {
  app.description(
      "Monte Carlo study of the calibration against the sphere's eccentricity (the paper's Tables 2 and "
      "3 and Figure 4), with the Cramer-Rao prediction; --plan predicts without simulating.");
  AddMachineOptions(app, o.machine);
  app.add_option("--trials", o.trials, "Calibrations per eccentricity")
      ->capture_default_str()
      ->check(InRange(ranges::kTrials));
  app.add_option("--eccentricities-mm", o.eccentricities_mm, "Eccentricities of the sphere [mm]")
      ->capture_default_str()
      ->delimiter(',');
  app.add_option("--direction", o.direction, "Direction of the eccentricity x,y,z")->capture_default_str();
  app.add_flag("--random-direction", o.random_direction, "A random direction for every trial (and setup)");
  app.add_option("--setups", o.setups, "Sphere placements per trial, turned evenly about the Theta axis")
      ->capture_default_str()
      ->check(InRange(ranges::kSetups));
  AddSeedOption(app, o.seed, "Random seed (results depend on it alone, not on --threads)")->capture_default_str();
  app.add_option("--max-std-um", o.max_std_um,
                 "A parameter whose predicted standard deviation, as a displacement of the probed point (angles "
                 "times R0), exceeds this is undetermined, as sph_calibrate judges it [um]")
      ->capture_default_str()
      ->check(InRange(ranges::kStdUm));
  app.add_option("--threads", o.threads, "Worker threads (0: all cores)")
      ->capture_default_str()
      ->check(InRange(ranges::kThreads));
  app.add_flag("!--no-table3", o.table3, "Skip Table 3 (sphericity of ten further spheres)");
  app.add_option("--table3-calibration-e-mm", o.table3_calibration_e_mm,
                 "Eccentricity of the calibration used for Table 3 [mm]")
      ->capture_default_str();
  app.add_option("--json", o.json_path, "Write the results as JSON ('-' for stdout)");
  app.add_option("--csv", o.csv_path, "Write the per-parameter statistics as CSV");
  app.add_option("--plot-dir", o.plot_dir, "Write Figure 4 (PNG, with gnuplot) and its data into this folder");
  AddPlotTimeoutOption(app, o.plot_timeout_s);
  app.add_flag("--plan", o.plan, "Predict the standard deviations from the linearised model, without simulating");
  app.add_option("--target-std-um", o.target_std_um,
                 "With --plan: find the smallest eccentricity (and per grid) meeting this std as a displacement [um]")
      ->check(InRange(ranges::kStdUm));
  AddOrientationPlanOptions(app, o);
  app.add_flag("!--no-progress", o.progress,
               "No progress on stderr (default: on a terminal once the run takes longer than a second; into a log "
               "once it takes longer than ten seconds, a line now and then)");
}

int RunMonteCarloApp(const MonteCarloAppOptions& o, std::ostream& out, std::ostream& err) {
  const PlotFolder plot_folder(o.plot_dir);  // removed again when a failed run leaves it empty
  try {
    RunPaths paths;
    paths.Input("--angles", o.machine.angles_path)
        .Output("the text report", o.json_path != "-" ? "-" : "")
        .Output("--json", o.json_path)
        .Output("--csv", o.csv_path);
    if (!o.plot_dir.empty()) {
      for (const char* f : {"fig4_std.dat", "fig4_crlb.dat", "fig4_spread.dat", "fig4.gp", "fig4_b_c_std.png",
                            "fig4_beta_epsilon_std.png", "fig4_spread.png"}) {
        paths.Output("--plot-dir", o.plot_dir + "/" + f);
      }
    }
    const MonteCarloStudyOptions spec = ToSpec(o);
    OutputFiles files(out);
    if (o.plan) return RunPlan(o, spec, out, files);
    if (o.target_std_um) throw Error("--target-std-um goes with --plan");
    if (o.plan_orientations) return RunOrientationPlan(o, spec, out, files);
    Progress progress("sph_montecarlo", err, o.progress ? ProgressMode::kAuto : ProgressMode::kNever);
    const MonteCarloRun run = RunMonteCarloStudy(o, [&](long d, long t) { progress.Update("calibrating", d, t); });
    progress.Finish();
    const MonteCarloStudy& r = run.study;
    const bool text = o.json_path != "-";
    if (text) WriteStudyTables(out, spec, r);
    if (run.table3 && text) WritePaperTable3(out, spec, *run.table3);
    if (text) {
      out << "\n"
          << o.trials * static_cast<int>(r.rows.size()) << " calibrations in " << Format("%.2f", run.wall_time_s)
          << " s\n"
          << std::flush;
    }
    if (!o.json_path.empty()) {
      const std::string json = run.JsonReport();
      files.Stage(o.json_path, [&](std::ostream& f) { f << json; });
    }
    if (!o.csv_path.empty()) files.Stage(o.csv_path, [&](std::ostream& f) { WriteStudyCsv(f, r); });
    if (!o.plot_dir.empty()) {
      plot_folder.Make();
      Plot(o.plot_dir, spec, r, o.plot_timeout_s, files);
    }
    files.Commit();
    if (!o.plot_dir.empty()) {
      err << "sph_montecarlo: wrote " << o.plot_dir
          << "/fig4_b_c_std.png, fig4_beta_epsilon_std.png, fig4_spread.png\n";
    }
    return kExitOk;
  } catch (const std::exception& e) {
    err << "sph_montecarlo: error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace sph::apps
