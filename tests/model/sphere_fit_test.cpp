#include "sph/model/sphere_fit.hpp"

#include <random>

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace sph
