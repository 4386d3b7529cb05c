// The acquisition's workflow: the checks before anything is made, the live or replay loop, the end.
#include "sph/can/acquisition.hpp"

#include <exception>
#include <string>
#include <vector>

#include "acquisition_internal.hpp"
#include "sph/can/candump_log.hpp"
#include "sph/core/error.hpp"
#include "sph/io/output_files.hpp"

namespace sph::can {
namespace {

// The result of a run that ended before its session began.
AcquisitionResult Failed(const AcquisitionOptions& o, const AcquisitionHooks& hooks, AcquisitionStatus status,
                         const std::string& error) {
  if (hooks.log) hooks.log(LogLevel::kError, error);
  AcquisitionResult r;
  r.status = status;
  r.error = error;
  r.mode = o.mode;
  r.output_path = o.output_path;
  return r;
}

// The checks before any output is made: the options, the paths, the replayed log, the outputs as
// they are now (a file that this run may not continue stays as it is). Returns kOk or the status
// of the failure, with its message in `error`.
AcquisitionStatus CheckBeforeRun(const AcquisitionOptions& o, bool live, PipelineConfig* pipeline, MasterConfig* master,
                                 ReplaySource* replay, std::string* error) {
  try {
    CheckAcquisitionOptions(o);
    if (live && o.iface.empty()) throw Error("--replay " + o.replay_path + ": this is a live acquisition (--iface)");
    if (!live && o.replay_path.empty()) throw Error("--iface " + o.iface + ": this is a replay (--replay)");
    *pipeline = AcquisitionPipelineConfig(o);
    *master = AcquisitionMasterConfig(o, *pipeline);
    RunPaths paths;
    for (const auto& [option, path] : o.option_files) paths.Input(option, path);
    paths.Input("--replay", o.replay_path);
    paths.Output("--output", o.output_path).Output("--can-log", o.can_log_path);
    // A log that cannot be read, holds no frame, holds several interfaces' frames and none
    // chosen, or goes back in time.
    if (!live) *replay = CheckReplayLog(o.replay_path, o.replay_iface, "--replay-iface");
  } catch (const std::exception& e) {
    *error = e.what();
    return AcquisitionStatus::kBadInput;
  }
  try {
    PointsWriter::CheckContinuable(o.output_path, AcquisitionHeader(o), AcquisitionPointsOptions(o));
    if (!o.can_log_path.empty()) CandumpWriter::CheckContinuable(o.can_log_path);
  } catch (const std::exception& e) {
    *error = e.what();
    return AcquisitionStatus::kOutputError;
  }
  return AcquisitionStatus::kOk;
}

// The loop, then the end of the session: the status, the summary, the warnings.
AcquisitionResult RunSession(AcquisitionContext& ctx, bool live) {
  AcquisitionStatus status = AcquisitionStatus::kOk;
  AcquisitionSession* session = nullptr;
  try {
    status = live ? RunLive(ctx) : RunReplay(ctx);
    session = ctx.session.get();
    if (session != nullptr && session->state() == AcquisitionSession::State::kOutputFailed) {
      status = AcquisitionStatus::kOutputError;
    } else if (session != nullptr && session->state() == AcquisitionSession::State::kStartRefused) {
      status = AcquisitionStatus::kStartRefused;
    } else if (session != nullptr) {
      session->Finish();
      if (session->state() == AcquisitionSession::State::kNodeLost) status = AcquisitionStatus::kNodeLost;
    }
  } catch (const OutputError& e) {
    session = ctx.session.get();
    ctx.Fail(AcquisitionStatus::kOutputError, std::string(e.what()) + " (everything written before is intact)");
    if (session != nullptr) session->Abandon();
    status = AcquisitionStatus::kOutputError;
    ctx.Summary();
  }
  if (session == nullptr) return Failed(ctx.options, {}, status, ctx.error);
  AcquisitionResult r = session->Result();
  r.status = status;
  r.error = session->error().empty() ? ctx.error : session->error();
  if (status == AcquisitionStatus::kOutputError || status == AcquisitionStatus::kStartRefused) return r;
  ctx.Summary();
  const auto warn = [&](const std::string& text) {
    ctx.Log(LogLevel::kWarning, text);
    r.warnings.push_back(text);
  };
  if (status != AcquisitionStatus::kOk) return r;
  if (session->state() == AcquisitionSession::State::kStarting) {
    warn("stopped before the devices were started: no points file was made");
  } else if (r.losses > 0) {
    warn("samples were lost: " + std::to_string(r.losses) + " (see the summary)");
    r.status = AcquisitionStatus::kSamplesLost;
  }
  return r;
}

AcquisitionResult Run(const AcquisitionOptions& o, RunControl& control, const AcquisitionHooks& hooks, bool live) {
  PipelineConfig pipeline;
  MasterConfig master;
  ReplaySource replay;
  std::string error;
  const AcquisitionStatus checked = CheckBeforeRun(o, live, &pipeline, &master, &replay, &error);
  if (checked != AcquisitionStatus::kOk) return Failed(o, hooks, checked, error);
  AcquisitionContext ctx{o, hooks, pipeline, master, control, replay, nullptr, {}};
  return RunSession(ctx, live);
}

}  // namespace

AcquisitionResult LiveAcquisition(const AcquisitionOptions& options, RunControl& control,
                                  const AcquisitionHooks& hooks) {
  return Run(options, control, hooks, true);
}

AcquisitionResult ReplayAcquisition(const AcquisitionOptions& options, RunControl& control,
                                    const AcquisitionHooks& hooks) {
  return Run(options, control, hooks, false);
}

std::vector<std::string> SummaryLines(const AcquisitionResult& r) {
  std::string s = r.acquired ? FormatCounts(r.counts, r.mode) : "no acquisition: the devices were not started";
  if (r.master_used) {
    const CanopenMaster::Counts& m = r.master;
    s += "\nmaster: NMT commands " + std::to_string(m.nmt_commands) + ", SDO transfers " +
         std::to_string(m.sdo_transfers) + ", reboots " + std::to_string(m.boot_ups) + ", restarted " +
         std::to_string(m.restarts) + ", not restarted " + std::to_string(m.restart_failures) +
         ", started without a heartbeat to confirm it " + std::to_string(m.unconfirmed) + ", left operational " +
         std::to_string(m.left_operational) + " (Start sent again " + std::to_string(m.start_retries) + ")";
  }
  if (!r.never_heard.empty()) {
    std::string nodes;
    for (const std::string& n : r.never_heard) nodes += (nodes.empty() ? "" : ", ") + n;
    s += "\nnever heard from: " + nodes;
  }
  std::vector<std::string> lines{s};
  if (r.outputs_opened) {
    std::string out = r.output_path + ": " + std::to_string(r.rows_written) + " rows written";
    if (r.frame_log) out += ", frame log " + std::to_string(r.frames_logged) + " frames";
    lines.push_back(out);
  }
  return lines;
}

}  // namespace sph::can
