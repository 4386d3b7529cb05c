// sph_cansim: a simulated SCMS as CANopen traffic, into a candump log or onto a CAN interface.
#ifndef SPH_APPS_CANSIM_CMD_HPP_
#define SPH_APPS_CANSIM_CMD_HPP_

#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "cli_fwd.hpp"

#include "app_common.hpp"
#include "sph/can/device_options.hpp"
#include "sph/can/device_sim.hpp"

namespace sph::apps {

struct CansimOptions {
  std::string output_path;               ///< candump log ("-": stdout)
  std::string config_path;               ///< the --config file read (an input: never an output)
  std::string iface;                     ///< live: CAN interface, paced in real time
  std::string log_iface = "can0";        ///< interface name written into the log
  std::string sync_source = "internal";  ///< internal: the simulator sends SYNC; external: answers SYNC
  MachineOptions machine;                ///< truth, sphere, pattern, noise (as sph_simulate)
  std::string center_mm = "2,0,0";
  std::string mount_rotation_deg;  ///< "rx,ry,rz": the sphere's body frame on its mount (deg); empty: none
  FormOptions form;                ///< the sphere's form error on its body frame
  std::uint64_t seed = 1;
  double move_s = 0.5;
  double stop_s = 1.0;
  double heartbeat_period_s = 1.0;
  double start_time_s = 1.7e9;  ///< log mode: time of the first SYNC
  // faults
  double drop_probability = 0.0;
  double short_probability = 0.0;
  double sync_drop_probability = 0.0;
  double probe_out_of_range_probability = 0.0;
  double jitter_us = 0.0;
  double error_frame_period_s = 0.0;
  std::vector<double> bus_off_at_s;
  std::vector<std::string> silences;     ///< "device:from_s:to_s"
  std::vector<std::string> emergencies;  ///< "device:at_s:code"
  std::vector<std::string> faults;       ///< "reboot:NODE@T", "settings-lost:NODE@T"
  // the devices as CANopen nodes
  bool boot_operational = false;  ///< live: start operational (another master started them)
  double boot_s = 0.05;
  int transmission_type = 1;
  int nodes_sync_counter_max = -1;  ///< the nodes' 1019h after a boot; -1: --sync-counter-max
  std::string record_path;          ///< what was sent for each SYNC
  double duration_s = 0.0;          ///< live: stop after this long; 0: at the pattern's end
  can::DeviceOptions devices;
};

void SetupCansimApp(CLI::App& app, CansimOptions& options);

/// The simulator configuration of the options; throws sph::Error.
can::DeviceSimConfig MakeDeviceSimConfig(const CansimOptions& options);

/// Writes the log or plays onto the interface; a summary of what was sent (and the faults
/// injected) goes to `err`. Returns kExitOk, kExitBadInput, or kExitOutputError/kExitInterfaceError.
/// Log mode has no master: its devices are operational from the start. Live, they boot
/// pre-operational and wait for NMT Start (unless boot_operational).
///
/// The log (a regular file) and the record are written beside their names and put in place at
/// the end, complete or not at all; a FIFO, a character device or standard output is written
/// directly. A stop signal (SIGINT, SIGTERM: ProcessControl().stop) ends a live play normally
/// (the record is written); it cuts a log short, which is then removed: 128 + the signal's
/// number is returned.
int RunCansim(const CansimOptions& options, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_CANSIM_CMD_HPP_
