// What the acquisition's workflow (acquisition.cpp) hands to its live and replay loops.
#ifndef SPH_CAN_ACQUISITION_INTERNAL_HPP_
#define SPH_CAN_ACQUISITION_INTERNAL_HPP_

#include <memory>
#include <string>

#include "sph/can/acquisition.hpp"
#include "sph/can/acquisition_session.hpp"
#include "sph/can/candump_log.hpp"
#include "sph/can/master.hpp"
#include "sph/can/pipeline.hpp"

namespace sph::can {

struct AcquisitionContext {
  const AcquisitionOptions& options;
  const AcquisitionHooks& hooks;
  PipelineConfig& pipeline_config;  ///< the live run may choose its SYNC period (CheckBusLoad)
  const MasterConfig& master_config;
  RunControl& control;
  /// Replay: what the log holds and which interface is replayed (CheckReplayLog).
  ReplaySource replay;
  /// The session of the run; RunLive and RunReplay make it (the replay adapts the master's
  /// configuration to what the log holds).
  std::unique_ptr<AcquisitionSession> session;
  std::string error;  ///< why the run failed

  void Log(LogLevel level, const std::string& text) const {
    if (hooks.log) hooks.log(level, text);
  }
  /// The summary hook with the session's result so far.
  void Summary() const {
    if (session && hooks.summary) hooks.summary(session->Result());
  }
  /// Logs `text` as an error and keeps it as the run's; returns `status`.
  AcquisitionStatus Fail(AcquisitionStatus status, const std::string& text) {
    Log(LogLevel::kError, text);
    error = text;
    return status;
  }
};

/// Live acquisition from a SocketCAN interface: kOk, or kBadInput, kInterfaceError (Fail()); the
/// session's state tells a refused start or an output error.
AcquisitionStatus RunLive(AcquisitionContext& context);
/// Replay of a candump log: kOk, or kBadInput (an unreadable log).
AcquisitionStatus RunReplay(AcquisitionContext& context);

}  // namespace sph::can

#endif  // SPH_CAN_ACQUISITION_INTERNAL_HPP_
