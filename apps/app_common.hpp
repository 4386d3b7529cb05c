// Conventions shared by the sph command-line apps.
#ifndef SPH_APPS_APP_COMMON_HPP_
#define SPH_APPS_APP_COMMON_HPP_

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <functional>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "cli_fwd.hpp"

#include "sph/io/cleanup.hpp"
#include "sph/io/output_files.hpp"
#include "sph/io/points_file.hpp"
#include "sph/core/ranges.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/simulation/simulation_options.hpp"
#include "sph/core/valid_range.hpp"
#include "sph/model/scms_model.hpp"

namespace sph::apps {

/// Exit codes of every sph app.
enum ExitCode : int {
  kExitOk = 0,         ///< success (sph_calibrate: a usable calibration)
  kExitNotUsable = 1,  ///< sph_calibrate: solved, but not usable (no convergence, undetermined parameters)
  kExitBadInput = 2,   ///< bad input or usage
};

/// A CLI11 check for a numeric option in `range`, refused in the library's words (RefusalOf()),
/// which CLI11 prefixes with the option's name:
/// "--sphere-radius-mm: must be > 0 and <= 1000 mm, got 1e308". (CLI11 2.1's own PositiveNumber
/// and Range print their 300-digit bounds and let infinity through.)
CLI::Validator InRange(const ValidRange& range);

/// The ranges of the apps' options: the library's and the apps' own.
namespace ranges {
using namespace sph::ranges;  // the library's (sph/core/ranges.hpp)
inline constexpr ValidRange kPlotTimeoutS{0.0, 86400.0, "s", true};
}  // namespace ranges

/// Adds --seed: a decimal integer from 0 to 2^64 - 1 ("--seed: must be an integer from 0 to
/// 18446744073709551615, got '-1'"), "010" being ten. (CLI11 2.1 alone wraps "-1" and 2^64 into
/// range and reads "010" as octal, "0x10" as hex.)
CLI::Option* AddSeedOption(CLI::App& app, std::uint64_t& seed, const std::string& help);

/// Adds --plot-timeout-s: how long each run of gnuplot may take before it is stopped (default 60 s,
/// within ranges::kPlotTimeoutS).
void AddPlotTimeoutOption(CLI::App& app, double& timeout_s);
/// --dcc FILE, the Digital Calibration Certificate to write, and --dcc-settings FILE, the
/// laboratory's settings it takes its administrative data from (docs/dcc.md).
void AddDccOptions(CLI::App& app, std::string& dcc_path, std::string& settings_path);

/// The options of the uncertainty inputs, one per field of kConditionFields ("--sphere-radius-u-um"
/// for the header field sphere_radius_u_um), with the same ranges. `source` ends the help text:
/// "(overrides the file's " gives "... (overrides the file's sphere_radius_u_um)".
void AddConditionOptions(CLI::App& app, SphereConditions& conditions, const std::string& source);

/// Adds the MachineOptions options (--alpha-deg ... --noise-phi-arcsec) to an app, listed under
/// `group` in --help when it is not empty.
void AddMachineOptions(CLI::App& app, MachineOptions& o, const std::string& group = "");

/// Adds --form-um, --form-flat-um and --form-bump-um, listed under `group`.
void AddFormOptions(CLI::App& app, FormOptions& o, const std::string& group);

/// The whole main() of an app: set up the options, parse, run. --help and --version exit 0, a parse
/// error exits kExitBadInput, and an exception escaping `run` is printed as "<name>: error: <what>"
/// on stderr with kExitBadInput. `run` returns the exit code. A signal that ends the program
/// removes the temporary files of its unfinished outputs (sph/io/cleanup.hpp). SIGPIPE is
/// ignored: a write to a closed pipe fails like one to a full disk, and a failed write to standard
/// output is an error ("<name>: error: cannot write to standard output: Broken pipe"), found by
/// OutputFiles::Commit() before the run's files are put in place, or at the latest here, as
/// kExitBadInput. Compiled once, in app_common.cpp, so that no main() compiles CLI11 (cli_fwd.hpp).
int RunApp(int argc, char** argv, const char* name, const std::function<void(CLI::App&)>& setup,
           const std::function<int()>& run);

/// RunApp() for an app whose options are an `Options` struct: `setup(app, options)` declares them
/// and `run(options)` runs with the parsed ones.
template <typename Options, typename Setup, typename Run>
int AppMain(int argc, char** argv, const char* name, Setup setup, Run run) {
  Options options;
  return RunApp(
      argc, argv, name, [&](CLI::App& app) { setup(app, options); }, [&] { return run(options); });
}

}  // namespace sph::apps

#endif  // SPH_APPS_APP_COMMON_HPP_
