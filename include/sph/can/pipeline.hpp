// The acquisition pipeline: CANopen frames in, samples (or averaged stop points) out. It knows
// nothing of sockets or files, so the daemon, the replay and the tests drive the same code.
//
// One SYNC cycle gives one sample, timed by the SYNC's receive time:
//
//   SYNC(t) ... TPDO theta ... TPDO phi ... TPDO probe ... SYNC(t + T) ...
//   \______________ window: the PDOs after SYNC(t) _____________/
//
// A window is resolved when the next SYNC arrives (or at the end). SYNCs that never arrived are
// found by the SYNC counter and by the time; a window that spans several cycles is split by the
// period each PDO arrived in, or by the SYNC counter a device maps into its PDO. A cycle with
// exactly one valid PDO of every device is a sample (where the devices carry the counter, a PDO may
// come up to one period late; a SYNC repeated with its counter is taken once); any other has no
// sample for the devices it lacks, is counted per device and reason, logged and written into the
// points file as a comment, never filled from a neighbouring cycle. A boot-up message of a
// device's node, or its heartbeat leaving operational, opens a gap mark. What the bus and the
// nodes tell (EMCY, error frames, heartbeats lost and back, state changes, a full transmit queue)
// is written as a comment at its place among the rows; a node's error state (an EMCY with its
// error register set, until its error reset) is marked where it starts and ends.
// The rules in full: docs/method/acquisition.md.
#ifndef SPH_CAN_PIPELINE_HPP_
#define SPH_CAN_PIPELINE_HPP_

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sph/can/canopen.hpp"
#include "sph/can/frame.hpp"
#include "sph/can/standstill.hpp"
#include "sph/io/points_file.hpp"

namespace sph::can {

enum Device : int { kTheta = 0, kPhi = 1, kProbe = 2, kNumDevices = 3 };
const char* DeviceName(int device);

enum class Mode { kStream, kPoints };
/// "stream", "points".
const char* ToString(Mode mode);

enum class LogLevel : int { kError = 0, kWarning = 1, kInfo = 2, kDebug = 3 };
const char* ToString(LogLevel level);

struct PipelineConfig {
  EncoderConfig theta{1, {0x181, 0, 4, false, false}, 1U << 24, 1, 0, false};
  EncoderConfig phi{2, {0x182, 0, 4, false, false}, 1U << 24, 1, 0, false};
  ProbeConfig probe;  ///< node 3, TPDO 0x183 by default
  std::uint32_t sync_cob_id = kSyncCobId;
  std::uint8_t sync_counter_max = 0;  ///< SYNC counter overflow value (2..240); 0: no counter
  double sync_period_s = 0.0;         ///< expected SYNC period for gap detection; 0: unknown
  double heartbeat_timeout_s = 0.0;   ///< a node silent longer than this is lost; 0: not watched
  /// Per device: the PDO byte that holds the counter of the SYNC it answers (the device maps it);
  /// -1: none. Needs sync_counter_max.
  std::array<int, kNumDevices> sync_counter_byte{-1, -1, -1};
  Mode mode = Mode::kStream;
  StandstillConfig standstill;
  int setup = 0;  ///< sphere placement id written with each sample

  /// Throws sph::Error on an inconsistent configuration (bad layouts, two devices on one id).
  void Validate() const;
};

/// Everything the pipeline counted. A sample is lost only if it is in incomplete_cycles or
/// missed_syncs; the other counts explain why.
struct PipelineCounts {
  std::uint64_t frames = 0;  ///< every frame given to OnFrame
  std::uint64_t sync_frames = 0;
  std::uint64_t cycles = 0;   ///< SYNC cycles closed, those of missed SYNCs included
  std::uint64_t samples = 0;  ///< complete cycles (stream mode: rows written)
  std::uint64_t incomplete_cycles = 0;
  std::uint64_t missed_syncs = 0;                      ///< SYNCs that never arrived (counter or time gaps)
  std::uint64_t recovered = 0;                         ///< of those, cycles whose PDOs all came: samples
  std::uint64_t counter_jumps = 0;                     ///< SYNC counters that jumped further than the time allows
  std::uint64_t repeated_syncs = 0;                    ///< SYNCs received twice (taken once)
  std::uint64_t sync_counter_errors = 0;               ///< SYNC counters outside 1..max or missing (not used)
  std::array<std::uint64_t, kNumDevices> missing{};    ///< cycles without a frame from the device
  std::array<std::uint64_t, kNumDevices> flagged{};    ///< values out of range or device errors
  std::array<std::uint64_t, kNumDevices> malformed{};  ///< frames too short for the configured field
  std::uint64_t duplicates = 0;                        ///< a second PDO of one device in one cycle (neither used)
  std::uint64_t unplaced = 0;                          ///< PDOs after lost frames, or of a SYNC outside the window
  std::uint64_t outside_cycle = 0;                     ///< PDOs before the first SYNC
  std::uint64_t malformed_other = 0;                   ///< bad SYNC, heartbeat or EMCY frames, unparsable log lines
  std::uint64_t error_frames = 0;
  std::uint64_t bus_off = 0;
  std::uint64_t emergencies = 0;
  std::uint64_t heartbeats_lost = 0;
  std::uint64_t not_operational = 0;    ///< a node's heartbeat left the operational state
  std::uint64_t heartbeats_back = 0;    ///< heartbeats that came back after being lost
  std::uint64_t error_states = 0;       ///< nodes that entered an error state (EMCY, register set)
  std::uint64_t error_state_rows = 0;   ///< rows written while a device's node was in an error state
  std::uint64_t tx_queue_full = 0;      ///< frames not sent: the transmit queue was full
  std::uint64_t reboots = 0;            ///< boot-up messages of the devices' nodes (gap marks)
  std::uint64_t rx_overflow_drops = 0;  ///< frames the kernel dropped (SO_RXQ_OVFL)
  std::uint64_t other_frames = 0;       ///< frames of no configured device
  std::uint64_t points = 0;             ///< points mode: averaged points written
  std::uint64_t short_stops = 0;        ///< points mode: stops too short to average
  std::uint64_t cut_by_stop = 0;        ///< the last cycle, unfinished at the end of the acquisition

