#include "sph/model/dh.hpp"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

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
  const Eigen::Affine3d composed = Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()) * Eigen::Translation3d(0, 0, d) *
                                   Eigen::Translation3d(a, 0, 0) * Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX());
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

// A dual number of the shape SinCosOf() recognises (a value `a`, a derivative vector `v`, T(a, v)),
// whose own sin and cos count their calls.
struct Dual {
  double a = 0.0;
  Eigen::Vector2d v = Eigen::Vector2d::Zero();
  Dual() = default;
  template <typename Derived>
  Dual(double value, const Eigen::MatrixBase<Derived>& derivative) : a(value), v(derivative) {}
};
int dual_trig_calls = 0;
Dual sin(const Dual& x) {
  ++dual_trig_calls;
  return Dual(std::sin(x.a), std::cos(x.a) * x.v);
}
Dual cos(const Dual& x) {
  ++dual_trig_calls;
  return Dual(std::cos(x.a), -std::sin(x.a) * x.v);
}

// Whatever was included before: the model headers take a dual number's sine and cosine from one
// scalar sine and cosine, never through its own sin and cos, and get the same values.
TEST(SinCosOf, TakesADualNumbersSineAndCosineFromItsValuePart) {
  const Dual x(0.7, Eigen::Vector2d(1.0, -2.0));
  dual_trig_calls = 0;
  const SinCos<Dual> t = SinCosOf(x);
  EXPECT_EQ(dual_trig_calls, 0);
  const Dual s = sin(x), c = cos(x);
  EXPECT_EQ(t.sin.a, s.a);
  EXPECT_EQ(t.cos.a, c.a);
  EXPECT_EQ(t.sin.v, s.v);
  EXPECT_EQ(t.cos.v, c.v);
}

}  // namespace
}  // namespace sph
