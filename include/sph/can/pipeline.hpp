// The acquisition pipeline: CANopen frames in, samples (or averaged stop points) out. It knows
// nothing of sockets or files, so the daemon, the replay and the tests drive the same code.
//
// One SYNC cycle gives one sample:
//
//   SYNC(t) ... TPDO theta ... TPDO phi ... TPDO probe ... SYNC(t + T) ...
//   \______________ cycle: values from the PDOs after SYNC(t) _________/
//
// The sample's time is the SYNC's receive time. It is emitted as soon as all three values have
// arrived; a cycle that ends (next SYNC, Finish()) without all three valid values is an
// incomplete cycle: counted per device and reason, logged, and written into the points file as
// a comment (runs of equal incomplete cycles in one comment), never dropped or filled in silence.
// SYNCs that never arrived (a gap in the SYNC counter, or more than 1.5 periods without SYNC)
// are counted as missed cycles and written as a comment too.
#ifndef SPH_CAN_PIPELINE_HPP_
#define SPH_CAN_PIPELINE_HPP_

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "sph/can/canopen.hpp"
#include "sph/can/frame.hpp"
#include "sph/can/standstill.hpp"
#include "sph/core/points_file.hpp"

namespace sph::can {

enum Device : int { kTheta = 0, kPhi = 1, kProbe = 2, kNumDevices = 3 };
const char* DeviceName(int device);

enum class Mode { kStream, kPoints };

enum class LogLevel : int { kError = 0, kWarning = 1, kInfo = 2, kDebug = 3 };
const char* ToString(LogLevel level);

struct PipelineConfig {
  EncoderConfig theta{1, {0x181, 0, 4, false, false}, 1U << 24, 1, 0, false};
  EncoderConfig phi{2, {0x182, 0, 4, false, false}, 1U << 24, 1, 0, false};
  ProbeConfig probe;                     ///< node 3, TPDO 0x183 by default
  std::uint32_t sync_cob_id = kSyncCobId;
  std::uint8_t sync_counter_max = 0;     ///< SYNC counter overflow value (2..240); 0: no counter
  double sync_period_s = 0.0;            ///< expected SYNC period for gap detection; 0: unknown
  double heartbeat_timeout_s = 0.0;      ///< a node silent longer than this is lost; 0: not watched
  Mode mode = Mode::kStream;
  StandstillConfig standstill;
  int setup = 0;                         ///< sphere placement id written with each sample

  /// Throws sph::Error on an inconsistent configuration (bad layouts, two devices on one id).
  void Validate() const;
};

/// Everything the pipeline counted. A sample is lost only if it is in incomplete_cycles or
/// missed_syncs; the other counts explain why.
struct PipelineCounts {
  std::uint64_t frames = 0;              ///< every frame given to OnFrame
  std::uint64_t sync_frames = 0;
  std::uint64_t cycles = 0;              ///< SYNC cycles closed
  std::uint64_t samples = 0;             ///< complete cycles (stream mode: rows written)
  std::uint64_t incomplete_cycles = 0;
  std::uint64_t missed_syncs = 0;        ///< SYNCs that never arrived (counter or time gaps)
  std::array<std::uint64_t, kNumDevices> missing{};   ///< cycles without a frame from the device
  std::array<std::uint64_t, kNumDevices> flagged{};   ///< values out of range or device errors
  std::array<std::uint64_t, kNumDevices> malformed{}; ///< frames too short for the configured field
  std::uint64_t duplicates = 0;          ///< a second PDO of one device in one cycle (first one kept)
  std::uint64_t outside_cycle = 0;       ///< PDOs before the first SYNC
  std::uint64_t malformed_other = 0;     ///< bad SYNC, heartbeat or EMCY frames, unparsable log lines
  std::uint64_t error_frames = 0;
  std::uint64_t bus_off = 0;
  std::uint64_t emergencies = 0;
  std::uint64_t heartbeats_lost = 0;
  std::uint64_t not_operational = 0;     ///< a node's heartbeat left the operational state
  std::uint64_t rx_overflow_drops = 0;   ///< frames the kernel dropped (SO_RXQ_OVFL)
  std::uint64_t other_frames = 0;        ///< frames of no configured device
  std::uint64_t points = 0;              ///< points mode: averaged points written
  std::uint64_t short_stops = 0;         ///< points mode: stops too short to average
  std::uint64_t cut_by_stop = 0;         ///< the last cycle, unfinished when a stop was requested