  /// incomplete_cycles + missed_syncs - recovered + rx_overflow_drops: nonzero means samples are
  /// missing.
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
  /// A frame (`what`: "SYNC") was not sent at `now_ns`: the transmit queue was full. Counted, noted.
  void OnTxQueueFull(const std::string& what, std::int64_t now_ns);
  /// A comment of an event at `t_ns` (the master's), written at its place among the rows.
  void AddEvent(std::int64_t t_ns, const std::string& text);
  /// End of the acquisition (a stop, --duration-s, the end of a replayed log): resolves the open
  /// window and closes the open stop, reports pending incomplete runs. The last cycle, whose
  /// PDOs may simply have come after the end, is a sample when complete, else noted as cut by
  /// the end and counted in cut_by_stop, not as incomplete. A live run stopped by a signal and
  /// the replay of its frame log so end alike.
  void Finish();

  const PipelineCounts& counts() const { return counts_; }
  const PipelineConfig& config() const { return config_; }

 private:
  static constexpr std::size_t kMaxPdosPerWindow = 64;
  static constexpr std::uint64_t kMaxRecovered = 64;  ///< missed cycles of one window placed at most
  struct Arrival {
    DecodeStatus status = DecodeStatus::kOk;
    double value = 0.0;
    std::int64_t t_ns = 0;
    int counter = -1;  ///< the SYNC counter the PDO carries, -1: none
  };
  struct Window {
    bool open = false;
    std::int64_t t_ns = 0;
    std::optional<std::uint8_t> counter;
    bool tainted = false;  ///< frames were lost while it was open
    std::array<std::vector<Arrival>, kNumDevices> pdos;
  };
  /// What one cycle of a resolved window has of a device.
  struct Slot {
    int index = -1;     ///< into the window's PDOs of the device; -1 none
    int count = 0;      ///< PDOs placed in the cycle
    bool lost = false;  ///< placed after lost frames: unusable
  };
  struct IncompleteRun {
    std::uint64_t cycles = 0;
    std::int64_t first_ns = 0, last_ns = 0;
    std::string reason;
  };
  /// A node's error state: from its EMCY to its error reset; the rows of that time.
  struct ErrorSpan {
    std::int64_t since_ns = 0;
    std::int64_t end_ns = std::numeric_limits<std::int64_t>::max();
    std::uint64_t rows = 0;
  };
  struct Node {
    int node_id = 0;
    std::string name;
    std::int64_t last_ns = 0;
    std::int64_t lost_since_ns = 0;  ///< its last heartbeat (or the start) when it was lost
    bool seen = false, lost = false;
    std::uint8_t state = static_cast<std::uint8_t>(NmtState::kOperational);
    /// Its error states whose rows may still be written (the last one open: in an error state).
    std::vector<std::shared_ptr<ErrorSpan>> errors;
    bool InError() const {
      return !errors.empty() && errors.back()->end_ns == std::numeric_limits<std::int64_t>::max();
    }
  };
  struct Gap {
    bool open = false;
    std::int64_t start_ns = 0;
    std::uint64_t missing_cycles = 0;  ///< cycles since without a PDO of the device
    const char* cause = "its reboot";  ///< "it left operational"
  };
  struct PendingNote {
    std::int64_t t_ns = 0;
    std::string text;
    std::shared_ptr<ErrorSpan> span;  ///< an error state's end: its rows are told when written
  };

