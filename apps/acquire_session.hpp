// One run of sph_acquired, live or replayed: the CANopen master and the acquisition pipeline on
// the same frames, and the outputs. The live loop and the replay feed it frames (with their
// receive times) and time; it is the same code for both, so that the replay of a run's frame log
// makes the same points file.
//
//   start:     the master starts, checks and identifies the devices; frames are kept in memory
//   acquiring: once every node runs, the points file is opened with the devices' identity in its
//              header, the frame log with the frames kept so far; the pipeline gets every frame
//   failed:    the start was refused (exit 5: no output is made) or an output failed (exit 3)
#ifndef SPH_APPS_ACQUIRE_SESSION_HPP_
#define SPH_APPS_ACQUIRE_SESSION_HPP_

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "acquire_cmd.hpp"
#include "sph/can/candump_log.hpp"
#include "sph/can/master.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/core/error.hpp"
#include "sph/core/points_writer.hpp"

namespace sph::apps {

/// A failed write of the points file or the frame log (exit code 3).
class OutputError : public Error {
 public:
  using Error::Error;
};

class AcquireSession {
 public:
  enum class State { kStarting, kAcquiring, kStartRefused, kOutputFailed };

  /// `source` names the input in the header ("CAN interface can0", "replay of frames.log");
  /// `iface` is the interface the frames come from, named in the frame log's lines.
  AcquireSession(const AcquireOptions& options, const can::PipelineConfig& pipeline, can::MasterConfig master,
                 const Logger& log, std::string source, std::string iface);
  ~AcquireSession();
  AcquireSession(const AcquireSession&) = delete;
  AcquireSession& operator=(const AcquireSession&) = delete;

  /// Where the master's frames go (live: the socket); without it they go nowhere (replay).
  void set_send(std::function<void(const can::CanFrame&)> send) { send_ = std::move(send); }
  /// Starts the master at `now_ns`.
  void Begin(std::int64_t now_ns);
  /// A received frame (own ones included), in receive order; its time is taken to the
  /// microsecond, as the frame log keeps it. Throws OutputError.
  void OnFrame(const can::CanFrame& frame);
  /// Timeouts. Throws OutputError.
  void OnTime(std::int64_t now_ns);
  void OnRxOverflow(std::uint64_t drops, std::int64_t now_ns);
  void OnMalformedInput(const std::string& what);
  void OnLinkEvent(const std::string& what, std::int64_t now_ns);
  /// Flushes the frame log, syncs the outputs when due. Throws OutputError.
  void FlushOutputs();
  /// The end: the pipeline's last cycle and stop, the outputs closed. Throws OutputError.
  void Finish();
  /// Closes the outputs after an output error, reporting nothing more.
  void Abandon();

  State state() const { return state_; }
  bool acquiring() const { return state_ == State::kAcquiring; }
  /// The master's next timeout (INT64_MAX: none).
  std::int64_t NextDeadline() const { return master_.NextDeadline(); }
  const can::CanopenMaster& master() const { return master_; }
  /// Null before the acquisition began.
  const can::AcquisitionPipeline* pipeline() const { return pipeline_.get(); }
  /// "frames ..., SYNC ..." and the master's counts, for the summary.
  std::string Summary() const;
  /// "points.txt: 1234 rows written, frame log 5678 frames"; "" before the outputs are open.
  std::string OutputSummary() const;
  /// Samples lost (the pipeline's Losses()).
  std::uint64_t Losses() const;

 private:
  void Advance(std::int64_t now_ns);
  bool OpenOutputs();
  void StartAcquisition(std::int64_t now_ns);

  const AcquireOptions& options_;
  const Logger& log_;
  can::PipelineConfig pipeline_config_;
  std::string source_;
  std::string iface_;
  std::function<void(const can::CanFrame&)> send_;
  can::CanopenMaster master_;
  std::unique_ptr<can::AcquisitionPipeline> pipeline_;
  std::unique_ptr<PointsWriter> points_;
  std::unique_ptr<can::CandumpWriter> frame_log_;
  std::vector<can::CanFrame> early_frames_;  ///< received before the acquisition began
  std::uint64_t early_dropped_ = 0;
  State state_ = State::kStarting;
};

}  // namespace sph::apps

#endif  // SPH_APPS_ACQUIRE_SESSION_HPP_
