// Conventions shared by the sph command-line apps.
#ifndef SPH_APPS_APP_COMMON_HPP_
#define SPH_APPS_APP_COMMON_HPP_

#include <exception>
#include <iostream>
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

/// The whole main() of an app: set up the options, parse, run. --help and --version exit 0, a parse
/// error exits kExitBadInput, and an exception escaping `run` is printed as "<name>: error: <what>"
/// on stderr with kExitBadInput. `run` takes the parsed options and returns the exit code.
template <typename Options, typename Setup, typename Run>
int AppMain(int argc, char** argv, const char* name, Setup setup, Run run) {
  CLI::App app;
  Options options;
  setup(app, options);
  app.set_version_flag("--version", std::string(name) + " " SPH_VERSION);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return ExitForParseError(app, e);
  }
  try {
    return run(options);
  } catch (const std::exception& e) {
    std::cerr << name << ": error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace sph::apps

#endif  // SPH_APPS_APP_COMMON_HPP_
