// sph_simulate: options, CLI set-up and the run function (unit-tested directly).
#ifndef SPH_APPS_SIMULATE_CMD_HPP_
#define SPH_APPS_SIMULATE_CMD_HPP_

#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "app_common.hpp"

namespace sph::apps {

struct SimulateOptions {
  std::string output_path = "-";
  std::string truth_path;                 ///< JSON truth file, empty: none
  MachineOptions machine;                 ///< truth, sphere, pattern, noise
  std::vector<std::string> centers_mm{"2,0,0"};  ///< "x,y,z" per setup
  std::uint64_t seed = 1;
  double sample_period_s = 1.0;
};

void SetupSimulateApp(CLI::App& app, SimulateOptions& options);

/// Writes the points file (and truth file). Returns kExitOk or kExitBadInput.
int RunSimulate(const SimulateOptions& options, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_SIMULATE_CMD_HPP_
