// What RunAcquire hands to its live and replay loops.
#ifndef SPH_APPS_ACQUIRE_INTERNAL_HPP_
#define SPH_APPS_ACQUIRE_INTERNAL_HPP_

#include <functional>
#include <memory>
#include <ostream>

#include "acquire_cmd.hpp"
#include "acquire_session.hpp"
#include "sph/can/candump_log.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/core/error.hpp"
#include "sph/core/points_writer.hpp"

namespace sph::apps {

struct AcquireContext {
  const AcquireOptions& options;
  const Logger& log;
  const can::PipelineConfig& pipeline_config;
  const can::MasterConfig& master_config;
  SignalFlags& signals;
  /// The session of the run; RunLive and RunReplay make it (the replay adapts the master's
  /// configuration to what the log holds).
  std::unique_ptr<AcquireSession> session;
  std::function<void()> print_summary;
};

/// Live acquisition from a SocketCAN interface. Returns kExitOk, kExitInterfaceError or
/// kExitBadInput; the session's state tells a refused start or an output error.
int RunLive(AcquireContext& context);
/// Replay of a candump log. Returns kExitOk or kExitBadInput (unreadable log).
int RunReplay(AcquireContext& context);
/// How sph_acquired writes its points file.
PointsWriterOptions AcquirePointsOptions(const AcquireOptions& options);
/// The points file's header of the options: R0, d and the setup's mount rotation (no metadata);
/// throws sph::Error naming --mount-rotation-deg when it is not "rx,ry,rz" or "unknown".
PointsHeader AcquireHeader(const AcquireOptions& options);
/// Why `path` cannot be replayed ("log.txt: cannot open for reading: ...", "log.txt: no CAN frame
/// in its 12 lines: ...", "log.txt:9: the time 1700000000.010000 s is before the 1700000000.020000 s of
/// line 8: a candump log is in time order"), or "" when it can be opened, holds at least one frame
/// and its frames' times never go back.
std::string CheckReplayLog(const std::string& path);

}  // namespace sph::apps

#endif  // SPH_APPS_ACQUIRE_INTERNAL_HPP_
