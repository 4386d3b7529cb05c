// An acquisition as one call: what sph_acquired runs, for a host program that acquires without
// the command line. LiveAcquisition() reads a SocketCAN interface, ReplayAcquisition() a candump
// log; both run the same AcquisitionSession (the CANopen master and the pipeline on the same
// frames) into a points file and, if asked, a frame log, and return what was made and counted.
//
// Before anything is made, the call checks the options (AcquisitionOptions: each value in its
// range, the combinations), that no output is an input or another output, the replayed log
// (CheckReplayLog) and that each existing output may be continued. Then the master starts the
// devices; once every node runs, the outputs are opened (see AcquisitionSession). The run ends at
// the log's end, when RunControl::stop is set, after duration_s, or when the start is refused.
// Messages name the options as sph_acquired's command line and config file do ("--sync-period-ms",
// a config file's "sync-period-ms"): the names a host's own configuration can mirror.
#ifndef SPH_CAN_ACQUISITION_HPP_
#define SPH_CAN_ACQUISITION_HPP_

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sph/can/device_options.hpp"
#include "sph/can/master.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/can/run_control.hpp"
#include "sph/can/sdo.hpp"
#include "sph/can/standstill.hpp"
#include "sph/core/ranges.hpp"
#include "sph/core/valid_range.hpp"
#include "sph/io/points_file.hpp"
#include "sph/io/points_writer.hpp"

