#include "sph/can/device_sim.hpp"

#include <algorithm>
#include <cmath>

#include "sph/can/error_frame.hpp"
#include "sph/core/error.hpp"
#include "sph/model/units.hpp"

namespace sph::can {
namespace {

std::int64_t ToNs(double s) { return static_cast<std::int64_t>(std::llround(s * 1e9)); }

}  // namespace

DeviceSimulator::DeviceSimulator(const DeviceSimConfig& config) : config_(config), rng_(config.spec.seed) {
  config_.devices.Validate();
  if (config_.spec.pattern.empty()) throw Error("device simulator: the pattern is empty");
  if (config_.spec.centers_mm.empty()) throw Error("device simulator: no sphere centre");
  if (!(config_.sync_period_s > 0.0)) throw Error("device simulator: the SYNC period must be positive");
  if (config_.stop_s < 0.0 || config_.move_s < 0.0 || config_.stop_s + config_.move_s <= 0.0) {
    throw Error("device simulator: stop and move times must not be negative, and not both zero");
  }
  total_cycles_ = static_cast<std::uint64_t>(std::floor(duration_s() / config_.sync_period_s + 1e-9));
  bus_off_done_.assign(config_.faults.bus_off_at_s.size(), false);
  emcy_done_.assign(config_.faults.emergencies.size(), false);
  next_error_frame_s_ = config_.faults.error_frame_period_s;
}

double DeviceSimulator::duration_s() const {
  const auto n = static_cast<double>(config_.spec.pattern.size());
  return n * config_.stop_s + (n - 1.0) * config_.move_s;
}

AnglePair DeviceSimulator::AxesAt(double t_s) const {
  const auto& pat = config_.spec.pattern;
  const double seg = config_.stop_s + config_.move_s;
  const auto n = pat.size();
  double i_d = std::floor(t_s / seg);
  if (i_d < 0.0) i_d = 0.0;
  auto i = static_cast<std::size_t>(i_d);
  if (i >= n) return pat.back();
  const double u = t_s - static_cast<double>(i) * seg;
  if (u < config_.stop_s || i + 1 >= n) return pat[i];
  const double frac = (u - config_.stop_s) / config_.move_s;
  const double s = 0.5 * (1.0 - std::cos(kPi * frac));
  return {pat[i].theta_deg + s * (pat[i + 1].theta_deg - pat[i].theta_deg),
          pat[i].phi_deg + s * (pat[i + 1].phi_deg - pat[i].phi_deg)};
}

bool DeviceSimulator::Silent(int device, double t_rel_s) const {
  for (const Silence& s : config_.faults.silences) {
    if (s.device == device && t_rel_s >= s.from_s && t_rel_s < s.to_s) return true;
  }
  return false;
}

bool DeviceSimulator::NextCycle(std::vector<CanFrame>& frames) {
  if (cycle_ >= total_cycles_) return false;
  const double t_rel = static_cast<double>(cycle_) * config_.sync_period_s;
  AppendCycle(ToNs(config_.start_time_s + t_rel), t_rel, true, frames);
  return true;
}

bool DeviceSimulator::AnswerSync(std::int64_t t_ns, std::vector<CanFrame>& frames) {
  if (cycle_ >= total_cycles_) return false;
  const double t_rel = static_cast<double>(cycle_) * config_.sync_period_s;
  AppendCycle(t_ns, t_rel, false, frames);
  return true;
}

void DeviceSimulator::AppendCycle(std::int64_t t_ns, double t_rel, bool with_sync, std::vector<CanFrame>& frames) {
  const SimFaults& f = config_.faults;
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const std::size_t first = frames.size();
  const auto period_ns = ToNs(config_.sync_period_s);
  auto at = [&](double offset_us) {  // a time inside this cycle
    return t_ns + std::min<std::int64_t>(ToNs(offset_us * 1e-6), period_ns * 9 / 10);
  };
  ++injected_.cycles;
  if (with_sync) {
    std::optional<std::uint8_t> counter;
    if (config_.devices.sync_counter_max != 0) {
      sync_counter_ = NextSyncCounter(sync_counter_, config_.devices.sync_counter_max);
      counter = sync_counter_;
    }
    if (f.sync_drop_probability > 0.0 && uniform(rng_) < f.sync_drop_probability) {
      ++injected_.syncs_dropped;
    } else {
      CanFrame sync = EncodeSync(counter, config_.devices.sync_cob_id);
      sync.t_ns = t_ns;
      frames.push_back(sync);
    }
  }
  // Draw every random number in a fixed order, whatever faults are on, so a seed gives the same
  // readings with and without faults.
  const AnglePair axes = AxesAt(t_rel);
  const double n_theta = gauss(rng_), n_phi = gauss(rng_), n_r = gauss(rng_);
  const double theta_deg = axes.theta_deg + config_.spec.noise_theta_arcsec / 3600.0 * n_theta;
  const double phi_deg = axes.phi_deg + config_.spec.noise_phi_arcsec / 3600.0 * n_phi;
  const auto r = ProbeReading(config_.spec.truth, axes.theta_deg * kRadPerDeg, axes.phi_deg * kRadPerDeg,
                              config_.spec.probe_offset_mm, config_.spec.centers_mm.front(),
                              config_.spec.sphere_radius_mm);
  for (int dev = 0; dev < kNumDevices; ++dev) {
    const double u_drop = uniform(rng_), u_short = uniform(rng_), u_range = uniform(rng_), u_jit = uniform(rng_);
    const auto d = static_cast<std::size_t>(dev);
    if (Silent(dev, t_rel)) {
      ++injected_.silent_cycles[d];
      continue;
    }
    if (f.drop_probability > 0.0 && u_drop < f.drop_probability) {
      ++injected_.dropped[d];
      continue;
    }
    CanFrame pdo;
    if (dev == kProbe) {
      const ProbeConfig& p = config_.devices.probe;
      pdo.id = p.field.can_id;
      std::int64_t raw = 0;
      if (!r || (f.probe_out_of_range_probability > 0.0 && u_range < f.probe_out_of_range_probability)) {
        raw = p.over_range_raw.value_or(0x7FFFFFFF);
        ++injected_.probe_out_of_range;
      } else {
        raw = EncodeProbeRaw(p, *r + config_.spec.noise_r_um * kMmPerUm * n_r);
      }
      InsertField(pdo, p.field, raw);
    } else {
      const EncoderConfig& e = dev == kTheta ? config_.devices.theta : config_.devices.phi;
      pdo.id = e.field.can_id;
      InsertField(pdo, e.field, EncodePositionRaw(e, dev == kTheta ? theta_deg : phi_deg));
    }
    if (f.short_probability > 0.0 && u_short < f.short_probability) {
      pdo.len = static_cast<std::uint8_t>(pdo.len - 1);
      ++injected_.shortened[d];
    }
    pdo.t_ns = at(100.0 + 130.0 * dev + f.jitter_us * u_jit);
    frames.push_back(pdo);
  }
  // Heartbeats, error frames and EMCY at the end of the cycle.
  if (config_.heartbeat_period_s > 0.0 && t_rel >= next_heartbeat_s_) {
    next_heartbeat_s_ += config_.heartbeat_period_s;
    const int nodes[] = {config_.devices.theta.node_id, config_.devices.phi.node_id, config_.devices.probe.node_id};
    for (int dev = 0; dev < kNumDevices; ++dev) {
      if (nodes[dev] == 0 || Silent(dev, t_rel)) continue;
      CanFrame hb = EncodeHeartbeat(nodes[dev], NmtState::kOperational);
      hb.t_ns = at(600.0 + 20.0 * dev);
      frames.push_back(hb);
      ++injected_.heartbeats;
    }
  }
  if (f.error_frame_period_s > 0.0 && t_rel >= next_error_frame_s_) {
    next_error_frame_s_ += f.error_frame_period_s;
    CanFrame e = MakeErrorFrame(kErrController, {0, 0x04});  // RX error warning
    e.t_ns = at(700.0);
    frames.push_back(e);
    ++injected_.error_frames;
  }
  for (std::size_t i = 0; i < f.bus_off_at_s.size(); ++i) {
    if (!bus_off_done_[i] && t_rel >= f.bus_off_at_s[i]) {
      bus_off_done_[i] = true;
      CanFrame e = MakeErrorFrame(kErrBusOff);
      e.t_ns = at(710.0);
      frames.push_back(e);
      ++injected_.error_frames;
      ++injected_.bus_off;
    }
  }
  for (std::size_t i = 0; i < f.emergencies.size(); ++i) {
    if (!emcy_done_[i] && t_rel >= f.emergencies[i].at_s) {
      emcy_done_[i] = true;
      const int dev = f.emergencies[i].device;
      const int node = dev == kTheta ? config_.devices.theta.node_id
                                     : dev == kPhi ? config_.devices.phi.node_id : config_.devices.probe.node_id;
      Emergency em;
      em.node_id = node;
      em.error_code = f.emergencies[i].code;
      em.error_register = 0x01;
      CanFrame e = EncodeEmergency(em);
      e.t_ns = at(720.0);
      frames.push_back(e);
      ++injected_.emergencies;
    }
  }
  std::stable_sort(frames.begin() + static_cast<std::ptrdiff_t>(first), frames.end(),
                   [](const CanFrame& a, const CanFrame& b) { return a.t_ns < b.t_ns; });
  ++cycle_;
}

}  // namespace sph::can
