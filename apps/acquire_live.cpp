// sph_acquired --iface: the SocketCAN poll loop. One ppoll() waits for frames, the SYNC timer,
// the master's next timeout and signals (blocked outside ppoll, so a signal between the flag
// check and the wait is not lost). The socket echoes the daemon's own frames (NMT, SDO, SYNC),
// so the frame log holds them and the replay sees what the master saw. Time-outs are handled
// after the received frames are read, as the replay, which knows only frame times, does. The
// SYNC timer starts when the devices are started. A lost interface (ENETDOWN, ENODEV) closes the
// socket; the loop checks every --reopen-interval-s whether the interface is up again and
// reopens it.
#include <poll.h>
#include <signal.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>

#include "acquire_internal.hpp"
#include "app_common.hpp"
#include "sph/can/socket.hpp"

namespace sph::apps {
namespace {

std::int64_t RealtimeNs() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

double MonotonicS() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

timespec ToTimespec(double s) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(s);
  ts.tv_nsec = static_cast<long>((s - static_cast<double>(ts.tv_sec)) * 1e9);
  return ts;
}

// The frames the daemon wants: SYNC, the three PDOs, heartbeats and EMCY of the nodes, the SDO
// answers, and its own NMT and SDO requests (echoed).
can::CanSocketOptions SocketOptions(const AcquireOptions& o, const can::PipelineConfig& c) {
  can::CanSocketOptions s;
  s.iface = o.iface;
  const std::uint32_t sff = can::kEffFlag | can::kRtrFlag | can::kSffMask;
  const std::uint32_t eff = can::kEffFlag | can::kRtrFlag | can::kEffMask;
  s.filters.emplace_back(c.sync_cob_id, sff);
  for (const std::uint32_t id : {c.theta.field.can_id, c.phi.field.can_id, c.probe.field.can_id}) {
    s.filters.emplace_back(id, (id & can::kEffFlag) ? eff : sff);
  }
  for (const int node : {c.theta.node_id, c.phi.node_id, c.probe.node_id}) {
    if (node == 0) continue;
    s.filters.emplace_back(can::kHeartbeatBase + static_cast<std::uint32_t>(node), sff);
    s.filters.emplace_back(can::kEmcyBase + static_cast<std::uint32_t>(node), sff);
    s.filters.emplace_back(can::kSdoResponseBase + static_cast<std::uint32_t>(node), sff);
    s.filters.emplace_back(can::kSdoRequestBase + static_cast<std::uint32_t>(node), sff);
  }
  s.filters.emplace_back(can::kNmtCobId, sff);
  s.error_mask = can::kDefaultErrorMask;
  s.receive_own = true;  // our SYNC comes back with its kernel time, our NMT and SDO into the log
  s.rcvbuf_bytes = o.rcvbuf_bytes;
  return s;
}

class SyncTimer {
 public:
  explicit SyncTimer(double period_s) {
    fd_ = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    if (fd_ < 0) throw Error(std::string("timerfd_create: ") + std::strerror(errno));
    itimerspec spec{};
    spec.it_interval = ToTimespec(period_s);
    spec.it_value = spec.it_interval;
    if (::timerfd_settime(fd_, 0, &spec, nullptr) != 0) {
      const int err = errno;
      ::close(fd_);
      throw Error(std::string("timerfd_settime: ") + std::strerror(err));
    }
  }
  ~SyncTimer() { ::close(fd_); }
  SyncTimer(const SyncTimer&) = delete;
  SyncTimer& operator=(const SyncTimer&) = delete;
  int fd() const { return fd_; }
  /// Expirations since the last call (0 if none).
  std::uint64_t Expirations() {
    std::uint64_t n = 0;
    return ::read(fd_, &n, sizeof n) == static_cast<ssize_t>(sizeof n) ? n : 0;
  }

 private:
  int fd_ = -1;
};

}  // namespace

