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
#include "sph/io/output_files.hpp"
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

// Figure 4: the data, the script (Figure4Script()) and the three images, staged in the folder
// `dir` (PlotFolder::Make()).
void Plot(const std::string& dir, const MonteCarloStudyOptions& spec, const MonteCarloStudy& r, double timeout_s,
          OutputFiles& files) {
  const std::string folder = dir + "/";
  files.Stage(folder + "fig4_std.dat", [&](std::ostream& f) { WriteFigure4Std(f, r); });
  files.Stage(folder + "fig4_crlb.dat", [&](std::ostream& f) { WriteFigure4Crlb(f, spec, r); });
  files.Stage(folder + "fig4_spread.dat", [&](std::ostream& f) { WriteFigure4Spread(f, spec, r); });
  const std::string script = Figure4Script(spec, r);
  files.Stage(folder + "fig4.gp", [&](std::ostream& f) { f << script; });
  GnuplotRun run;
  run.folder = dir;
  run.script = script;
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

}  // namespace

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
