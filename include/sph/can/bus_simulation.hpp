// A simulated SCMS on CAN as one call: what sph_cansim runs, for a host program that tests its
// acquisition without a machine. SimulateBusLog() writes the devices' traffic of the whole
// pattern into a candump log (no master: the devices are operational from the start);
// SimulateBusLive() plays the devices on a SocketCAN interface in real time, where they boot
// pre-operational and wait for a master's NMT Start (unless boot_operational), answer SDO, and
// either produce the SYNC or answer another producer's. The devices are DeviceSimulator's
// (sph/can/device_sim.hpp).
//
// Outputs: the log (a regular file) and the record are written beside their names and put in place
// at the end, complete or not at all; a FIFO, a character device or standard output ("-") is written
// directly. RunControl::stop ends a live play normally (the record is written) and cuts a log
// short, which is then removed. Messages name the options as sph_cansim's command line does.
#ifndef SPH_CAN_BUS_SIMULATION_HPP_
#define SPH_CAN_BUS_SIMULATION_HPP_

#include <cstdint>
#include <functional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "sph/can/device_options.hpp"
#include "sph/can/device_sim.hpp"
#include "sph/can/run_control.hpp"
#include "sph/core/valid_range.hpp"

namespace sph::can {

/// The options of a simulated bus: sph_cansim's, under the same names (--output: output_path).
struct BusSimulationOptions {
  std::string output_path;         ///< log: the candump log ("-": standard output)
  std::string iface;               ///< live: the CAN interface, paced in real time
  std::string log_iface = "can0";  ///< log: the interface named in its lines
  bool external_sync = false;      ///< live: answer the SYNCs of another producer instead of sending SYNC
  std::string record_path;         ///< what the devices sent for each SYNC (WriteRecord()); empty: none
  /// Files the options were read from, each with the option that names it ({"--config", path},
  /// {"--angles", path}): inputs, which no output may replace.
  std::vector<std::pair<std::string, std::string>> option_files;
  double duration_s = 0.0;        ///< live: stop after this long; 0: at the pattern's end
  bool boot_operational = false;  ///< live: the devices start operational (another master started them)
  DeviceOptions devices;          ///< ids, layouts, scales, SYNC: the same settings as the acquisition's
  /// The machine, the pattern and its timing, the faults, the nodes' settings. The run sets
  /// sim.devices and sim.sync_period_s from `devices`, sim.start_operational (log: always; live:
  /// boot_operational) and, live, sim.start_time_s to the time the play begins.
  DeviceSimConfig sim;
};

/// The valid values of the simulation's own numbers (the devices': sph/can/device_options.hpp).
namespace ranges {
inline constexpr ValidRange kStepTimeS{0.0, 3600.0, "s"};  ///< --move-s, --stop-s
inline constexpr ValidRange kProbability{0.0, 1.0, ""};
inline constexpr ValidRange kHeartbeatPeriodS{0.001, 65.535, "s"};    ///< or 0: none (1017h holds whole ms)
inline constexpr ValidRange kErrorFramePeriodS{0.001, 86400.0, "s"};  ///< or 0: none
inline constexpr ValidRange kJitterUs{0.0, 1e6, "us"};
inline constexpr ValidRange kBootS{0.0, 60.0, "s"};
inline constexpr ValidRange kTransmissionType{0.0, 255.0, ""};
inline constexpr ValidRange kNodesSyncCounterMax{-1.0, 240.0, ""};
}  // namespace ranges

/// "device:from_s:to_s" (--silence): `device` theta, phi or probe sends nothing then. Throws
/// sph::Error naming the option and its value ("--silence 'probe:14:10': the window must end after
/// it begins (from_s < to_s)").
Silence ParseSilence(const std::string& text);
/// "device:at_s:code" (--emcy): an EMCY frame, the code in hex.
EmcyEvent ParseEmcy(const std::string& text);
/// "reboot:NODE@T", "settings-lost:NODE@T", "preop:NODE@T" or "error:NODE@T" (--fault, see
/// NodeFaultKind; an error clears 1 s later): NODE a node id 1..127 or theta, phi, probe (their
/// nodes in `devices`), T in s after the start.
RebootEvent ParseFault(const std::string& text, const DeviceOptions& devices);

/// Throws sph::Error naming the option when a value is out of its range or the options do not go
/// together: neither or both of output_path and iface ("give either --output (a candump log) or
/// --iface (live)"), external_sync without iface, a simulation that would end beyond what a
/// frame time holds, the devices (DevicesConfig()), DeviceSimConfig::Validate(). The run checks
/// the rest as the simulator is made (an empty pattern, a set-up that sph_simulate refuses).
void CheckBusSimulationOptions(const BusSimulationOptions& options);

enum class BusSimulationStatus {
  kOk,
  kBadInput,        ///< the options, or an output that is an input
  kOutputError,     ///< the log or the record cannot be written (nothing is put in place)
  kInterfaceError,  ///< the CAN interface cannot be used
  kStopped,         ///< RunControl::stop cut the log short: it was removed (or, written directly, is incomplete)
};

/// What a run sent.
struct BusSimulationResult {
  BusSimulationStatus status = BusSimulationStatus::kOk;
  std::string error;                                 ///< why the run failed (kBadInput, kOutputError, kInterfaceError)
  int stopped_by = 0;                                ///< kStopped: RunControl::stop's value (the signal's number)
  std::uint64_t cycles = 0;                          ///< SYNC cycles of the whole pattern
  double duration_s = 0.0;                           ///< the pattern's duration
  SimInjected injected;                              ///< what the devices did, the faults they injected
  std::uint64_t frames_sent = 0, frames_failed = 0;  ///< live: frames written to the socket, and not
  std::uint64_t pdos_late = 0;  ///< live: PDOs not sent because their synchronous window had closed
};

/// What the run tells while it runs, in order: kInfo lines ("28800 SYNC cycles, 28.8 s", the play's
/// counts, the faults injected) and kError the failure (the result's error).
struct BusSimulationHooks {
  std::function<void(LogLevel, const std::string&)> log;
};

/// Writes the devices' traffic of the whole pattern into options.output_path. Never throws for
/// bad input: the result says.
BusSimulationResult SimulateBusLog(const BusSimulationOptions& options, RunControl& control,
                                   const BusSimulationHooks& hooks);
/// Plays the devices on options.iface until the pattern's end, duration_s or RunControl::stop.
BusSimulationResult SimulateBusLive(const BusSimulationOptions& options, RunControl& control,
                                    const BusSimulationHooks& hooks);

/// The record's text: one line per SYNC the devices answered, "sync_t_s counter theta_deg phi_deg
/// r_mm", '-' for no counter or no valid value, after a comment line naming the columns.
void WriteRecord(const std::vector<SimCycleRecord>& records, std::ostream& out);

/// "cycles 2500, SYNC dropped 0, PDOs sent theta/phi/probe 2500/2500/2500, ...": what `injected`
/// counts.
std::string FormatInjected(const SimInjected& injected);

}  // namespace sph::can

#endif  // SPH_CAN_BUS_SIMULATION_HPP_
