// Stop-and-go measuring: find where both axes stand still and average the samples there.
#ifndef SPH_CAN_STANDSTILL_HPP_
#define SPH_CAN_STANDSTILL_HPP_

#include <cmath>
#include <cstdint>
#include <optional>

#include "sph/io/points_file.hpp"

namespace sph::can {

struct StandstillConfig {
  /// Both axes within this of the stop's first sample [deg] (theta difference taken modulo 360).
  double tolerance_deg = 0.001;
  /// Time the axes must have been still before averaging starts (settling) [s].
  double dwell_s = 0.2;
  /// Averaging time per stop [s]; 0: until the axes move again.
  double average_s = 0.0;
  /// Fewer averaged samples than this: the stop is not a point (counted as a short stop).
  int min_samples = 3;
};

/// One averaged point and its scatter: sample standard deviations (n - 1) of the samples.
struct StopPoint {
  Sample mean;  ///< t_s is the mean time of the averaged samples
  int n = 0;    ///< samples averaged
  double sd_theta_deg = 0.0;
  double sd_phi_deg = 0.0;
  double sd_r_mm = 0.0;
  double duration_s = 0.0;  ///< first to last averaged sample
};

/// Detects stops in a stream of samples.
///
/// A stop starts at a sample (its anchor) and lasts while every later sample is within
/// tolerance_deg of the anchor in both axes. Samples whose time is at least dwell_s after the
/// anchor's are averaged (Welford's running mean and variance, O(1) memory); the point is
/// emitted when the axes leave the tolerance, when average_s is reached, or at Finish().
/// A stop with fewer than min_samples averaged samples is only counted (short_stops()).
/// Times are compared in integer nanoseconds (a sample's t_s since the epoch in a double is only
/// good to a quarter of a microsecond, which would decide at random whether a sample exactly
/// dwell_s after the anchor is averaged).
class StandstillDetector {
 public:
  explicit StandstillDetector(const StandstillConfig& config) : config_(config) {}

  /// Feeds the next sample (in time order), taken at `t_ns` (its t_s in ns); returns a point when
  /// a stop ended with it.
  std::optional<StopPoint> Add(const Sample& sample, std::int64_t t_ns);
  /// Ends the stream: the open stop, if long enough.
  std::optional<StopPoint> Finish();
  long short_stops() const { return short_stops_; }

 private:
  std::optional<StopPoint> Close();

  struct Running {  // Welford
    long n = 0;
    double mean = 0.0, m2 = 0.0;
    void Add(double x) {
      ++n;
      const double d = x - mean;
      mean += d / static_cast<double>(n);
      m2 += d * (x - mean);
    }
    double Sd() const { return n > 1 ? std::sqrt(m2 / static_cast<double>(n - 1)) : 0.0; }
  };

  StandstillConfig config_;
  std::optional<Sample> anchor_;
  std::int64_t anchor_ns_ = 0;
  bool done_ = false;                 // this stop's point was emitted (average_s reached)
  Running d_theta_, d_phi_, r_, dt_;  // dt_: seconds after the anchor
  std::int64_t first_ns_ = 0, last_ns_ = 0;
  long short_stops_ = 0;
};

}  // namespace sph::can

#endif  // SPH_CAN_STANDSTILL_HPP_
