// The command line of the CAN apps: the device options shared by sph_acquired and sph_cansim (the
// same names configure the daemon and the simulated machine, so one config file serves both), the
// checks of their texts, and the strict reading of a --config file.
#ifndef SPH_APPS_CAN_OPTIONS_HPP_
#define SPH_APPS_CAN_OPTIONS_HPP_

#include <memory>
#include <string>

#include "cli_fwd.hpp"

#include "app_common.hpp"
#include "sph/can/device_options.hpp"

namespace sph::apps {

/// Adds the --theta-*, --phi-*, --probe-* and --sync-* options of `options`, in option group
/// "Devices". `period_may_be_unknown`: --sync-period-ms 0 means "not known" (a daemon following an
/// external SYNC producer); else the period must be given.
void AddDeviceOptions(CLI::App& app, can::DeviceOptions& options, bool period_may_be_unknown);

/// A CLI11 check for a number that is 0 (which means `zero`, e.g. "none") or in `range`, refused
/// in the library's words (RefusalOf()):
/// "--heartbeat-period-s: must be 0 (none) or >= 0.001 and <= 65.535 s, got 1e-300".
CLI::Validator ZeroOrInRange(const ValidRange& range, const std::string& zero);

/// A CLI11 check for an integer option in `range` (whole bounds), of an unsigned type where
/// `is_unsigned`: "--theta-node: Value 128 not in range 0 to 127".
CLI::Validator IntegerIn(const ValidRange& range, bool is_unsigned = false);

/// A CLI11 check for a Linux network interface name: 1 to 15 characters, none of them a space,
/// '/' or ':' (the kernel's rule), and not "." or "..".
CLI::Validator InterfaceName();

/// Makes `app` read its --config file strictly, the way the apps read every text input: a line
/// that names no option of `program` (nor of `also_known`, whose options the file may hold for
/// the other program), an option given twice, a section header or binary data (a NUL byte) is
/// refused with "<file>:<line>: <problem>". The path of the file read is put in `*path_read`.
void UseStrictConfig(CLI::App& app, const std::string& program, std::string* path_read,
                     std::shared_ptr<CLI::App> also_known = nullptr);

}  // namespace sph::apps

#endif  // SPH_APPS_CAN_OPTIONS_HPP_