  void OnSync(const CanFrame& frame, SyncInfo sync);
  /// The SYNC's counter if it is one the producer can send, else none (warned about).
  std::optional<std::uint8_t> UsableCounter(const CanFrame& frame, const SyncInfo& sync);
  /// Whether the SYNC is the one before received again (same counter, within half a period).
  bool Repeats(const CanFrame& frame, const SyncInfo& sync) const;
  /// Resolves the held window (see the file comment); its late PDOs can no longer come.
  void ResolveHeld();
  /// Period for gap detection [s]: configured, else as observed (0: not known yet).
  double PeriodS() const;
  void OnPdo(int device, const CanFrame& frame);
  /// Resolves the open window into 1 + `missed` cycles; `next_ns` is the next SYNC's time. With
  /// `last` (the end) an incomplete cycle is cut, not counted as incomplete.
  void Resolve(std::uint64_t missed, std::int64_t next_ns, bool last = false);
  using Cycles = std::vector<std::array<Slot, kNumDevices>>;
  void PlaceArrivals(std::uint64_t missed, double period, bool placeable, Cycles& cycles);
  void CountDuplicates(const Cycles& cycles);
  void ResolveReceived(const std::array<Slot, kNumDevices>& slots, bool last);
  void ResolveMissed(const Cycles& cycles, std::uint64_t missed, std::int64_t next_ns, double period);
  /// SYNCs missed before `frame` (see the file comment); remembers the period it observes.
  std::uint64_t MissedBefore(const CanFrame& frame, const SyncInfo& sync);
  /// Why a cycle with these slots is no sample ("theta no frame, probe 2 PDOs"); "" for a sample.
  std::string Reason(const std::array<Slot, kNumDevices>& slots) const;
  void EmitCycle(const std::array<Slot, kNumDevices>& slots, std::int64_t t_ns);
  /// Gap end marks for rebooted devices that have a PDO in this cycle.
  void CloseGaps(const std::array<Slot, kNumDevices>& slots, std::int64_t t_ns);
  /// Gap start marks for the devices of `node` ("rebooted (boot-up message)" etc.).
  void OpenGaps(const Node& node, std::int64_t t_ns, const char* cause, const std::string& what);
  void OnHeartbeat(Node& node, const CanFrame& frame, std::uint8_t state);
  void OnEmergency(Node& node, const Emergency& emcy, std::int64_t t_ns);
  void EndErrorState(Node& node, std::int64_t t_ns, const std::string& why);
  /// A comment at `t_ns`, written before the first row after it (see FlushEvents).
  void NoteAt(std::int64_t t_ns, const std::string& text);
  /// Writes the events before `t_ns` (after the incomplete cycles before them).
  void FlushEvents(std::int64_t t_ns);
  /// A row of time `t_ns` written: counted for the error states it lies in.
  void RowWritten(std::int64_t t_ns);
  void EmitPoint(const StopPoint& point);
  void NoteIncomplete(const std::string& reason, std::int64_t t_ns);
  void FlushIncomplete();
  bool OnHealthFrame(const CanFrame& frame);  // heartbeat, EMCY, error frame
  void CheckHeartbeats(std::int64_t now_ns);
  void Log(LogLevel level, const std::string& text);
  /// Logs the first 20 of a kind, then every 1000th, so floods stay readable; `text()` makes the
  /// line, only for a line logged (a flood of frames costs no text).
  template <typename Text>
  void LogLimited(std::uint64_t count, LogLevel level, const Text& text) {
    if (cb_.log && (count <= 20 || count % 1000 == 0)) LogCounted(count, level, text());
  }
  void LogCounted(std::uint64_t count, LogLevel level, const std::string& text);
  /// Whether a cycle with these slots is a sample (Reason() is "").
  static bool Complete(const std::array<Slot, kNumDevices>& slots, const Window& window);
  void Note(const std::string& text);

  PipelineConfig config_;
  Callbacks cb_;
  PipelineCounts counts_;
  Window window_;
  /// Where the devices carry the SYNC counter: the window before, held open for its late PDOs
  /// until the next SYNC, with the SYNCs missed after it and the time of the SYNC that closed it.
  bool hold_ = false;
  Window held_;
  std::uint64_t held_missed_ = 0;
  std::int64_t held_next_ns_ = 0;
  bool counter_unconfigured_warned_ = false;
  std::vector<std::array<Slot, kNumDevices>> scratch_;  ///< the cycles of the window being resolved
  IncompleteRun run_;
  std::array<Gap, kNumDevices> gaps_{};
  std::optional<std::uint8_t> last_counter_;
  std::int64_t last_sync_ns_ = 0;
  std::int64_t observed_period_ns_ = 0;  ///< the last interval between two SYNCs that followed
  bool have_sync_ = false;
  std::int64_t start_ns_ = 0;
  std::vector<Node> nodes_;
  std::vector<PendingNote> events_;  ///< comments waiting for their place among the rows
  std::optional<StandstillDetector> stops_;
};

}  // namespace sph::can

#endif  // SPH_CAN_PIPELINE_HPP_
