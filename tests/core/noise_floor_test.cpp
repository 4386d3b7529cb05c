#include "sph/measure/noise_floor.hpp"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "sph/sphere/sphere_fit.hpp"

namespace sph {
namespace {

// The expected range of n independent standard normal values, by the trapezoidal rule on
// E[R_n] = integral of 1 - Phi(x)^n - (1 - Phi(x))^n dx (David and Nagaraja, Order Statistics).
double ExpectedRange(int n) {
  double sum = 0.0;
  const double h = 1e-3;
  for (double x = -10.0; x <= 10.0; x += h) {
    const double phi = 0.5 * std::erfc(-x / std::sqrt(2.0));
    sum += (1.0 - std::pow(phi, n) - std::pow(1.0 - phi, n)) * h;
  }
  return sum;
}

// Directions of a 24 x 12 grid (the paper's) on a sphere of radius 20 mm about (1, 2, 3).
std::vector<Eigen::Vector3d> Grid(double form_amplitude_mm) {
  std::vector<Eigen::Vector3d> points;
  const Eigen::Vector3d c(1.0, 2.0, 3.0);
  for (int i = 0; i < 24; ++i) {
    for (int j = 0; j < 12; ++j) {
      const double t = 2.0 * M_PI * i / 24.0, p = M_PI * (j + 0.5) / 12.0;
      const Eigen::Vector3d u(std::sin(p) * std::cos(t), std::sin(p) * std::sin(t), std::cos(p));
      // A form of degree 3 (zonal): it does not move the least-squares centre or radius.
      const double form = form_amplitude_mm * (5.0 * std::pow(u.z(), 3) - 3.0 * u.z()) / 2.0;
      points.push_back(c + (20.0 + form) * u);
    }
  }
  return points;
}

TEST(FormNoiseFloor, PeakToValleyOfPureNoiseIsTheExpectedRangeOfNormalValues) {
  const std::vector<Eigen::Vector3d> points = Grid(0.0);
  const double sigma = 50e-6;
  NoiseFloorOptions o;
  o.draws = 200;
  // The residual rms pure noise has on average: sigma sqrt((n - 4) / n).
  const double rms = sigma * std::sqrt(284.0 / 288.0);
  const FormNoiseFloor f = EstimateFormNoiseFloor(points, Eigen::Vector3d(1, 2, 3), 20.0, rms, sigma, o);
  // E[R_288] = 5.7 sigma; the least-squares fit takes 4 degrees of freedom out of 288, which
  // shrinks the range by far less than the draws' 1 % standard error of the mean.
  const double expected = ExpectedRange(288) * sigma;
  EXPECT_NEAR(expected / sigma, 5.70, 0.05);
  EXPECT_NEAR(f.ls_pv_mean_mm / expected, 1.0, 0.03);
  // The range's own scatter: about 0.5 sigma for n in the hundreds.
  EXPECT_GT(f.ls_pv_std_mm, 0.3 * sigma);
  EXPECT_LT(f.ls_pv_std_mm, 0.8 * sigma);
  // The minimum zone of noise is below its least-squares peak-to-valley, never above.
  EXPECT_LT(f.mz_mean_mm, f.ls_pv_mean_mm);
  EXPECT_GT(f.mz_mean_mm, 0.7 * f.ls_pv_mean_mm);
  // Residual rms equal to the noise's own: no form left.
  EXPECT_NEAR(f.rms_form_mm, 0.0, 1e-12);
}

TEST(FormNoiseFloor, AFormErrorAboveTheNoiseIsTold) {
  // 0.5 um of degree-3 form and 0.05 um of noise (independent of the draws' generator).
  std::vector<Eigen::Vector3d> points = Grid(0.5e-3);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 50e-6);
  const Eigen::Vector3d c(1.0, 2.0, 3.0);
  for (Eigen::Vector3d& p : points) p = c + ((p - c).norm() + noise(rng)) * (p - c).normalized();
  const LeastSquaresSphere ls = FitSphereLeastSquares(points);
  double lo = 1e9, hi = -1e9;
  for (const Eigen::Vector3d& p : points) {
    const double e = (p - ls.sphere.center).norm() - ls.sphere.radius;
    lo = std::min(lo, e);
    hi = std::max(hi, e);
  }
  const FormNoiseFloor f = EstimateFormNoiseFloor(points, ls.sphere.center, ls.sphere.radius, ls.rms, 50e-6);
  EXPECT_FALSE(FormNoiseFloor::Within(hi - lo, f.ls_pv_mean_mm, f.ls_pv_std_mm));
  // The noise-corrected rms finds the rms the form alone has about its least-squares sphere
  // (the noise-free points fitted) within 10 %.
  const LeastSquaresSphere form_only = FitSphereLeastSquares(Grid(0.5e-3));
  EXPECT_NEAR(f.rms_form_mm / form_only.rms, 1.0, 0.1);
}

TEST(FormNoiseFloor, RefusesWhatItCannotDo) {
  const std::vector<Eigen::Vector3d> points = Grid(0.0);
  EXPECT_THROW(EstimateFormNoiseFloor(points, Eigen::Vector3d(1, 2, 3), 20.0, 0.0, 0.0), Error);
  EXPECT_THROW(EstimateFormNoiseFloor({points.begin(), points.begin() + 4}, Eigen::Vector3d(1, 2, 3), 20.0, 0.0, 1e-4),
               Error);
}

}  // namespace
}  // namespace sph