namespace sph::can {

enum class SyncMode {
  kProduce,  ///< the acquisition sends SYNC every sync period (live)
  kFollow,   ///< another node produces SYNC
};

/// The options of an acquisition: sph_acquired's, under the same names (--output: output_path).
struct AcquisitionOptions {
  std::string iface;         ///< live: the CAN interface
  std::string replay_path;   ///< replay: a candump log
  std::string replay_iface;  ///< replay: the interface replayed; empty: the log's only one
  std::string output_path;   ///< --output: the points file (sph-points 1), appended, never overwritten
  std::string can_log_path;  ///< --can-log: every frame appended to this candump log; empty: none
  /// Files the options were read from, each with the option that names it ({"--config", path}):
  /// inputs, which no output may replace.
  std::vector<std::pair<std::string, std::string>> option_files;
  /// fsync the outputs at most this long after a record [s]; 0: every record; -1: only at the end.
  double fsync_interval_s = 1.0;
  Mode mode = Mode::kStream;               ///< kStream: a row per SYNC cycle; kPoints: one averaged row per stop
  int setup = 0;                           ///< the sphere placement written in the setup column
  std::optional<double> sphere_radius_mm;  ///< header: R0
  std::optional<double> probe_offset_mm;   ///< header: d
  /// Header: the sphere's orientation on its mount in this setup (mount_rotation_deg@setup);
  /// none: the reference orientation.
  std::optional<MountRotation> mount_rotation;
  /// Header: this setup measures another sphere than the reference one, of this radius [mm].
  std::optional<double> other_sphere_radius_mm;
  SyncMode sync_mode = SyncMode::kProduce;
  /// A node without heartbeat this long is lost; 0: off; -1: three of the longest producer
  /// heartbeat time the master found or set in the nodes (off without NMT or SDO).
  double heartbeat_timeout_s = -1.0;
  /// The bus's bitrate [kbit/s]: the SYNC cycle's load is checked against it (sph/can/bus_load.hpp)
  /// and, without --sync-period-ms, the period chosen from it; 0: the interface's, where the
  /// kernel reports it (live), else not checked.
  double bitrate_kbit_s = 0.0;
  StandstillConfig standstill;     ///< points mode: --standstill-tol-deg, --dwell-s, --average-s, --min-samples
  double duration_s = 0.0;         ///< live: stop after this long; 0: until RunControl::stop
  double replay_speed = 0.0;       ///< replay: 1 = the log's own pace; 0: as fast as possible
  double reopen_interval_s = 0.5;  ///< live: how often to look whether a lost interface is back
  int rcvbuf_bytes = 0;            ///< live: the socket's receive buffer (SO_RCVBUF); 0: the kernel's
  // the CANopen master
  bool no_nmt = false;             ///< send no NMT command: another master starts the devices
  bool nmt_broadcast = false;      ///< one Start to all nodes (node 0)
  bool nmt_reset_comm = false;     ///< Reset communication first, then wait for the boot-ups
  bool nmt_stop_at_exit = false;   ///< Stop remote node at the end
  bool nmt_preop_at_exit = false;  ///< Enter pre-operational at the end
  bool no_sdo = false;             ///< no identification, no checks
  bool trust_config = false;       ///< a device that differs from the configuration is a warning
  bool configure_pdo = false;      ///< write the TPDO settings and 1019h, verify by reading back
  double sdo_timeout_ms = 500.0;
  double boot_timeout_s = 5.0;
  /// A node that left operational mid-run (rebooted, or its heartbeat says another state) is
  /// started again; not operational within this, it ends the run (AcquisitionStatus::kNodeLost).
  double node_return_timeout_s = 10.0;
  int node_heartbeat_ms = 100;  ///< written into a node whose 1017h is 0; 0: none
  /// --probe-pdo-object: the object the probe's TPDO maps at its offset byte (checked, and
  /// written with configure_pdo); none: the probe's mapping is not checked.
  std::optional<ObjectAddress> probe_pdo_object;
  DeviceOptions devices;
  /// The program named in the points file's header (generator) and in its resumed comment;
  /// empty: "sph_acquired <version>".
  std::string generator;
};

/// The valid values of the acquisition's own numbers (the devices': sph/can/device_options.hpp;
/// the sphere's and the probe's: sph/core/ranges.hpp).
namespace ranges {
using sph::ranges::kProbeOffsetMm;
using sph::ranges::kSphereRadiusMm;
inline constexpr ValidRange kFsyncIntervalS{0.0, 86400.0, "s"};  ///< or -1: only at the end
inline constexpr ValidRange kTimeoutS{0.0, 86400.0, "s"};        ///< heartbeat timeout, dwell, averaging
inline constexpr ValidRange kStandstillTolDeg{0.0, 360.0, "deg", true};
inline constexpr ValidRange kMinSamples{1.0, 100000000.0, ""};
inline constexpr ValidRange kReplaySpeed{0.0, 1e6, "times the log's pace"};
inline constexpr ValidRange kReopenIntervalS{0.0, 3600.0, "s", true};
inline constexpr ValidRange kRcvbufBytes{0.0, 1073741824.0, "bytes"};
inline constexpr ValidRange kNodeHeartbeatMs{0.0, 65535.0, ""};
inline constexpr ValidRange kSdoTimeoutMs{1.0, 60000.0, "ms"};
inline constexpr ValidRange kBootTimeoutS{0.01, 600.0, "s"};
inline constexpr ValidRange kNodeReturnTimeoutS{0.1, 86400.0, "s"};
inline constexpr ValidRange kBitrateKbitS{10.0, 1000.0, "kbit/s"};  ///< classic CAN; or 0: the interface's
}  // namespace ranges

/// Throws sph::Error naming the option when a value is out of its range or the options do not go
/// together: neither or both of iface and replay_path ("give either --iface (live) or --replay (a
/// candump log)"), replay_iface without a replay, master flags that contradict each other
/// ("--no-nmt: --configure-pdo needs NMT"), the devices (DevicesConfig()).
void CheckAcquisitionOptions(const AcquisitionOptions& options);

/// The pipeline configuration of `options`: the devices, the mode, the setup, the standstill,
/// and the SYNC period (without sync_period_ms, 0 for a replay or a followed producer: as
/// observed). Throws sph::Error as CheckAcquisitionOptions() does.
PipelineConfig AcquisitionPipelineConfig(const AcquisitionOptions& options);

/// The load of the SYNC cycle on a bus of `bitrate_bit_s` (0: not known: nothing is checked).
/// Where the acquisition produces SYNC: without sync_period_ms, `pipeline`'s period becomes the
/// one DefaultSyncPeriodS() chooses; a period whose load is over the bus's capacity throws
/// sph::Error naming --sync-period-ms and the shortest period it can carry. Returns a warning when
/// the load is over half the capacity ("" otherwise).
std::string CheckBusLoad(const AcquisitionOptions& options, PipelineConfig* pipeline, double bitrate_bit_s);

/// The master's configuration of `options`, its nodes from `pipeline`, its messages naming the
/// options (--theta-counts-per-rev). Throws sph::Error on contradicting master flags.
MasterConfig AcquisitionMasterConfig(const AcquisitionOptions& options, const PipelineConfig& pipeline);

/// The points file's header of `options` without metadata: R0, d, and the setup's mount rotation
/// and other sphere's radius.
PointsHeader AcquisitionHeader(const AcquisitionOptions& options);

/// How the acquisition writes its points file (the t_s and setup columns, the fsync interval).
PointsWriterOptions AcquisitionPointsOptions(const AcquisitionOptions& options);

enum class AcquisitionStatus {
  kOk,              ///< stopped cleanly (the log's end, a stop, duration_s) with no sample lost
  kSamplesLost,     ///< stopped cleanly, but samples were lost (see the counts)
  kBadInput,        ///< the options, the replayed log, or an output that is an input
  kOutputError,     ///< an output cannot be continued or written (everything written before is intact)
  kInterfaceError,  ///< the CAN interface cannot be used (no such interface, no CAN support)
  kStartRefused,    ///< a device did not answer or does not match the configuration: no output made
  kNodeLost,        ///< a node left operational mid-run and was not back within the return timeout:
                    ///< the outputs are finished cleanly up to that point
};

/// What a run made and counted.
struct AcquisitionResult {
  AcquisitionStatus status = AcquisitionStatus::kOk;
  std::string error;  ///< why the run failed (every status but kOk and kSamplesLost); also logged
  /// The checks passed and the session was made: the counts below are its.
  bool ran = false;
  bool acquired = false;  ///< the devices were started and the outputs opened
  PipelineCounts counts;  ///< the pipeline's, from the start of the acquisition
  Mode mode = Mode::kStream;
  bool master_used = false;  ///< the master sent NMT commands or SDO requests
  CanopenMaster::Counts master;
  bool outputs_opened = false;      ///< the points file (and the frame log) were opened
  std::string output_path;          ///< the points file
  std::uint64_t rows_written = 0;   ///< rows this run wrote into it
  bool frame_log = false;           ///< a frame log was written
  std::uint64_t frames_logged = 0;  ///< frames this run wrote into it
  std::uint64_t losses = 0;         ///< samples lost (PipelineCounts::Losses())
  /// The nodes no frame came from during the run ("node 3 (probe)"): with --no-sdo a node that is
  /// not there is started without a word.
  std::vector<std::string> never_heard;
  /// What the operator must know about the outcome, also logged as warnings: samples lost, a run
  /// stopped before the devices were started, an incomplete line of an earlier run cut off.
  std::vector<std::string> warnings;
};

/// The summary of `result`, as sph_acquired prints it after "summary: ": the counts (several
/// lines: "frames 1234, SYNC 300, cycles 300, samples 299\nlost: ...") and the master's, then,
/// when outputs were opened, "points.txt: 299 rows written, frame log 1234 frames".
std::vector<std::string> SummaryLines(const AcquisitionResult& result);

/// What the run tells while it runs.
struct AcquisitionHooks {
  /// Each log line (filter by level as wanted): the start, the devices' events, every loss.
  std::function<void(LogLevel, const std::string&)> log;
  /// The result so far: when RunControl::summary was set, and once at the end of a run that
  /// ran (before the final warnings are logged).
  std::function<void(const AcquisitionResult&)> summary;
};

/// Acquires live from options.iface (SocketCAN) until stopped (RunControl::stop, duration_s, a
/// refused start, an output error). In kProduce mode the SYNC is sent every sync period once the
/// devices run. A lost interface is waited for and reopened. Never throws for bad input: the
/// result says.
AcquisitionResult LiveAcquisition(const AcquisitionOptions& options, RunControl& control,
                                  const AcquisitionHooks& hooks);

/// Replays options.replay_path: the frames of one interface (replay_iface, or the log's only
/// one), at replay_speed, through the same session, so that the replay of a live run's frame log
/// makes the same points file. A log without the master's NMT commands or SDO requests (another
/// master ran the bus, or sph_cansim wrote it) is replayed as with no_nmt or no_sdo. Never throws
/// for bad input: the result says.
AcquisitionResult ReplayAcquisition(const AcquisitionOptions& options, RunControl& control,
                                    const AcquisitionHooks& hooks);

}  // namespace sph::can

#endif  // SPH_CAN_ACQUISITION_HPP_
