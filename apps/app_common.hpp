// Conventions shared by the sph command-line apps.
#ifndef SPH_APPS_APP_COMMON_HPP_
#define SPH_APPS_APP_COMMON_HPP_

#include <cmath>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <CLI/CLI.hpp>

#include "sph/core/simulate.hpp"

namespace sph::apps {

/// Exit codes of every sph app.
enum ExitCode : int {
  kExitOk = 0,        ///< success (sph_calibrate: a usable calibration)
  kExitNotUsable = 1, ///< sph_calibrate: solved, but not usable (no convergence, undetermined parameters)
  kExitBadInput = 2,  ///< bad input or usage
};

/// CLI11 checks for numbers with plain messages ("must be positive"); CLI11 2.1's PositiveNumber
/// and NonNegativeNumber are ranges that print their 300-digit upper bound. Infinity is refused
/// too: a value written on into a file's header would make a file the readers refuse.
inline CLI::Validator Positive() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        return end != text.c_str() && *end == '\0' && v > 0.0 && std::isfinite(v)
                   ? ""
                   : "must be a positive number, got " + text;
      },
      "POSITIVE");
}
inline CLI::Validator NonNegative() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        return end != text.c_str() && *end == '\0' && v >= 0.0 && std::isfinite(v)
                   ? ""
                   : "must be a finite number >= 0, got " + text;
      },
      "NONNEGATIVE");
}

/// The simulated machine and measurement shared by sph_simulate and sph_montecarlo: the true
/// errors, the sphere, the pattern and the noise (defaults: the paper's study).
struct MachineOptions {
  double alpha_deg = 0.02, a_mm = 0.002, beta_deg = 0.02, b_mm = 0.002;
  double epsilon_deg = 0.02, c_mm = 0.002, d_prime_mm = -0.062;
  double sphere_radius_mm = 20.0;
  double probe_offset_mm = 25.0;
  int theta_steps = 24;
  int phi_steps = 12;
  std::string angles_path;  ///< explicit pattern: "theta_deg phi_deg" per line
  double noise_r_um = 0.05;
  double noise_theta_arcsec = 0.0;
  double noise_phi_arcsec = 0.0;
};

/// Adds the MachineOptions options (--alpha-deg ... --noise-phi-arcsec) to an app, listed under
/// `group` in --help when it is not empty.
void AddMachineOptions(CLI::App& app, MachineOptions& o, const std::string& group = "");

/// The simulation spec of the options (centres and seed left at their defaults). Reads the
/// --angles file; throws sph::Error on a bad one.
SimulationSpec ToSimulationSpec(const MachineOptions& o);

/// Parses "x,y,z" (mm); `what` names the option in the error.
Eigen::Vector3d ParseVector3(const std::string& text, const std::string& what);

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