  /// incomplete_cycles + missed_syncs + rx_overflow_drops: nonzero means samples are missing.
  std::uint64_t Losses() const;
};

/// Multi-line human summary of `counts` ("frames 1234, SYNC 300, samples 299, ...").
std::string FormatCounts(const PipelineCounts& counts, Mode mode);

class AcquisitionPipeline {
 public:
  struct Callbacks {
    std::function<void(const Sample&)> sample;     ///< a row for the points file
    std::function<void(const std::string&)> note;  ///< a comment for the points file
    std::function<void(LogLevel, const std::string&)> log;
  };

  /// Validates `config` (throws sph::Error).
  AcquisitionPipeline(const PipelineConfig& config, Callbacks callbacks);

  void OnFrame(const CanFrame& frame);
  /// Time passes without frames (live mode): heartbeat timeouts are checked against `now_ns`.
  void OnTime(std::int64_t now_ns);
  /// The kernel dropped `drops` frames (SO_RXQ_OVFL): counted and logged.
  void OnRxOverflow(std::uint64_t drops, std::int64_t now_ns);
  /// A log line that is not a frame (replay): counted as malformed and logged.
  void OnMalformedInput(const std::string& what);
  /// The interface went down or came back (live mode): the open cycle is closed, noted in the file.
  void OnLinkEvent(const std::string& what, std::int64_t now_ns);
  /// End of input: closes the open cycle and the open stop, reports pending incomplete runs.
  /// With `stopped` (a requested stop, not the end of the data) an unfinished last cycle is
  /// noted as cut by the stop and counted in cut_by_stop, not as incomplete.
  void Finish(bool stopped = false);

  const PipelineCounts& counts() const { return counts_; }
  const PipelineConfig& config() const { return config_; }

 private:
  struct Cycle {
    bool open = false;
    bool emitted = false;
    std::int64_t t_ns = 0;
    std::array<DecodeStatus, kNumDevices> status{};
    std::array<bool, kNumDevices> seen{};
    std::array<double, kNumDevices> value{};
  };
  struct IncompleteRun {
    std::uint64_t cycles = 0;
    std::int64_t first_ns = 0, last_ns = 0;
    std::string reason;
  };
  struct Node {
    int node_id = 0;
    std::string name;
    std::int64_t last_ns = 0;
    bool seen = false, lost = false;
    std::uint8_t state = static_cast<std::uint8_t>(NmtState::kOperational);
  };

  void OnSync(const CanFrame& frame, const SyncInfo& sync);
  void OnPdo(int device, const CanFrame& frame);
  void CloseCycle();
  void EmitSample();
  void EmitPoint(const StopPoint& point);
  void NoteIncomplete(const std::string& reason, std::int64_t t_ns);
  void FlushIncomplete();
  bool OnHealthFrame(const CanFrame& frame);  // heartbeat, EMCY, error frame
  void CheckHeartbeats(std::int64_t now_ns);
  void Log(LogLevel level, const std::string& text);
  /// Logs the first 20 of a kind, then every 1000th, so floods stay readable.
  void LogLimited(std::uint64_t count, LogLevel level, const std::string& text);
  void Note(const std::string& text);

  PipelineConfig config_;
  Callbacks cb_;
  PipelineCounts counts_;
  Cycle cycle_;
  IncompleteRun run_;
  std::optional<std::uint8_t> last_counter_;
  std::int64_t last_sync_ns_ = 0;
  bool have_sync_ = false;
  std::int64_t start_ns_ = 0;
  std::vector<Node> nodes_;
  std::optional<StandstillDetector> stops_;
};

}  // namespace sph::can

#endif  // SPH_CAN_PIPELINE_HPP_