int RunLive(AcquireContext& ctx) {
  const AcquireOptions& o = ctx.options;
  const can::PipelineConfig& config = ctx.pipeline_config;
  const can::CanSocketOptions sopts = SocketOptions(o, config);
  const bool produce = o.sync_mode == "produce";
  if (produce && !(config.sync_period_s > 0.0)) {
    ctx.log(can::LogLevel::kError, "--sync-mode produce needs a --sync-period-ms above 0");
    return kExitBadInput;
  }
  std::optional<can::CanSocket> sock;
  try {
    sock.emplace(sopts);
  } catch (const std::exception& e) {
    ctx.log(can::LogLevel::kError, e.what());
    return kExitInterfaceError;
  }
  ctx.session = std::make_unique<AcquireSession>(o, config, ctx.master_config, ctx.log, "CAN interface " + o.iface);
  AcquireSession& session = *ctx.session;
  session.set_send([&](const can::CanFrame& f) {
    if (sock) sock->Send(f);
  });
  ctx.log(can::LogLevel::kInfo,
          o.iface + ": " +
              (ctx.master_config.nmt || ctx.master_config.sdo ? std::string("starting the devices")
                                                              : std::string("listening")) +
              " (SYNC " +
              (produce ? "produced every " + std::to_string(o.devices.sync_period_ms) + " ms"
                       : std::string("from an external producer")) +
              ", timestamps: " + can::ToString(sock->timestamp_mode()) + ")");
  // Signals are delivered only inside ppoll (see the file comment).
  sigset_t blocked, wait_mask;
  sigemptyset(&blocked);
  sigaddset(&blocked, SIGTERM);
  sigaddset(&blocked, SIGINT);
  sigaddset(&blocked, SIGUSR1);
  pthread_sigmask(SIG_BLOCK, &blocked, &wait_mask);
  sigdelset(&wait_mask, SIGTERM);
  sigdelset(&wait_mask, SIGINT);
  sigdelset(&wait_mask, SIGUSR1);

  std::optional<SyncTimer> timer;
  std::uint8_t counter = 0;
  std::uint64_t syncs_sent = 0, sync_overruns = 0, tx_busy = 0;
  const double t_start = MonotonicS();
  double down_since = 0.0, next_reopen = 0.0;
  int result = kExitOk;
  session.Begin(RealtimeNs());

  while (!ctx.signals.stop) {
    if (session.state() == AcquireSession::State::kStartRefused ||
        session.state() == AcquireSession::State::kOutputFailed) {
      break;
    }
    if (produce && session.acquiring() && !timer) timer.emplace(config.sync_period_s);
    if (ctx.signals.summary) {
      ctx.signals.summary = 0;
      ctx.print_summary();
    }
    const double now = MonotonicS();
    if (o.duration_s > 0.0 && now - t_start >= o.duration_s) {
      ctx.log(can::LogLevel::kInfo, "--duration-s reached");
      break;
    }
    if (!sock) {  // interface down: wait, then try to reopen
      if (now >= next_reopen) {
        next_reopen = now + o.reopen_interval_s;
        if (can::InterfaceIsUp(o.iface)) {
          try {
            sock.emplace(sopts);
            char buf[64];
            std::snprintf(buf, sizeof buf, "%.2f", now - down_since);
            ctx.log(can::LogLevel::kWarning, o.iface + ": up again after " + std::string(buf) + " s; socket reopened");
            session.OnLinkEvent("interface " + o.iface + " up again, acquisition resumed", RealtimeNs());
            if (timer) timer->Expirations();  // no burst of SYNCs for the time we were down
            continue;
          } catch (const std::exception& e) {
            ctx.log(can::LogLevel::kDebug, std::string("reopen failed: ") + e.what());
          }
        }
      }
      const timespec wait = ToTimespec(std::max(0.0, std::min(next_reopen - now, 0.2)));
      ::ppoll(nullptr, 0, &wait, &wait_mask);
      if (timer) timer->Expirations();
      session.OnTime(RealtimeNs());
      session.FlushOutputs();
      continue;
    }

    // Wait at most until the master's next timeout.
    double wait_s = 0.2;
    const std::int64_t deadline = session.NextDeadline();
    if (deadline != std::numeric_limits<std::int64_t>::max()) {
      wait_s = std::max(0.0, std::min(wait_s, static_cast<double>(deadline - RealtimeNs()) * 1e-9 + 1e-4));
    }
    pollfd fds[2] = {{sock->fd(), POLLIN, 0}, {timer ? timer->fd() : -1, POLLIN, 0}};
    const timespec wait = ToTimespec(wait_s);
    const int rc = ::ppoll(fds, timer ? 2 : 1, &wait, &wait_mask);
    if (rc < 0 && errno != EINTR) {
      ctx.log(can::LogLevel::kError, std::string("ppoll: ") + std::strerror(errno));
      result = kExitInterfaceError;
      break;
    }
    bool went_down = false;
    int down_errno = 0;
    if (rc > 0 && timer && (fds[1].revents & POLLIN)) {
      const std::uint64_t n = timer->Expirations();
      if (n > 1) {
        sync_overruns += n - 1;
        ctx.log(can::LogLevel::kWarning, "SYNC timer overrun: " + std::to_string(n - 1) + " SYNC periods skipped");
      }
      if (n > 0) {
        std::optional<std::uint8_t> c;
        if (config.sync_counter_max != 0) c = counter = can::NextSyncCounter(counter, config.sync_counter_max);
        int err = 0;
        const can::TxStatus tx = sock->Send(can::EncodeSync(c, config.sync_cob_id), &err);
        if (tx == can::TxStatus::kOk) {
          ++syncs_sent;
        } else if (tx == can::TxStatus::kBusy) {
          ++tx_busy;
        } else {
          went_down = true;
          down_errno = err;
        }
      }
    }
    // Read every frame queued (bounded, so the timer is served) before the timeouts.
    for (int i = 0; i < 256 && !went_down; ++i) {
      const can::RxResult r = sock->Receive();
      if (r.new_drops > 0) session.OnRxOverflow(r.new_drops, RealtimeNs());
      if (r.status == can::RxStatus::kNone) {  // queue empty: drops that no frame followed
        session.OnRxOverflow(sock->TakeDrops(), RealtimeNs());
        break;
      }
      if (r.status == can::RxStatus::kDown) {
        went_down = true;
        down_errno = r.error;
      } else if (r.status == can::RxStatus::kMalformed) {
        session.OnMalformedInput(o.iface + ": a read of unexpected size");
      } else {
        session.OnFrame(r.frame);
      }
    }
    if (went_down) {
      session.OnRxOverflow(sock->TakeDrops(), RealtimeNs());
      ctx.log(can::LogLevel::kWarning, o.iface + ": " + std::strerror(down_errno) +
                                           ": waiting for the interface to come back");
      session.OnLinkEvent("interface " + o.iface + " lost (" + std::strerror(down_errno) + ")", RealtimeNs());
      sock.reset();
      down_since = MonotonicS();
      next_reopen = down_since + o.reopen_interval_s;
    }
    session.OnTime(RealtimeNs());
    session.FlushOutputs();
  }
  if (sock) session.OnRxOverflow(sock->TakeDrops(), RealtimeNs());  // drops after the last frame read
  if (ctx.signals.stop) ctx.log(can::LogLevel::kInfo, "stop requested: flushing and closing");
  if (sock && (o.nmt_stop_at_exit || o.nmt_preop_at_exit)) {
    const auto command = o.nmt_stop_at_exit ? can::NmtCommand::kStop : can::NmtCommand::kEnterPreOperational;
    for (const can::CanFrame& f : session.master().CommandAll(command)) sock->Send(f);
    ctx.log(can::LogLevel::kInfo, "NMT " + can::NmtCommandName(static_cast<std::uint8_t>(command)) + " sent");
  }
  session.set_send(nullptr);  // the socket goes with this function; the session lives on
  pthread_sigmask(SIG_UNBLOCK, &blocked, nullptr);
  if (produce && timer) {
    ctx.log(can::LogLevel::kInfo, "SYNC sent " + std::to_string(syncs_sent) + ", timer overruns " +
                                      std::to_string(sync_overruns) + ", TX queue full " + std::to_string(tx_busy));
  }
  return result;
}

}  // namespace sph::apps
