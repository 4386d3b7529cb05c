// The simulated bus, live: the devices on a CAN interface in real time. They answer SYNC, NMT and
// SDO frames from the bus and send heartbeats and boot-ups on their own; with the internal SYNC
// source the simulator is also the SYNC producer.
#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <optional>
#include <vector>

#include "bus_simulation_internal.hpp"
#include "clock.hpp"
#include "sph/can/canopen.hpp"
#include "sph/can/socket.hpp"

namespace sph::can {
namespace {

// The CAN socket of a live play: the frames the devices listen to (SYNC, NMT, their SDO requests).
CanSocketOptions LiveSocketOptions(const BusSimulationOptions& o, const DeviceSimConfig& c) {
  CanSocketOptions so;
  so.iface = o.iface;
  const std::uint32_t sff = kEffFlag | kRtrFlag | kSffMask;
  so.filters.emplace_back(o.devices.sync_cob_id, sff);
  so.filters.emplace_back(kNmtCobId, sff);
  for (const int node : {c.devices.theta.node_id, c.devices.phi.node_id, c.devices.probe.node_id}) {
    if (node != 0) so.filters.emplace_back(kSdoRequestBase + static_cast<std::uint32_t>(node), sff);
  }
  so.error_mask = 0;
  return so;
}

// The devices on a live interface, paced in real time: frames planned by the simulator are sent
// at their times; a synchronous PDO remembers its SYNC, because it must not go out once its
// synchronous window has closed (CiA 301, object 1007h): when the next SYNC came first, or half a
// period after its own. A real device drops it then; a simulator slowed down (an emulated machine)
// would otherwise answer one SYNC after the next.
class LivePlay {
 public:
  LivePlay(const BusSimulationOptions& o, const RunControl& control, DeviceSimulator& sim, const DeviceSimConfig& c,
           CanSocket& sock)
      : o_(o),
        control_(control),
        sim_(sim),
        c_(c),
        sock_(sock),
        external_(o.external_sync),
        period_ns_(static_cast<std::int64_t>(std::llround(c.sync_period_s * 1e9))),
        // The synchronous window (1007h): half a period, so that a SYNC of a producer that is late
        // by less than that, and the early one after it, still find each PDO in its own period.
        window_ns_(period_ns_ / 2),
        start_ns_(static_cast<std::int64_t>(std::llround(c.start_time_s * 1e9))),
        end_ns_(o.duration_s > 0.0 ? start_ns_ + static_cast<std::int64_t>(o.duration_s * 1e9)
                                   : std::numeric_limits<std::int64_t>::max()),
        next_sync_(external_ ? std::numeric_limits<std::int64_t>::max() : start_ns_),
        pdo_ids_{c.devices.theta.field.can_id, c.devices.phi.field.can_id, c.devices.probe.field.can_id} {}

  void Run() {
    while (control_.stop.load() == 0) {
      // Take every frame queued first: a SYNC waiting in the queue closes the window before.
      for (int i = 0; i < 64; ++i) {
        const RxResult r = sock_.Receive();
        if (r.status != RxStatus::kFrame) break;
        Deliver(r.frame);
      }
      const std::int64_t now = RealtimeNs();
      if (now >= end_ns_ || (sim_.finished() && pending_.empty())) break;
      SendDue(now);
      if (!external_ && now >= next_sync_ && !sim_.finished()) {
        SendSync();
        continue;
      }
      Wait(now);
    }
  }

  void Summarise(BusRun& run) const {
    run.result.frames_sent = sent_;
    run.result.frames_failed = failed_;
    run.result.pdos_late = late_;
    if (late_ > 0) {
      run.Report(LogLevel::kInfo, std::to_string(late_) +
                                      " PDOs not sent: their synchronous window had closed (the simulator was late)");
    }
    run.Report(LogLevel::kInfo,
               o_.iface + ": sent " + std::to_string(sent_) + " frames, " + std::to_string(failed_) + " failed");
  }

 private:
  struct Planned {
    CanFrame frame;
    std::int64_t sync_ns = 0;  // the SYNC a synchronous PDO answers; 0: not one
  };

