// Conventions shared by the sph command-line apps.
#ifndef SPH_APPS_APP_COMMON_HPP_
#define SPH_APPS_APP_COMMON_HPP_

#include <string>

#include <CLI/CLI.hpp>

namespace sph::apps {

/// Exit codes of every sph app.
enum ExitCode : int {
  kExitOk = 0,        ///< success (sph_calibrate: a usable calibration)
  kExitNotUsable = 1, ///< sph_calibrate: solved, but not usable (no convergence, undetermined parameters)
  kExitBadInput = 2,  ///< bad input or usage
};

/// Handles a CLI11 parse error the way every app does: --help and --version exit 0, anything else
/// prints CLI11's message and exits with kExitBadInput.
inline int ExitForParseError(const CLI::App& app, const CLI::ParseError& e) {
  const int code = app.exit(e);
  return code == 0 ? kExitOk : kExitBadInput;
}

}  // namespace sph::apps

#endif  // SPH_APPS_APP_COMMON_HPP_
