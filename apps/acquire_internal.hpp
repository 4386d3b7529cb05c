// What RunAcquire hands to its live and replay loops.
#ifndef SPH_APPS_ACQUIRE_INTERNAL_HPP_
#define SPH_APPS_ACQUIRE_INTERNAL_HPP_

#include <functional>
#include <ostream>

#include "acquire_cmd.hpp"
#include "sph/can/candump_log.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/core/error.hpp"
#include "sph/core/points_writer.hpp"

namespace sph::apps {

/// A failed write of the points file or the frame log (exit code 3).
class OutputError : public Error {
 public:
  using Error::Error;
};

struct AcquireContext {
  const AcquireOptions& options;
  const Logger& log;
  can::AcquisitionPipeline& pipeline;
  PointsWriter& points;
  can::CandumpWriter* frame_log;  ///< nullptr: none
  SignalFlags& signals;
  std::function<void()> print_summary;

  /// Frame log append; throws OutputError.
  void LogFrame(const can::CanFrame& frame);
  /// Flushes the frame log, syncs both files when due; throws OutputError.
  void FlushOutputs();
};

/// Live acquisition from a SocketCAN interface. Returns kExitOk or kExitInterfaceError.
int RunLive(AcquireContext& context);
/// Replay of a candump log. Returns kExitOk or kExitBadInput (unreadable log).
int RunReplay(AcquireContext& context);
/// Why `path` cannot be replayed ("log.txt: cannot open for reading: ...", "log.txt: no CAN frame
/// in its 12 lines: ..."), or "" when it can be opened and holds at least one frame.
std::string CheckReplayLog(const std::string& path);

}  // namespace sph::apps

#endif  // SPH_APPS_ACQUIRE_INTERNAL_HPP_
