// What the probe's noise alone makes of a sphere's form statistics.
//
// Peak-to-valley and minimum-zone values are extremes: of n readings with noise sigma, their range
// grows like sigma times the expected range of n normal values (5.7 sigma for 288 readings, 6.9 for
// 2000), whether or not the sphere has any form error. A sphericity means little without this
// floor beside it. It is found here by simulation at the very directions measured: pure noise
// (normal, sigma) on a perfect sphere of the fitted centre and radius, fitted as the measurement
// was (least squares; the minimum zone from the least-squares centre), `draws` times, giving the
// mean and std of each statistic. The RMS has a noise-corrected estimate, the form's own RMS:
// sqrt(max(0, rms^2 - sigma^2 (n - 4) / n)) (the least-squares residual of pure noise has expected
// mean square sigma^2 (n - 4) / n); PV and MZ have none (an extreme does not subtract).
#ifndef SPH_MEASURE_NOISE_FLOOR_HPP_
#define SPH_MEASURE_NOISE_FLOOR_HPP_

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace sph {

struct NoiseFloorOptions {
  int draws = 50;              ///< simulated measurements of pure noise
  std::uint64_t seed = 1;      ///< of the draws (sph::Random: the same on every compiler)
  long max_mz_points = 20000;  ///< above this many points the minimum zone of the draws is not computed
};

/// Form statistics of pure noise at the measured directions; lengths in mm.
struct FormNoiseFloor {
  double sigma_mm = 0.0;
  int draws = 0;
  double ls_pv_mean_mm = 0.0, ls_pv_std_mm = 0.0;  ///< peak-to-valley of the least-squares residuals
  double mz_mean_mm = 0.0, mz_std_mm = 0.0;        ///< minimum-zone width; NaN when not computed
  double rms_form_mm = 0.0;                        ///< noise-corrected RMS of the measured residuals

  /// A measured value within mean + 2 std of the noise's own: indistinguishable from noise.
  static bool Within(double value, double mean, double std) { return value <= mean + 2.0 * std; }
};

/// The floor for `points` whose least-squares sphere is (center, radius) with residual RMS `rms_mm`.
FormNoiseFloor EstimateFormNoiseFloor(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center_mm,
                                      double radius_mm, double rms_mm, double sigma_mm,
                                      const NoiseFloorOptions& options = NoiseFloorOptions());

}  // namespace sph

#endif  // SPH_MEASURE_NOISE_FLOOR_HPP_
