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

namespace sph::apps {

struct MonteCarloOptions {
  MachineOptions machine;  ///< truth, sphere, pattern, noise
  std::vector<double> eccentricities_mm{0.5, 1.0, 1.5, 2.0};
  std::string direction = "1,0,0";
  bool random_direction = false;
  int setups = 1;
  int trials = 1000;
  std::uint64_t seed = 1;
  int threads = 0;
  bool table3 = true;
  double table3_calibration_e_mm = 2.0;
  std::string json_path;
  std::string csv_path;
  std::string plot_dir;
  bool plan = false;                     ///< predict only, no simulation
  std::optional<double> target_std_um;   ///< with plan: search the smallest eccentricity
  bool progress = true;                  ///< progress bar on stderr when it is a terminal
};

void SetupMonteCarloApp(CLI::App& app, MonteCarloOptions& options);

/// Runs the study (or the plan); tables go to `out`, progress and errors to `err`.
/// Returns kExitOk, or kExitBadInput on bad options or a failed output.
int RunMonteCarloApp(const MonteCarloOptions& options, std::ostream& out, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_MONTECARLO_CMD_HPP_
