#include "sph/calib/observability.hpp"

#include <random>

#include <Eigen/LU>

#include <gtest/gtest.h>

#include "test_util.hpp"

namespace sph {
namespace {

std::vector<ParameterDescription> Lengths(int n) {
  std::vector<ParameterDescription> d;
  for (int i = 0; i < n; ++i) d.push_back({"p" + std::to_string(i), Quantity::kLength, 1.0});
  return d;
}

TEST(AnalyseFit, CovarianceIsScaledInverseNormalMatrix) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::MatrixXd j(50, 3);
  Eigen::VectorXd e(50);
  for (int r = 0; r < 50; ++r) {
    j.row(r) << g(rng), 100.0 * g(rng), 0.01 * g(rng);  // columns of very different scale
    e(r) = 1e-4 * g(rng);
  }
  const ObservabilityReport rep = AnalyseFit(j, e, Lengths(3), 1e9);
  const double s2 = e.squaredNorm() / 47.0;
  const Eigen::MatrixXd expected = s2 * (j.transpose() * j).inverse();
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) EXPECT_NEAR(rep.covariance(a, b), expected(a, b), 1e-9 * std::abs(expected(a, a)));
    EXPECT_NEAR(rep.std(a), std::sqrt(expected(a, a)), 1e-9 * std::sqrt(expected(a, a)));
    EXPECT_NEAR(rep.correlation(a, a), 1.0, 1e-12);
  }
  EXPECT_TRUE(rep.AllDetermined());
}

TEST(AnalyseFit, ExactlyDependentColumnsAreUndetermined) {
  Eigen::MatrixXd j(20, 3);
  for (int r = 0; r < 20; ++r) j.row(r) << 1.0, r, 2.0 * r;  // col2 = 2 col1
  const Eigen::VectorXd e = Eigen::VectorXd::Constant(20, 1e-3);
  const ObservabilityReport rep = AnalyseFit(j, e, Lengths(3), 1e9);
  EXPECT_TRUE(rep.determined[0]);
  EXPECT_FALSE(rep.determined[1]);
  EXPECT_FALSE(rep.determined[2]);
  EXPECT_TRUE(std::isinf(rep.std(1)));
  EXPECT_TRUE(std::isinf(rep.condition_number) || rep.condition_number > 1e12);
  ASSERT_FALSE(rep.weak.empty());
  // The null direction is p1 + 0.5 p2 -> coefficients +1 and -0.5 after normalising.
  ASSERT_EQ(rep.weak[0].terms.size(), 2u);
  EXPECT_EQ(rep.weak[0].terms[0].first, 1);
  EXPECT_NEAR(rep.weak[0].terms[0].second, 1.0, 1e-9);
  EXPECT_NEAR(rep.weak[0].terms[1].second, -0.5, 1e-9);
}

TEST(AnalyseFit, ThresholdUsesTheLeverArmForAngles) {
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(4, 1);
  j.col(0) << 1, 1, 1, 1;
  Eigen::VectorXd e(4);
  e << 1e-3, -1e-3, 1e-3, -1e-3;  // s = 1.15e-3, std = s / 2 = 0.577e-3 (rad or mm)
  auto lengths = AnalyseFit(j, e, {{"x", Quantity::kLength, 1.0}}, 1.0);
  EXPECT_TRUE(lengths.determined[0]);  // 0.58 um <= 1 um
  auto angle = AnalyseFit(j, e, {{"t", Quantity::kAngle, 20.0}}, 1.0);
  EXPECT_FALSE(angle.determined[0]);  // 0.58e-3 rad * 20 mm = 11.5 um > 1 um
  EXPECT_NEAR(angle.StdAsDisplacementUm(0), 20.0 * angle.std(0) * 1e3, 1e-9);
}

}  // namespace
}  // namespace sph
