#include "sph/sphere/sphere_fit.hpp"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "sph/model/units.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using sph::testing::MatrixNear;

std::vector<Eigen::Vector3d> PointsOnSphere(const Eigen::Vector3d& c, double radius, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d u = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    pts.push_back(c + radius * u);
  }
  return pts;
}

TEST(FitSphereAlgebraic, ExactOnPointsOnASphere) {
  const Eigen::Vector3d c(2.0, -1.0, 0.5);
  const Sphere s = FitSphereAlgebraic(PointsOnSphere(c, 20.0, 50, 3));
  ASSERT_TRUE(s.ok);
  EXPECT_PRED_FORMAT3(MatrixNear, s.center, c, 1e-11);
  EXPECT_NEAR(s.radius, 20.0, 1e-11);
}

TEST(FitSphereAlgebraic, FarFromTheOriginStaysAccurate) {
  const Eigen::Vector3d c(-650.0, 250.0, 700.0);
  const Sphere s = FitSphereAlgebraic(PointsOnSphere(c, 13.5, 40, 5));
  ASSERT_TRUE(s.ok);
  EXPECT_PRED_FORMAT3(MatrixNear, s.center, c, 1e-9);
  EXPECT_NEAR(s.radius, 13.5, 1e-9);
}

TEST(FitSphereAlgebraic, RejectsTooFewAndDegeneratePoints) {
  EXPECT_FALSE(FitSphereAlgebraic(PointsOnSphere(Eigen::Vector3d::Zero(), 1.0, 3, 1)).ok);
  std::vector<Eigen::Vector3d> plane;
  for (int i = 0; i < 10; ++i) plane.emplace_back(std::cos(i), std::sin(i), 0.0);
  EXPECT_FALSE(FitSphereAlgebraic(plane).ok);
  EXPECT_FALSE(FitSphereAlgebraic(std::vector<Eigen::Vector3d>(10, Eigen::Vector3d(1, 2, 3))).ok);
}

// Points spread evenly (Fibonacci lattice) over the cap of directions within `half_angle_deg` of +z.
std::vector<Eigen::Vector3d> EvenCap(const Eigen::Vector3d& c, double radius, double half_angle_deg, int n) {
  const double z_min = std::cos(half_angle_deg * kPi / 180.0);
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (1.0 - z_min) * (i + 0.5) / n;
    const double s = std::sqrt(1.0 - z * z);
    pts.push_back(c + radius * Eigen::Vector3d(s * std::cos(golden * i), s * std::sin(golden * i), z));
  }
  return pts;
}

// Sum of squared geometric residuals.
double Cost(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& c, double r) {
  double s = 0.0;
  for (const auto& p : pts) s += std::pow((p - c).norm() - r, 2);
  return s;
}

TEST(FitSphereLeastSquares, ExactOnPointsOnASphere) {
  const Eigen::Vector3d c(2.0, -1.0, 0.5);
  const LeastSquaresSphere fit = FitSphereLeastSquares(PointsOnSphere(c, 20.0, 50, 3));
  ASSERT_TRUE(fit.sphere.ok);
  EXPECT_TRUE(fit.converged);
  EXPECT_PRED_FORMAT3(MatrixNear, fit.sphere.center, c, 1e-12);
  EXPECT_NEAR(fit.sphere.radius, 20.0, 1e-12);
  EXPECT_LT(fit.rms, 1e-13);
}

TEST(FitSphereLeastSquares, IsAMinimumOfTheGeometricCostWhereTheAlgebraicFitIsNot) {
  // A noisy cap: the algebraic fit is biased here, the geometric fit is the minimum of
  // sum (|p - c| - R)^2. Its gradient vanishes, so any small move raises the cost.
  std::vector<Eigen::Vector3d> pts = EvenCap(Eigen::Vector3d(1, 2, 3), 10.0, 50.0, 200);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (auto& p : pts) p += noise(rng) * (p - Eigen::Vector3d(1, 2, 3)).normalized();
  const LeastSquaresSphere fit = FitSphereLeastSquares(pts);
  ASSERT_TRUE(fit.sphere.ok);
  ASSERT_TRUE(fit.converged);
  const double best = Cost(pts, fit.sphere.center, fit.sphere.radius);
  EXPECT_NEAR(fit.rms, std::sqrt(best / 200.0), 1e-15);
  for (int k = 0; k < 4; ++k) {
    for (const double h : {1e-4, -1e-4}) {
      Eigen::Vector4d x;
      x << fit.sphere.center, fit.sphere.radius;
      x(k) += h;
      EXPECT_GT(Cost(pts, x.head<3>(), x(3)), best) << "parameter " << k << " step " << h;
    }
  }
  const Sphere algebraic = FitSphereAlgebraic(pts);
  EXPECT_GT(Cost(pts, algebraic.center, algebraic.radius), best * (1.0 + 1e-6));
  EXPECT_GT((algebraic.center - fit.sphere.center).norm(), 1e-3);
}

TEST(FitSphereLeastSquares, DilutionMeasuresTheCoverage) {
  // The values quoted in LeastSquaresSphere's documentation: 1 for the whole sphere, 2 for a
  // hemisphere, about 5, 10 and 24 for caps of half-angle 60, 45 and 30 deg.
  const Eigen::Vector3d c(0.5, 0.0, -0.5);
  const auto dilution = [&](double half_angle_deg) {
    const LeastSquaresSphere fit = FitSphereLeastSquares(EvenCap(c, 20.0, half_angle_deg, 4000));
    EXPECT_TRUE(fit.sphere.ok);
    return std::make_pair(fit.RadiusDilution(), fit.CenterDilution());
  };
  const auto full = dilution(180.0);
  EXPECT_NEAR(full.first, 1.0, 0.01);
  EXPECT_NEAR(full.second, 1.0, 0.01);
  const auto hemisphere = dilution(90.0);
  EXPECT_NEAR(hemisphere.first, 2.0, 0.01);
  EXPECT_NEAR(hemisphere.second, 2.0, 0.01);
  EXPECT_NEAR(dilution(60.0).first, 5.3, 0.1);
  EXPECT_NEAR(dilution(45.0).first, 10.1, 0.2);
  EXPECT_NEAR(dilution(30.0).first, 24.1, 0.2);
}

TEST(FitSphereLeastSquares, RejectsTooFewAndDegeneratePoints) {
  EXPECT_FALSE(FitSphereLeastSquares(PointsOnSphere(Eigen::Vector3d::Zero(), 1.0, 3, 1)).sphere.ok);
  std::vector<Eigen::Vector3d> plane;
  for (int i = 0; i < 10; ++i) plane.emplace_back(std::cos(i), std::sin(i), 0.0);
  EXPECT_FALSE(FitSphereLeastSquares(plane).sphere.ok);
}

}  // namespace
}  // namespace sph
