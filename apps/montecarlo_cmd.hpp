// sph_montecarlo: options, CLI set-up and the run function (unit-tested directly).
#ifndef SPH_APPS_MONTECARLO_CMD_HPP_
#define SPH_APPS_MONTECARLO_CMD_HPP_

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "cli_fwd.hpp"

#include "app_common.hpp"
#include "gnuplot.hpp"
#include "sph/calib/montecarlo_options.hpp"

namespace sph::apps {

/// What sph_montecarlo studies (the library's MonteCarloOptions), its plans and the files it writes.
struct MonteCarloAppOptions : MonteCarloOptions {
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
