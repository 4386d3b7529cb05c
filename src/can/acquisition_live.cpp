// The live acquisition: the SocketCAN poll loop. One ppoll() waits for frames, the SYNC timer,
// the master's next timeout and the run's wake signals (blocked outside ppoll, so a signal
// between the flag check and the wait is not lost). The socket echoes the daemon's own frames (NMT, SDO, SYNC),
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
#include <utility>
#include <vector>

#include "acquisition_internal.hpp"
#include "clock.hpp"
#include "sph/can/bus_load.hpp"
#include "sph/can/socket.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"

namespace sph::can {
namespace {

double MonotonicS() { return static_cast<double>(MonotonicNs()) * 1e-9; }

timespec ToTimespec(double s) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(s);
  ts.tv_nsec = static_cast<long>((s - static_cast<double>(ts.tv_sec)) * 1e9);
  return ts;
}

// The frames the daemon wants: SYNC, the three PDOs, heartbeats and EMCY of the nodes, the SDO
// answers, and its own NMT and SDO requests (echoed).
CanSocketOptions SocketOptions(const AcquisitionOptions& o, const PipelineConfig& c) {
  CanSocketOptions s;
  s.iface = o.iface;
  const std::uint32_t sff = kEffFlag | kRtrFlag | kSffMask;
  const std::uint32_t eff = kEffFlag | kRtrFlag | kEffMask;
  s.filters.emplace_back(c.sync_cob_id, sff);
  for (const std::uint32_t id : {c.theta.field.can_id, c.phi.field.can_id, c.probe.field.can_id}) {
    s.filters.emplace_back(id, (id & kEffFlag) ? eff : sff);
  }
  for (const int node : {c.theta.node_id, c.phi.node_id, c.probe.node_id}) {
    if (node == 0) continue;
    s.filters.emplace_back(kHeartbeatBase + static_cast<std::uint32_t>(node), sff);
    s.filters.emplace_back(kEmcyBase + static_cast<std::uint32_t>(node), sff);
    s.filters.emplace_back(kSdoResponseBase + static_cast<std::uint32_t>(node), sff);
    s.filters.emplace_back(kSdoRequestBase + static_cast<std::uint32_t>(node), sff);
  }
  s.filters.emplace_back(kNmtCobId, sff);
  s.error_mask = kDefaultErrorMask;
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

// The wake signals are delivered only inside ppoll (see the file comment): blocked for the
// object's lifetime, and `wait_mask` is the mask ppoll waits with.
class BlockedSignals {
 public:
  explicit BlockedSignals(const std::vector<int>& signals) {
    sigemptyset(&blocked_);
    for (const int s : signals) sigaddset(&blocked_, s);
    pthread_sigmask(SIG_BLOCK, &blocked_, &wait_mask_);
    for (const int s : signals) sigdelset(&wait_mask_, s);
  }
  ~BlockedSignals() { pthread_sigmask(SIG_UNBLOCK, &blocked_, nullptr); }
  BlockedSignals(const BlockedSignals&) = delete;
  BlockedSignals& operator=(const BlockedSignals&) = delete;
  const sigset_t* wait_mask() const { return &wait_mask_; }

 private:
  sigset_t blocked_;
  sigset_t wait_mask_;
};

// The live acquisition: the socket, the SYNC timer and the session, one step of Run()'s loop per
// wake-up.
class LiveLoop {
 public:
  // `socket` is open with `socket_options`, which reopen it after the interface was lost.
  LiveLoop(AcquisitionContext& ctx, CanSocketOptions socket_options, CanSocket socket)
      : ctx_(ctx),
        o_(ctx.options),
        config_(ctx.pipeline_config),
        socket_options_(std::move(socket_options)),
        produce_(o_.sync_mode == SyncMode::kProduce),
        sock_(std::move(socket)),
        session_(*ctx.session),
        signals_(ctx.control.wake_signals) {
    session_.set_send([this](const CanFrame& f) {
      if (sock_ && sock_->Send(f) == TxStatus::kBusy) {
        ++tx_busy_;
        session_.OnTxQueueFull(f.id == kNmtCobId ? "NMT command" : "SDO request", RealtimeNs());
      }
    });
  }

  // The loop until a stop, --duration-s, a refused start, an output that failed or a ppoll
  // error; then the NMT command at exit.
  AcquisitionStatus Run() {
    const double t_start = MonotonicS();
    session_.Begin(RealtimeNs());
    AcquisitionStatus result = AcquisitionStatus::kOk;
    while (ctx_.control.stop.load() == 0) {
      if (session_.ended()) break;
      if (produce_ && session_.acquiring() && !timer_) timer_.emplace(config_.sync_period_s);
      if (ctx_.control.summary.exchange(0) != 0) ctx_.Summary();
      const double now = MonotonicS();
      if (o_.duration_s > 0.0 && now - t_start >= o_.duration_s) {
        ctx_.Log(LogLevel::kInfo, "--duration-s reached");
        break;
      }
      if (!sock_) {
        WaitForInterface(now);
      } else if (!ServeSocket()) {
        result = AcquisitionStatus::kInterfaceError;
        break;
      }
      session_.OnTime(RealtimeNs());
      session_.FlushOutputs();
    }
    Finish();
    return result;
  }

 private:
  // The interface is down: wait, and every --reopen-interval-s try to reopen the socket.
  void WaitForInterface(double now) {
    if (now >= next_reopen_) {
      next_reopen_ = now + o_.reopen_interval_s;
      if (InterfaceIsUp(o_.iface)) {
        try {
          sock_.emplace(socket_options_);
          ctx_.Log(LogLevel::kWarning, o_.iface + ": up again after " + internal::Format("%.2f", now - down_since_) +
                                           " s; socket reopened");
          session_.OnLinkEvent("interface " + o_.iface + " up again, acquisition resumed", RealtimeNs());
          if (timer_) timer_->Expirations();  // no burst of SYNCs for the time we were down
          return;
        } catch (const std::exception& e) {
          ctx_.Log(LogLevel::kDebug, std::string("reopen failed: ") + e.what());
        }
      }
    }
    const timespec wait = ToTimespec(std::max(0.0, std::min(next_reopen_ - now, 0.2)));
    ::ppoll(nullptr, 0, &wait, signals_.wait_mask());
    if (timer_) timer_->Expirations();
  }

  // Waits at most until the master's next timeout for frames, the SYNC timer or a signal; sends
  // the SYNC that is due and reads the frames queued. False on a ppoll error.
  bool ServeSocket() {
    double wait_s = 0.2;
    const std::int64_t deadline = session_.NextDeadline();
    if (deadline != std::numeric_limits<std::int64_t>::max()) {
      wait_s = std::max(0.0, std::min(wait_s, static_cast<double>(deadline - RealtimeNs()) * 1e-9 + 1e-4));
    }
    pollfd fds[2] = {{sock_->fd(), POLLIN, 0}, {timer_ ? timer_->fd() : -1, POLLIN, 0}};
    const timespec wait = ToTimespec(wait_s);
    const int rc = ::ppoll(fds, timer_ ? 2 : 1, &wait, signals_.wait_mask());
    if (rc < 0 && errno != EINTR) {
      ctx_.Fail(AcquisitionStatus::kInterfaceError, std::string("ppoll: ") + std::strerror(errno));
      return false;
    }
    int down_errno = 0;
    const bool up = !(rc > 0 && timer_ && (fds[1].revents & POLLIN)) || SendSync(&down_errno);
    if (!up || !ReadFrames(&down_errno)) LinkLost(down_errno);
    return true;
  }

  // The SYNCs the timer asks for (one; overruns counted and logged). False when the interface
  // went down, with its errno.
  bool SendSync(int* down_errno) {
    const std::uint64_t n = timer_->Expirations();
    if (n > 1) {
      sync_overruns_ += n - 1;
      ctx_.Log(LogLevel::kWarning, "SYNC timer overrun: " + std::to_string(n - 1) + " SYNC periods skipped");
    }
    if (n == 0) return true;
    std::optional<std::uint8_t> c;
    if (config_.sync_counter_max != 0) c = counter_ = NextSyncCounter(counter_, config_.sync_counter_max);
    const TxStatus tx = sock_->Send(EncodeSync(c, config_.sync_cob_id), down_errno);
    if (tx == TxStatus::kOk) {
      ++syncs_sent_;
    } else if (tx == TxStatus::kBusy) {
      ++tx_busy_;
      session_.OnTxQueueFull("SYNC", RealtimeNs());
    } else {
      return false;
    }
    return true;
  }

  // Every frame queued, bounded so that the timer is served, into the session. False when the
  // interface went down, with its errno.
  bool ReadFrames(int* down_errno) {
    for (int i = 0; i < 256; ++i) {
      const RxResult r = sock_->Receive();
      if (r.new_drops > 0) session_.OnRxOverflow(r.new_drops, RealtimeNs());
      if (r.status == RxStatus::kNone) {  // queue empty: drops that no frame followed
        session_.OnRxOverflow(sock_->TakeDrops(), RealtimeNs());
        return true;
      }
      if (r.status == RxStatus::kDown) {
        *down_errno = r.error;
        return false;
      }
      if (r.status == RxStatus::kMalformed) {
        session_.OnMalformedInput(o_.iface + ": a read of unexpected size");
      } else {
        session_.OnFrame(r.frame);
      }
    }
    return true;
  }

  // The interface went down: the socket is closed until it is up again.
  void LinkLost(int down_errno) {
    session_.OnRxOverflow(sock_->TakeDrops(), RealtimeNs());
    ctx_.Log(LogLevel::kWarning,
             o_.iface + ": " + std::strerror(down_errno) + ": waiting for the interface to come back");
    session_.OnLinkEvent("interface " + o_.iface + " lost (" + std::strerror(down_errno) + ")", RealtimeNs());
    sock_.reset();
    down_since_ = MonotonicS();
    next_reopen_ = down_since_ + o_.reopen_interval_s;
  }

  // The drops after the last frame read, the NMT command at exit, the SYNC counts.
  void Finish() {
    if (sock_) session_.OnRxOverflow(sock_->TakeDrops(), RealtimeNs());
    if (ctx_.control.stop.load() != 0) ctx_.Log(LogLevel::kInfo, "stop requested: flushing and closing");
    if (sock_ && (o_.nmt_stop_at_exit || o_.nmt_preop_at_exit)) {
      const auto command = o_.nmt_stop_at_exit ? NmtCommand::kStop : NmtCommand::kEnterPreOperational;
      for (const CanFrame& f : session_.master().CommandAll(command)) sock_->Send(f);
      ctx_.Log(LogLevel::kInfo, "NMT " + NmtCommandName(static_cast<std::uint8_t>(command)) + " sent");
    }
    if (sock_ && session_.state() == AcquisitionSession::State::kStarting) session_.UndoStart();
    session_.set_send(nullptr);  // the socket goes with this loop; the session lives on
    if (produce_ && timer_) {
      ctx_.Log(LogLevel::kInfo, "SYNC sent " + std::to_string(syncs_sent_) + ", timer overruns " +
                                    std::to_string(sync_overruns_) + ", TX queue full " + std::to_string(tx_busy_));
    }
  }

  AcquisitionContext& ctx_;
  const AcquisitionOptions& o_;
  const PipelineConfig& config_;
  const CanSocketOptions socket_options_;
  const bool produce_;
  std::optional<CanSocket> sock_;
  AcquisitionSession& session_;
  const BlockedSignals signals_;
  std::optional<SyncTimer> timer_;
  std::uint8_t counter_ = 0;
  std::uint64_t syncs_sent_ = 0, sync_overruns_ = 0, tx_busy_ = 0;
  double down_since_ = 0.0, next_reopen_ = 0.0;
};

}  // namespace

AcquisitionStatus RunLive(AcquisitionContext& ctx) {
  const AcquisitionOptions& o = ctx.options;
  const PipelineConfig& config = ctx.pipeline_config;
  const bool produce = o.sync_mode == SyncMode::kProduce;
  if (produce && !(config.sync_period_s > 0.0)) {
    return ctx.Fail(AcquisitionStatus::kBadInput, "--sync-mode produce needs a --sync-period-ms above 0");
  }
  // The bus's load: the bitrate given, else the interface's where the kernel reports it.
  double bitrate = o.bitrate_kbit_s * 1e3;
  if (!(bitrate > 0.0)) {
    if (const auto reported = InterfaceBitrate(o.iface)) bitrate = *reported;
  }
  try {
    const double given_s = ctx.pipeline_config.sync_period_s;
    const std::string warning = CheckBusLoad(o, &ctx.pipeline_config, bitrate);
    if (!warning.empty()) ctx.Log(LogLevel::kWarning, warning);
    if (ctx.pipeline_config.sync_period_s != given_s) {
      ctx.Log(LogLevel::kInfo,
              "no --sync-period-ms: SYNC every " + internal::Format("%g", ctx.pipeline_config.sync_period_s * 1e3) +
                  " ms, the shortest period under half the bus (" + internal::Format("%g", bitrate * 1e-3) + " kbit/s" +
                  (o.bitrate_kbit_s > 0.0 ? "" : ", the interface's") + ")");
    }
  } catch (const std::exception& e) {
    return ctx.Fail(AcquisitionStatus::kBadInput, e.what());
  }
  const CanSocketOptions socket_options = SocketOptions(o, config);
  std::optional<CanSocket> sock;
  try {
    sock.emplace(socket_options);
  } catch (const std::exception& e) {
    return ctx.Fail(AcquisitionStatus::kInterfaceError, e.what());
  }
  ctx.session = std::make_unique<AcquisitionSession>(o, config, ctx.master_config, ctx.hooks.log,
                                                     "CAN interface " + o.iface, o.iface);
  ctx.Log(LogLevel::kInfo, o.iface + ": " +
                               (ctx.master_config.nmt || ctx.master_config.sdo ? std::string("starting the devices")
                                                                               : std::string("listening")) +
                               " (SYNC " +
                               (produce ? "produced every " + internal::Format("%g", config.sync_period_s * 1e3) + " ms"
                                        : std::string("from an external producer")) +
                               ", timestamps: " + ToString(sock->timestamp_mode()) + ")");
  LiveLoop loop(ctx, socket_options, std::move(*sock));
  return loop.Run();
}

}  // namespace sph::can
