// A CAN bus in memory for the tests: the simulated devices on one side, a master (the daemon's
// side) on the other, virtual time. Every frame goes to both sides in time order; the master's
// own frames come back to it, as its socket echoes them. Nothing here is the code under test.
#ifndef SPH_TESTS_CAN_SIM_BUS_HPP_
#define SPH_TESTS_CAN_SIM_BUS_HPP_

#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "sph/can/canopen.hpp"
#include "sph/can/device_sim.hpp"
#include "sph/can/frame.hpp"

namespace sph::can::testing {

class SimBus {
 public:
  /// The master's side: frames as received (own ones included), and its timeouts.
  struct Host {
    std::function<void(const CanFrame&)> on_frame;
    std::function<void(std::int64_t)> on_time;
    std::function<std::int64_t()> next_deadline;
  };

  SimBus(DeviceSimulator* sim, std::int64_t now_ns) : sim_(sim), now_(now_ns) {}
  void set_host(Host host) { host_ = std::move(host); }
  /// The host's SYNC producer: a SYNC every `period_ns` from `first_ns` (0: none).
  void ProduceSync(std::int64_t first_ns, std::int64_t period_ns, std::uint8_t counter_max = 0) {
    next_sync_ = first_ns;
    sync_period_ = period_ns;
    counter_max_ = counter_max;
  }
  void StopSync() { next_sync_ = kNever; }
  /// The host sends `frame` now (on the bus 20 us later).
  void Send(CanFrame frame) {
    frame.t_ns = now_ + 20000;
    Queue(frame, true);
  }
  std::int64_t now() const { return now_; }
  /// Every frame that was on the bus, in order.
  const std::vector<CanFrame>& log() const { return log_; }

  void RunUntil(std::int64_t t_end) {
    for (;;) {
      const std::int64_t t_frame = pending_.empty() ? kNever : pending_.front().frame.t_ns;
      const std::int64_t t_sim = sim_->NextEventNs();
      const std::int64_t t_host = host_.next_deadline ? host_.next_deadline() : kNever;
      const std::int64_t t = std::min({t_frame, t_sim, t_host, next_sync_});
      if (t >= t_end) break;
      now_ = t;
      if (t == t_host) {
        host_.on_time(t);
      } else if (t == next_sync_) {
        std::optional<std::uint8_t> c;
        if (counter_max_ != 0) c = counter_ = NextSyncCounter(counter_, counter_max_);
        CanFrame sync = EncodeSync(c);
        sync.t_ns = t;
        Queue(sync, true);
        next_sync_ += sync_period_;
      } else if (t == t_sim) {
        std::vector<CanFrame> out;
        sim_->AdvanceTo(t + 1, out);
        for (const CanFrame& f : out) Queue(f, false);
      } else {
        const Pending p = pending_.front();
        pending_.erase(pending_.begin());
        log_.push_back(p.frame);
        if (p.from_host) {
          std::vector<CanFrame> out;
          sim_->AdvanceTo(p.frame.t_ns, out);
          sim_->OnFrame(p.frame, out);
          for (const CanFrame& f : out) Queue(f, false);
        }
        if (host_.on_time) host_.on_time(p.frame.t_ns);
        if (host_.on_frame) host_.on_frame(p.frame);
      }
    }
    now_ = t_end;
  }

 private:
  static constexpr std::int64_t kNever = std::numeric_limits<std::int64_t>::max();
  struct Pending {
    CanFrame frame;
    bool from_host = false;
  };
  void Queue(const CanFrame& f, bool from_host) {
    const auto at = std::upper_bound(pending_.begin(), pending_.end(), f.t_ns,
                                     [](std::int64_t t, const Pending& p) { return t < p.frame.t_ns; });
    pending_.insert(at, Pending{f, from_host});
  }

  DeviceSimulator* sim_;
  Host host_;
  std::int64_t now_;
  std::vector<Pending> pending_;
  std::vector<CanFrame> log_;
  std::int64_t next_sync_ = kNever;
  std::int64_t sync_period_ = 0;
  std::uint8_t counter_max_ = 0;
  std::uint8_t counter_ = 0;
};

}  // namespace sph::can::testing

#endif  // SPH_TESTS_CAN_SIM_BUS_HPP_
