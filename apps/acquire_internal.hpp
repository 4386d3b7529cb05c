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
  /// Replay: what the log holds and which interface is replayed (CheckReplayLog).
  can::ReplaySource replay;
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

}  // namespace sph::apps

#endif  // SPH_APPS_ACQUIRE_INTERNAL_HPP_
