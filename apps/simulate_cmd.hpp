// sph_simulate: options, CLI set-up and the run function (unit-tested directly).
#ifndef SPH_APPS_SIMULATE_CMD_HPP_
#define SPH_APPS_SIMULATE_CMD_HPP_

#include <ostream>
#include <string>

#include "cli_fwd.hpp"

#include "app_common.hpp"

namespace sph::apps {

/// What sph_simulate simulates (the library's SimulationOptions) and the files it writes.
struct SimulateOptions : SimulationOptions {
  std::string output_path = "-";
  std::string truth_path;  ///< JSON truth file, empty: none
};

void SetupSimulateApp(CLI::App& app, SimulateOptions& options);

/// Writes the points file (and truth file). Returns kExitOk or kExitBadInput.
int RunSimulate(const SimulateOptions& options, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_SIMULATE_CMD_HPP_
