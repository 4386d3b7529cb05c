// sph_montecarlo's command line: its options declared, each with its check and help.
#include <CLI/CLI.hpp>

#include "app_common.hpp"
#include "montecarlo_cmd.hpp"
#include "progress.hpp"
#include "sph/model/effect_terms.hpp"

namespace sph::apps {
namespace {

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

}  // namespace sph::apps
