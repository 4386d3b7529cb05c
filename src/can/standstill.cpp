#include "sph/can/standstill.hpp"

#include <cmath>

namespace sph::can {
namespace {

// a - b wrapped into [-180, 180).
double AngleDiffDeg(double a, double b) {
  double d = std::fmod(a - b + 180.0, 360.0);
  if (d < 0) d += 360.0;
  return d - 180.0;
}

}  // namespace

std::optional<StopPoint> StandstillDetector::Add(const Sample& s, std::int64_t t_ns) {
  std::optional<StopPoint> out;
  if (anchor_ && (std::abs(AngleDiffDeg(s.theta_deg, anchor_->theta_deg)) > config_.tolerance_deg ||
                  std::abs(s.phi_deg - anchor_->phi_deg) > config_.tolerance_deg)) {
    out = Close();  // the axes moved: this stop is over, the sample may start the next one
    anchor_.reset();
  }
  if (!anchor_) {
    anchor_ = s;
    anchor_ns_ = t_ns;
  }
  if (done_ || t_ns - anchor_ns_ < std::llround(config_.dwell_s * 1e9)) return out;
  if (r_.n == 0) first_ns_ = t_ns;
  last_ns_ = t_ns;
  d_theta_.Add(AngleDiffDeg(s.theta_deg, anchor_->theta_deg));
  d_phi_.Add(s.phi_deg - anchor_->phi_deg);
  r_.Add(s.r_mm);
  dt_.Add(static_cast<double>(t_ns - anchor_ns_) * 1e-9);
  if (!out && config_.average_s > 0.0 && last_ns_ - first_ns_ >= std::llround(config_.average_s * 1e9)) {
    out = Close();
    done_ = true;  // ignore the rest of this stop
  }
  return out;
}

std::optional<StopPoint> StandstillDetector::Finish() {
  std::optional<StopPoint> p = Close();
  anchor_.reset();
  return p;
}

std::optional<StopPoint> StandstillDetector::Close() {
  std::optional<StopPoint> out;
  if (!done_ && anchor_ && r_.n > 0) {
    if (r_.n >= config_.min_samples) {
      StopPoint p;
      p.n = static_cast<int>(r_.n);
      p.mean = *anchor_;
      p.mean.theta_deg = anchor_->theta_deg + d_theta_.mean;
      if (anchor_->theta_deg >= 0.0 && anchor_->theta_deg < 360.0) {
        if (p.mean.theta_deg < 0.0) p.mean.theta_deg += 360.0;
        if (p.mean.theta_deg >= 360.0) p.mean.theta_deg -= 360.0;
      }
      p.mean.phi_deg = anchor_->phi_deg + d_phi_.mean;
      p.mean.r_mm = r_.mean;
      p.mean.t_s = anchor_->t_s + dt_.mean;
      p.sd_theta_deg = d_theta_.Sd();
      p.sd_phi_deg = d_phi_.Sd();
      p.sd_r_mm = r_.Sd();
      p.duration_s = static_cast<double>(last_ns_ - first_ns_) * 1e-9;
      out = p;
    } else {
      ++short_stops_;
    }
  }
  d_theta_ = d_phi_ = r_ = dt_ = Running{};
  done_ = false;
  return out;
}

}  // namespace sph::can
