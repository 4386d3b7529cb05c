// sph_montecarlo: options, CLI set-up and the run function (unit-tested directly).
#ifndef SPH_APPS_MONTECARLO_CMD_HPP_
#define SPH_APPS_MONTECARLO_CMD_HPP_

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "cli_fwd.hpp"

#include "app_common.hpp"
#include "gnuplot.hpp"

namespace sph {
struct MonteCarloStudyOptions;
}  // namespace sph

namespace sph::apps {

struct MonteCarloAppOptions {
  MachineOptions machine;  ///< truth, sphere, pattern, noise
  std::vector<double> eccentricities_mm{0.5, 1.0, 1.5, 2.0};
  std::string direction = "1,0,0";
  bool random_direction = false;
  int setups = 1;
  int trials = 1000;
  std::uint64_t seed = 1;
  int threads = 0;
  double max_std_um = 10.0;  ///< a parameter whose predicted std, as a displacement, exceeds this is undetermined
  bool table3 = true;
  double table3_calibration_e_mm = 2.0;
  std::string json_path;
  std::string csv_path;
  std::string plot_dir;
  double plot_timeout_s = kDefaultPlotTimeoutS;  ///< gnuplot is stopped after this long
  bool plan = false;                             ///< predict only, no simulation
  std::optional<double> target_std_um;           ///< with plan: search the smallest eccentricity
  bool progress = true;                          ///< progress on stderr (ProgressMode::kAuto), or none
  /// --plan-orientations: the mount orientations that separate the sphere's form from the machine.
  bool plan_orientations = false;
  std::vector<std::string> effects;              ///< the machine's effects (ids); empty: the whole library
  int form_degree_max = 4;                       ///< the form's terms of degrees 2..L
  int max_orientations = 5;                      ///< the reference orientation included
  std::vector<std::string> candidate_rotations;  ///< "rx,ry,rz" [deg]; empty: the default candidates
  double phi_wobble_pivot_mm = 0.0;
};

void SetupMonteCarloApp(CLI::App& app, MonteCarloAppOptions& options);

/// Runs the study (or the plan); tables go to `out`, progress and errors to `err`.
/// Returns kExitOk, or kExitBadInput on bad options or a failed output.
int RunMonteCarloApp(const MonteCarloAppOptions& options, std::ostream& out, std::ostream& err);

/// The --plan-orientations run (orientation_plan_cmd.cpp): the plan for the sphere at each
/// eccentricity of `options`, as text on `out` or JSON through `files`. Throws sph::Error.
int RunOrientationPlan(const MonteCarloAppOptions& options, const MonteCarloStudyOptions& spec, std::ostream& out,
                       OutputFiles& files);

}  // namespace sph::apps

#endif  // SPH_APPS_MONTECARLO_CMD_HPP_
