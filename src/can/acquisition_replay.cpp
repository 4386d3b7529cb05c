// The replayed acquisition: the master and the pipeline offline, from a candump log: the frames
// of one interface (--replay-iface, or the log's only one), those of others left out. The master
// runs as it did live, its frames going nowhere: the log holds what it sent, and its answers
// drive it. A log without the master's NMT commands or SDO requests (recorded while another
// master ran the bus, or made by sph_cansim -o) is replayed as with --no-nmt or --no-sdo.
#include <time.h>

#include <cerrno>
#include <cstdio>
#include <limits>
#include <optional>

#include "acquisition_internal.hpp"
#include "clock.hpp"
#include "sph/can/candump_log.hpp"
#include "sph/can/canopen.hpp"
#include "sph/can/sdo.hpp"

namespace sph::can {
namespace {

// Sleeps until `mono_ns`, or until a stop is asked (a signal interrupts the sleep).
void SleepUntil(std::int64_t mono_ns, const RunControl& control) {
  timespec ts{static_cast<time_t>(mono_ns / 1000000000), static_cast<long>(mono_ns % 1000000000)};
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    if (control.stop.load() != 0) return;
  }
}

// Whether the log holds NMT commands, and SDO requests to the configured nodes; when the first
// of them came.
struct MasterTraffic {
  bool nmt = false;
  bool sdo = false;
  std::optional<std::int64_t> first_ns;
};
MasterTraffic ScanForMaster(const std::string& path, const std::string& iface, const MasterConfig& master) {
  MasterTraffic t;
  CandumpReader reader(path);
  for (;;) {
    const CandumpReader::Result r = reader.Next();
    if (r.status == CandumpReader::Status::kEnd) break;
    if (r.status != CandumpReader::Status::kFrame || r.iface != iface || r.frame.IsExtended() || r.frame.IsRemote()) {
      continue;
    }
    bool ours = false;
    if (r.frame.id == kNmtCobId && DecodeNmt(r.frame)) ours = t.nmt = true;
    for (const MasterNode& n : master.nodes) {
      if (r.frame.id == kSdoRequestBase + static_cast<std::uint32_t>(n.node_id)) ours = t.sdo = true;
    }
    if (ours && !t.first_ns) t.first_ns = r.frame.t_ns;
    if (t.nmt && t.sdo) break;
  }
  return t;
}

// The master's configuration for the log: as with --no-nmt when the log holds no NMT command, as
// with --no-sdo when it holds no SDO request.
MasterConfig MasterForLog(const AcquisitionContext& ctx, const MasterTraffic& traffic) {
  MasterConfig master = ctx.master_config;
  if (master.nmt && !traffic.nmt) {
    ctx.Log(LogLevel::kDebug, ctx.options.replay_path + ": no NMT command in it: replayed as with --no-nmt");
    master.nmt = false;
    master.configure_pdo = false;
    master.reset_communication = false;
  }
  if (master.sdo && !traffic.sdo) {
    ctx.Log(LogLevel::kDebug, ctx.options.replay_path + ": no SDO request in it: replayed as with --no-sdo");
    master.sdo = false;
    master.configure_pdo = false;
  }
  return master;
}

// The time of the first frame replayed. The daemon that recorded the log began just before its
// first request; a log that another program (candump) began earlier holds frames the daemon never
// saw: they are left out.
std::int64_t ReplayBeginNs(const MasterConfig& master, const MasterTraffic& traffic) {
  const bool uses_master = master.nmt || master.sdo;
  return uses_master && traffic.first_ns ? *traffic.first_ns - 10000000 : std::numeric_limits<std::int64_t>::min();
}

// How far the replay is: the frames given to the session and those left out before them, the last
// frame's time, and the log's and the monotonic clock's time of the first frame (for the pace).
struct ReplayProgress {
  std::int64_t first_frame_ns = 0, start_mono_ns = 0, last_ns = 0;
  std::uint64_t n = 0, before = 0, other_iface = 0;
};

// Whether a stop was requested (and logged); reports the summary when it was asked for.
bool StopRequested(AcquisitionContext& ctx) {
  if (ctx.control.stop.load() != 0) {
    ctx.Log(LogLevel::kInfo, "stop requested: ending the replay");
    return true;
  }
  if (ctx.control.summary.exchange(0) != 0) ctx.Summary();
  return false;
}

// Begins the session at the first frame replayed, after logging how many frames were left out.
void BeginReplay(AcquisitionContext& ctx, std::int64_t t_ns, std::uint64_t before) {
  if (before > 0) {
    ctx.Log(LogLevel::kInfo, ctx.options.replay_path + ": " + std::to_string(before) +
                                 " frames before the daemon's first request are left out");
  }
  ctx.session->Begin(t_ns);
}

// Waits until the frame at `t_ns` is due at `speed` times the log's pace; the first frame sets the
// clocks.
void KeepPace(AcquisitionContext& ctx, double speed, std::int64_t t_ns, ReplayProgress& p) {
  if (p.n == 0) {
    p.first_frame_ns = t_ns;
    p.start_mono_ns = MonotonicNs();
    return;
  }
  const auto due = p.start_mono_ns + static_cast<std::int64_t>(static_cast<double>(t_ns - p.first_frame_ns) / speed);
  if (due > MonotonicNs()) {
    ctx.session->FlushOutputs();  // idle anyway: make what we have visible
    SleepUntil(due, ctx.control);
  }
}

// Gives one frame to the session (at the log's pace with a --replay-speed), flushing the outputs
// every 4096 frames.
void ReplayFrame(AcquisitionContext& ctx, const CanFrame& frame, ReplayProgress& p) {
  AcquisitionSession& session = *ctx.session;
  if (p.n == 0) BeginReplay(ctx, frame.t_ns, p.before);
  if (ctx.options.replay_speed > 0.0) KeepPace(ctx, ctx.options.replay_speed, frame.t_ns, p);
  session.OnTime(frame.t_ns);
  session.OnFrame(frame);
  p.last_ns = frame.t_ns;
  if ((++p.n & 0xFFF) == 0) session.FlushOutputs();
}

// After the last frame: a start the log ends in the middle of has its timeouts run out, and an
// acquiring session's outputs are flushed. A timeout due within one SYNC period after the last
// frame ran out before the live run ended (its next SYNC would be in the log): a node that did
// not come back ends the replay as it ended the run.
void FinishReplay(AcquisitionContext& ctx, std::int64_t last_ns) {
  AcquisitionSession& session = *ctx.session;
  if (session.state() == AcquisitionSession::State::kStarting && ctx.control.stop.load() == 0) {
    session.OnTime(last_ns + 3600LL * 1000000000LL);
  }
  const auto period_ns = static_cast<std::int64_t>(ctx.pipeline_config.sync_period_s * 1e9);
  if (session.state() == AcquisitionSession::State::kAcquiring && period_ns > 0 && ctx.control.stop.load() == 0 &&
      session.NextDeadline() <= last_ns + period_ns) {
    session.OnTime(session.NextDeadline());
  }
  if (session.state() == AcquisitionSession::State::kAcquiring ||
      session.state() == AcquisitionSession::State::kNodeLost) {
    session.FlushOutputs();
  }
}

// Replays the frames of `reader` from `begin_ns` on into the session until the log ends, a stop is
// requested or the session can go no further.
AcquisitionStatus ReplayFrames(AcquisitionContext& ctx, CandumpReader& reader, std::int64_t begin_ns) {
  AcquisitionSession& session = *ctx.session;
  ReplayProgress p;
  for (;;) {
    if (session.ended()) break;
    if (StopRequested(ctx)) break;
    CandumpReader::Result r;
    try {
      r = reader.Next();
    } catch (const std::exception& e) {
      return ctx.Fail(AcquisitionStatus::kBadInput, e.what());
    }
    if (r.status == CandumpReader::Status::kEnd) break;
    if (r.status == CandumpReader::Status::kMalformed) {
      session.OnMalformedInput(r.error);
      continue;
    }
    if (r.iface != ctx.replay.iface) {
      ++p.other_iface;
      continue;
    }
    if (r.frame.t_ns < begin_ns) {
      ++p.before;
      continue;
    }
    ReplayFrame(ctx, r.frame, p);
  }
  FinishReplay(ctx, p.last_ns);
  if (p.other_iface > 0) {
    std::string others;
    for (const std::string& i : ctx.replay.interfaces) {
      if (i != ctx.replay.iface) others += (others.empty() ? "" : ", ") + i;
    }
    ctx.Log(LogLevel::kInfo, ctx.options.replay_path + ": replayed the frames of " + ctx.replay.iface + "; " +
                                 std::to_string(p.other_iface) + " frames of " + others + " left out");
  }
  return AcquisitionStatus::kOk;
}

}  // namespace

AcquisitionStatus RunReplay(AcquisitionContext& ctx) {
  std::unique_ptr<CandumpReader> reader;
  MasterConfig master;
  MasterTraffic traffic;
  try {
    traffic = ScanForMaster(ctx.options.replay_path, ctx.replay.iface, ctx.master_config);
    master = MasterForLog(ctx, traffic);
    reader = std::make_unique<CandumpReader>(ctx.options.replay_path);
  } catch (const std::exception& e) {
    return ctx.Fail(AcquisitionStatus::kBadInput, e.what());
  }
  ctx.session = std::make_unique<AcquisitionSession>(ctx.options, ctx.pipeline_config, master, ctx.hooks.log,
                                                     "replay of " + ctx.options.replay_path, ctx.replay.iface);
  return ReplayFrames(ctx, *reader, ReplayBeginNs(master, traffic));
}

}  // namespace sph::can
