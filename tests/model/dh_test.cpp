#include "sph/model/dh.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "test_util.hpp"

namespace sph {
namespace {

using sph::testing::MatrixNear;

template <typename T>
class DhTransformTyped : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(DhTransformTyped, Scalars);

// Tolerances: a few ulps of the result's magnitude (<= 20) in each precision.
template <typename T>
double Tol() {
  return std::is_same_v<T, float> ? 1e-5 : 1e-13;
}

TYPED_TEST(DhTransformTyped, ZeroAnglesIsPureTranslation) {
  using T = TypeParam;
  const Mat4<T> m = DhTransform(T(0), T(3), T(2), T(0));
  Mat4<T> expected = Mat4<T>::Identity();
  expected(0, 3) = T(2);
  expected(2, 3) = T(3);
  EXPECT_PRED_FORMAT3(MatrixNear, m, expected, Tol<T>());
}

TYPED_TEST(DhTransformTyped, EqualsComposedElementaryTransforms) {
  using T = TypeParam;
  const double theta = 0.7, d = -1.3, a = 4.2, alpha = -2.1;
  const Eigen::Affine3d composed = Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()) *
                                   Eigen::Translation3d(0, 0, d) * Eigen::Translation3d(a, 0, 0) *
                                   Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX());
  const Mat4<T> m = DhTransform(T(theta), T(d), T(a), T(alpha));
  EXPECT_PRED_FORMAT3(MatrixNear, m, composed.matrix(), Tol<T>());
}

TYPED_TEST(DhTransformTyped, RotZIsDhWithoutOffsets) {
  using T = TypeParam;
  EXPECT_PRED_FORMAT3(MatrixNear, RotZ(T(0.3)), DhTransform(T(0.3), T(0), T(0), T(0)), Tol<T>());
}

TEST(SinCosOf, MatchesSinAndCos) {
  for (double x : {-3.0, -0.5, 0.0, 1e-9, 1.2, 7.0}) {
    const SinCos<double> t = SinCosOf(x);
    EXPECT_EQ(t.sin, std::sin(x));
    EXPECT_EQ(t.cos, std::cos(x));
  }
}

}  // namespace
}  // namespace sph
