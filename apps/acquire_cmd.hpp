// sph_acquired: options, CLI set-up and the run function (unit-tested directly). The acquisition
// itself is the library's (sph/can/acquisition.hpp); this declares its options and prints what it
// tells.
//
// Exit codes: 0 stopped cleanly (signal, end of replay, --duration-s) with no sample lost;
// 1 stopped cleanly but samples were lost (incomplete cycles, missed SYNC, kernel drops: see the
// summary); 2 bad input or usage; 3 output error (points file or frame log: e.g. a full disk;
// everything written before is intact); 4 CAN interface error at start (no such interface, no
// CAN support in the kernel); 5 the start was refused: a device did not answer or does not match
// the configuration (the message names node, object and both values), no output is made.
#ifndef SPH_APPS_ACQUIRE_CMD_HPP_
#define SPH_APPS_ACQUIRE_CMD_HPP_

#include <ostream>
#include <string>

#include "cli_fwd.hpp"

#include "app_common.hpp"
#include "sph/can/acquisition.hpp"
#include "sph/can/run_control.hpp"

namespace sph::apps {

enum AcquireExit : int {
  kExitSamplesLost = 1,
  kExitOutputError = 3,
  kExitInterfaceError = 4,
  kExitDeviceError = 5,
  kExitNodeLost = 6,  ///< a node left operational mid-run and did not come back: the run ended cleanly
};

struct AcquireOptions {
  can::AcquisitionOptions acq;  ///< every option but those below, bound to the library's fields
  std::string config_path;      ///< the --config file read (an input: never an output)
  std::string log_level = "info";
  int verbose = 0;
};

/// The process's run control, whose flags the signal handlers set.
can::RunControl& ProcessControl();
/// Installs SIGTERM/SIGINT/SIGUSR1 handlers (no SA_RESTART) that set ProcessControl()'s stop (to
/// the signal's number) and summary flags, and makes them its wake signals.
void InstallSignalHandlers();

void SetupAcquireApp(CLI::App& app, AcquireOptions& options);

/// Runs the daemon (live or replay) with ProcessControl(). Logs, warnings and the summary go to
/// `err` ("sph_acquired: warning: ..."). Returns one of the exit codes above.
int RunAcquire(const AcquireOptions& options, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_ACQUIRE_CMD_HPP_