  // The devices take `frame` (received, or the simulator's own SYNC); their answers are planned.
  void Deliver(const CanFrame& frame) {
    out_.clear();
    sim_.AdvanceTo(frame.t_ns, out_);
    const bool sync = DecodeSync(frame, c_.devices.sync_cob_id).has_value();
    if (sync) last_sync_ = frame.t_ns;
    const std::size_t before = out_.size();
    sim_.OnFrame(frame, out_);
    for (std::size_t i = 0; i < out_.size(); ++i) {
      const bool pdo =
          i >= before && sync && std::find(std::begin(pdo_ids_), std::end(pdo_ids_), out_[i].id) != std::end(pdo_ids_);
      pending_.push_back({out_[i], pdo ? frame.t_ns : 0});
    }
  }

  // Sends the planned frames due at `now`, in time order, but a synchronous PDO whose window closed.
  void SendDue(std::int64_t now) {
    std::stable_sort(pending_.begin(), pending_.end(),
                     [](const Planned& a, const Planned& b) { return a.frame.t_ns < b.frame.t_ns; });
    std::size_t k = 0;
    arrived_.clear();
    for (; k < pending_.size() && pending_[k].frame.t_ns <= now; ++k) {
      const Planned& p = pending_[k];
      if (p.sync_ns != 0) {
        // Just before a synchronous PDO: a SYNC queued meanwhile closes its window.
        for (int i = 0; i < 64; ++i) {
          const RxResult r = sock_.Receive();
          if (r.status != RxStatus::kFrame) break;
          arrived_.push_back(r.frame);
          if (DecodeSync(r.frame, c_.devices.sync_cob_id)) last_sync_ = std::max(last_sync_, r.frame.t_ns);
        }
        if (p.sync_ns < last_sync_ || RealtimeNs() - p.sync_ns > window_ns_) {
          ++late_;
          continue;
        }
      }
      if (sock_.Send(p.frame) == TxStatus::kOk) {
        ++sent_;
      } else {
        ++failed_;
      }
    }
    pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(k));
    for (const CanFrame& f : arrived_) Deliver(f);
  }

  // The simulator's own SYNC, at its time.
  void SendSync() {
    CanFrame sync =
        EncodeSync(c_.devices.sync_counter_max != 0
                       ? std::optional<std::uint8_t>(counter_ = NextSyncCounter(counter_, c_.devices.sync_counter_max))
                       : std::nullopt,
                   c_.devices.sync_cob_id);
    sync.t_ns = next_sync_;
    pending_.push_back({sync, 0});
    Deliver(sync);
    next_sync_ += period_ns_;
  }

  // Plans what the devices send on their own, then waits for a frame until the next thing to do.
  void Wait(std::int64_t now) {
    out_.clear();
    sim_.AdvanceTo(now, out_);
    for (const CanFrame& f : out_) pending_.push_back({f, 0});
    std::int64_t wake = std::min({sim_.NextEventNs(), next_sync_, end_ns_});
    for (const Planned& p : pending_) wake = std::min(wake, p.frame.t_ns);
    const std::int64_t wait_ns = std::max<std::int64_t>(0, std::min<std::int64_t>(wake - now, 200000000));
    const RxResult r = sock_.Receive(static_cast<int>((wait_ns + 999999) / 1000000));
    if (r.status == RxStatus::kFrame) Deliver(r.frame);
  }

  const BusSimulationOptions& o_;
  const RunControl& control_;
  DeviceSimulator& sim_;
  const DeviceSimConfig& c_;
  CanSocket& sock_;
  const bool external_;
  const std::int64_t period_ns_, window_ns_, start_ns_, end_ns_;
  std::int64_t next_sync_;
  const std::uint32_t pdo_ids_[3];
  std::vector<Planned> pending_;
  std::vector<CanFrame> out_, arrived_;
  std::uint64_t sent_ = 0, failed_ = 0, late_ = 0;
  std::int64_t last_sync_ = 0;
  std::uint8_t counter_ = 0;
};

}  // namespace

BusSimulationResult SimulateBusLive(const BusSimulationOptions& options, RunControl& control,
                                    const BusSimulationHooks& hooks) {
  BusRun run(options, control, hooks);
  if (run.Begin(true).status != BusSimulationStatus::kOk) return run.result;
  std::optional<CanSocket> sock;
  try {
    sock.emplace(LiveSocketOptions(options, run.config));
  } catch (const std::exception& e) {
    run.Fail(BusSimulationStatus::kInterfaceError, e.what());
    return run.End();  // the faults injected (none) reported, the record (empty) written all the same
  }
  LivePlay play(options, control, *run.sim, run.config, *sock);
  play.Run();
  play.Summarise(run);
  return run.End();
}

}  // namespace sph::can
