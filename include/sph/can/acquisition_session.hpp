// One acquisition, live or replayed: the CANopen master and the acquisition pipeline on the same
// frames, and the outputs. The live loop and the replay (sph/can/acquisition.hpp) feed it frames
// (with their receive times) and time; it is the same code for both, so that the replay of a run's
// frame log makes the same points file. A host with a CAN driver of its own drives it the same way.
//
//   start:     the master starts, checks and identifies the devices; frames are kept in memory
//   acquiring: once every node runs, the points file is opened with the devices' identity in its
//              header, the frame log with the frames kept so far; the pipeline gets every frame
//   failed:    the start was refused (no output is made) or an output failed
//   node lost: a node left operational mid-run and did not come back (the outputs are finished)
#ifndef SPH_CAN_ACQUISITION_SESSION_HPP_
#define SPH_CAN_ACQUISITION_SESSION_HPP_

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sph/can/acquisition.hpp"
#include "sph/can/candump_log.hpp"
#include "sph/can/master.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/core/error.hpp"
#include "sph/io/points_writer.hpp"

namespace sph::can {

/// A failed write of the points file or the frame log.
class OutputError : public Error {
 public:
  using Error::Error;
};

class AcquisitionSession {
 public:
  enum class State { kStarting, kAcquiring, kStartRefused, kOutputFailed, kNodeLost };
  using Log = std::function<void(LogLevel, const std::string&)>;

  /// `options` (kept by reference: it must outlive the session) give the outputs and the header;
  /// `pipeline` and `master` are their configurations (AcquisitionPipelineConfig(),
  /// AcquisitionMasterConfig(): a replay adapts the master's to what the log holds). `source`
  /// names the input in the header ("CAN interface can0", "replay of frames.log"); `iface` is the
  /// interface the frames come from, named in the frame log's lines.
  AcquisitionSession(const AcquisitionOptions& options, const PipelineConfig& pipeline, MasterConfig master, Log log,
                     std::string source, std::string iface);
  ~AcquisitionSession();
  AcquisitionSession(const AcquisitionSession&) = delete;
  AcquisitionSession& operator=(const AcquisitionSession&) = delete;

  /// Where the master's frames go (live: the socket); without it they go nowhere (replay).
  void set_send(std::function<void(const CanFrame&)> send) { send_ = std::move(send); }
  /// Starts the master at `now_ns`.
  void Begin(std::int64_t now_ns);
  /// A received frame (own ones included), in receive order; its time is taken to the
  /// microsecond, as the frame log keeps it. Throws OutputError.
  void OnFrame(const CanFrame& frame);
  /// Timeouts. Throws OutputError.
  void OnTime(std::int64_t now_ns);
  void OnRxOverflow(std::uint64_t drops, std::int64_t now_ns);
  void OnMalformedInput(const std::string& what);
  void OnLinkEvent(const std::string& what, std::int64_t now_ns);
  /// A frame (`what`: "SYNC") was not sent: the transmit queue was full.
  void OnTxQueueFull(const std::string& what, std::int64_t now_ns);
  /// Flushes the frame log, syncs the outputs when due. Throws OutputError.
  void FlushOutputs();
  /// The end: the pipeline's last cycle and stop, the outputs closed. Throws OutputError.
  void Finish();
  /// Closes the outputs after an output error, reporting nothing more.
  void Abandon();
  /// After a start that was refused (done by the session itself) or stopped before it completed:
  /// sends CanopenMaster::UndoStart()'s frames, so that the bus is left as found, and logs them.
  void UndoStart();

  State state() const { return state_; }
  bool acquiring() const { return state_ == State::kAcquiring; }
  /// Whether the run can go no further: a refused start, a failed output, a node lost.
  bool ended() const {
    return state_ == State::kStartRefused || state_ == State::kOutputFailed || state_ == State::kNodeLost;
  }
  /// The master's next timeout (INT64_MAX: none).
  std::int64_t NextDeadline() const { return master_.NextDeadline(); }
  const CanopenMaster& master() const { return master_; }
  /// Null before the acquisition began.
  const AcquisitionPipeline* pipeline() const { return pipeline_.get(); }
  /// The counts and outputs so far (status kOk; the run sets status, error and warnings).
  AcquisitionResult Result() const;
  /// Samples lost (the pipeline's Losses()).
  std::uint64_t Losses() const;
  /// Warnings about the outputs opened (an incomplete line of an earlier run cut off, frames of
  /// the start that the frame log misses), also logged.
  const std::vector<std::string>& warnings() const { return warnings_; }
  /// Why the session failed (kStartRefused: the master's errors, one a line; kOutputFailed: the
  /// output that could not be opened; kNodeLost: the node that did not come back); "" otherwise.
  const std::string& error() const { return error_; }

 private:
  void Advance(std::int64_t now_ns);
  bool OpenOutputs();
  void StartAcquisition(std::int64_t now_ns);
  void Warn(const std::string& text);

  const AcquisitionOptions& options_;
  Log log_;
  PipelineConfig pipeline_config_;
  std::string source_;
  std::string iface_;
  std::function<void(const CanFrame&)> send_;
  CanopenMaster master_;
  std::unique_ptr<AcquisitionPipeline> pipeline_;
  std::unique_ptr<PointsWriter> points_;
  std::unique_ptr<CandumpWriter> frame_log_;
  std::vector<CanFrame> early_frames_;  ///< received before the acquisition began
  std::uint64_t early_dropped_ = 0;
  std::int64_t now_ns_ = 0;  ///< the time of the frame or timeout being handled
  std::vector<std::string> warnings_;
  std::string error_;
  State state_ = State::kStarting;
};

}  // namespace sph::can

#endif  // SPH_CAN_ACQUISITION_SESSION_HPP_
