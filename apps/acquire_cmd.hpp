// sph_acquired: options, CLI set-up and the run functions (unit-tested directly).
//
// Exit codes: 0 stopped cleanly (signal, end of replay, --duration-s) with no sample lost;
// 1 stopped cleanly but samples were lost (incomplete cycles, missed SYNC, kernel drops: see the
// summary); 2 bad input or usage; 3 output error (points file or frame log: e.g. a full disk;
// everything written before is intact); 4 CAN interface error at start (no such interface, no
// CAN support in the kernel); 5 the start was refused: a device did not answer or does not match
// the configuration (the message names node, object and both values), no output is made.
#ifndef SPH_APPS_ACQUIRE_CMD_HPP_
#define SPH_APPS_ACQUIRE_CMD_HPP_

#include <csignal>
#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include "cli_fwd.hpp"

#include "can_options.hpp"
#include "sph/can/master.hpp"
#include "sph/can/pipeline.hpp"

namespace sph::apps {

enum AcquireExit : int {
  kExitSamplesLost = 1,
  kExitOutputError = 3,
  kExitInterfaceError = 4,
  kExitDeviceError = 5,
};

struct AcquireOptions {
  std::string iface;            ///< live: CAN interface
  std::string replay_path;      ///< offline: candump log
  std::string replay_iface;     ///< offline: the interface replayed; empty: the log's only one
  std::string output_path;      ///< points file (appended)
  std::string can_log_path;     ///< candump log of every frame (appended); empty: none
  std::string config_path;      ///< the --config file read (an input: never an output)
  std::string mode = "stream";  ///< stream | points
  int setup = 0;
  std::optional<double> sphere_radius_mm;
  std::optional<double> probe_offset_mm;
  /// Header: the sphere's orientation on its mount in this setup, "rx,ry,rz" (rotation vector,
  /// deg) or "unknown"; empty: none (the reference orientation).
  std::string mount_rotation_deg;
  /// Header: this setup measures another sphere than the reference one, of this radius [mm].
  std::optional<double> other_sphere_radius_mm;
  double fsync_interval_s = 1.0;
  std::string sync_mode = "produce";  ///< produce | follow
  double heartbeat_timeout_s = 0.0;
  double standstill_tol_deg = 0.001;
  double dwell_s = 0.2;
  double average_s = 0.0;
  int min_samples = 3;
  double duration_s = 0.0;         ///< live: stop after this long; 0: until a signal
  double replay_speed = 0.0;       ///< replay: 1 = real time; 0: as fast as possible
  double reopen_interval_s = 0.5;  ///< live: retry period while the interface is down
  int rcvbuf_bytes = 0;
  std::string log_level = "info";
  int verbose = 0;
  // the CANopen master
  bool no_nmt = false;             ///< leave NMT to another master
  bool nmt_broadcast = false;      ///< one Start to all nodes (node 0)
  bool nmt_reset_comm = false;     ///< Reset communication first
  bool nmt_stop_at_exit = false;   ///< Stop remote node at the end
  bool nmt_preop_at_exit = false;  ///< Enter pre-operational at the end
  bool no_sdo = false;             ///< no identification, no checks
  bool trust_config = false;       ///< mismatches are warnings
  bool configure_pdo = false;      ///< write the TPDO settings, verify by reading back
  double sdo_timeout_ms = 500.0;
  double boot_timeout_s = 5.0;
  int node_heartbeat_ms = 100;   ///< written into a node whose 1017h is 0; 0: none
  std::string probe_pdo_object;  ///< "0x2000:00": checked in the probe's mapping
  DeviceOptions devices;
};

/// Flags the signal handlers set (sph_acquired.cpp installs them).
struct SignalFlags {
  volatile std::sig_atomic_t stop = 0;     ///< SIGTERM, SIGINT: the signal's number
  volatile std::sig_atomic_t summary = 0;  ///< SIGUSR1
};
/// The process's flags.
SignalFlags& ProcessSignals();
/// Installs SIGTERM/SIGINT/SIGUSR1 handlers (no SA_RESTART) that set ProcessSignals().
void InstallSignalHandlers();

void SetupAcquireApp(CLI::App& app, AcquireOptions& options);

/// Runs the daemon (live or replay). Logs, warnings and the summary go to `err`.
/// Returns one of the exit codes above.
int RunAcquire(const AcquireOptions& options, std::ostream& err);

// ---- for the run functions and their tests
/// The pipeline configuration the options describe; throws sph::Error.
can::PipelineConfig MakePipelineConfig(const AcquireOptions& options);
/// The master's configuration (nodes from `pipeline`, option names in its messages); throws
/// sph::Error.
can::MasterConfig MakeMasterConfig(const AcquireOptions& options, const can::PipelineConfig& pipeline);

/// Writes "sph_acquired: <level>: <text>" lines at or below a level.
class Logger {
 public:
  Logger(std::ostream& out, can::LogLevel max_level) : out_(out), max_(max_level) {}
  void operator()(can::LogLevel level, const std::string& text) const;
  bool Enabled(can::LogLevel level) const { return static_cast<int>(level) <= static_cast<int>(max_); }

 private:
  std::ostream& out_;
  can::LogLevel max_;
};

}  // namespace sph::apps

#endif  // SPH_APPS_ACQUIRE_CMD_HPP_
