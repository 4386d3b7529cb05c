#include "sph/model/scms_model.hpp"

#include <random>

#include <gtest/gtest.h>

#include "test_util.hpp"

namespace sph {
namespace {

using sph::testing::MatrixNear;

// Model outputs are ~20 mm; double arithmetic through a few transforms is good to ~1e-14 mm.
constexpr double kTolerance = 1e-12;  // mm

constexpr double kD = 25.0;  // nominal probe zero distance [mm]

ScmsGeometry Only(int param, double value) {
  ScmsGeometry g{};
  g[static_cast<std::size_t>(param)] = value;
  return g;
}

// Spherical coordinates: the model with all errors zero.
Eigen::Vector3d Nominal(double theta, double phi, double r, double d) {
  return (d - r) * Eigen::Vector3d(std::sin(phi) * std::cos(theta), std::sin(phi) * std::sin(theta), std::cos(phi));
}

TEST(ScmsPoint, CheckValuesOfTheModelDescription) {
  const ScmsGeometry zero{};
  EXPECT_PRED_FORMAT3(MatrixNear, ScmsPoint(zero, 0.0, kPi / 2, 5.0, kD), Eigen::Vector3d(20, 0, 0), kTolerance);
  EXPECT_PRED_FORMAT3(MatrixNear, ScmsPoint(zero, 0.0, 0.0, 5.0, kD), Eigen::Vector3d(0, 0, 20), kTolerance);
}

TEST(ScmsPoint, ZeroErrorsAreSphericalCoordinates) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-4.0, 4.0), reading(0.0, 10.0);
  const ScmsGeometry zero{};
  for (int i = 0; i < 100; ++i) {
    const double theta = angle(rng), phi = angle(rng), r = reading(rng);
    EXPECT_PRED_FORMAT3(MatrixNear, ScmsPoint(zero, theta, phi, r, kD), Nominal(theta, phi, r, kD), kTolerance);
  }
}

// The expectations below were worked out by hand by composing the elementary transforms of
// Eq. (1) with one error non-zero; z = r - (d + d') is the probe point on the probe line.
constexpr double kTheta = 0.5236;  // ~30 deg
constexpr double kPhi = 1.0472;    // ~60 deg
constexpr double kR = 5.0;

TEST(ScmsPoint, ProbeZeroErrorScalesTheRadius) {
  // d' only: the point is at distance d + d' - r from the axes' common point.
  const double dp = -0.062;
  EXPECT_PRED_FORMAT3(MatrixNear, ScmsPoint(Only(kDPrime, dp), kTheta, kPhi, kR, kD),
                      Nominal(kTheta, kPhi, kR, kD + dp), kTolerance);
}

TEST(ScmsPoint, AxisOffsetShiftsAlongTheRotatedX) {
  // a only: Rz(theta) (Rx(pi/2) s + [a, 0, 0]) = nominal + a (cos theta, sin theta, 0).
  const double a = 0.002;
  const Eigen::Vector3d expected =
      Nominal(kTheta, kPhi, kR, kD) + a * Eigen::Vector3d(std::cos(kTheta), std::sin(kTheta), 0);
  EXPECT_PRED_FORMAT3(MatrixNear, ScmsPoint(Only(kA, a), kTheta, kPhi, kR, kD), expected, kTolerance);
}

TEST(ScmsPoint, ProbeOffsetAlongPhiAxisShiftsSideways) {
  // b only: q = [0, -z, b]; Rz(-phi) q = [-z sin phi, -z cos phi, b]; Rx(pi/2) gives
  // [-z sin phi, -b, -z cos phi]; so p = nominal + b (sin theta, -cos theta, 0).
  const double b = 0.003;
  const Eigen::Vector3d expected =
      Nominal(kTheta, kPhi, kR, kD) + b * Eigen::Vector3d(std::sin(kTheta), -std::cos(kTheta), 0);
  EXPECT_PRED_FORMAT3(MatrixNear, ScmsPoint(Only(kB, b), kTheta, kPhi, kR, kD), expected, kTolerance);
}

TEST(ScmsPoint, ProbeLineOffsetShiftsAlongTheMeridian) {
  // c only: q = [c, -z, 0]; Rz(-phi) q = [c cos phi - z sin phi, -c sin phi - z cos phi, 0];
  // Rx(pi/2) gives [x, 0, y]; so p = nominal + c (cos phi cos theta, cos phi sin theta, -sin phi).
  const double c = -0.004;
  const Eigen::Vector3d expected =
      Nominal(kTheta, kPhi, kR, kD) +
      c * Eigen::Vector3d(std::cos(kPhi) * std::cos(kTheta), std::cos(kPhi) * std::sin(kTheta), -std::sin(kPhi));
  EXPECT_PRED_FORMAT3(MatrixNear, ScmsPoint(Only(kC, c), kTheta, kPhi, kR, kD), expected, kTolerance);
}

TEST(ScmsPoint, AxisAngleErrorTiltsTheSwingPlane) {
  // alpha only: s = [-z sin phi, -z cos phi, 0]; Rx(pi/2 + alpha) s = [-z sin phi,
  // z cos phi sin alpha, -z cos phi cos alpha]; then Rz(theta).
  const double alpha = 0.01;
  const double z = kR - kD;
  const Eigen::Vector3d s(-z * std::sin(kPhi), z * std::cos(kPhi) * std::sin(alpha),
                          -z * std::cos(kPhi) * std::cos(alpha));
  const Eigen::Vector3d expected(std::cos(kTheta) * s.x() - std::sin(kTheta) * s.y(),
                                 std::sin(kTheta) * s.x() + std::cos(kTheta) * s.y(), s.z());
  EXPECT_PRED_FORMAT3(MatrixNear, ScmsPoint(Only(kAlpha, alpha), kTheta, kPhi, kR, kD), expected, kTolerance);
}

TEST(ScmsPoint, ProbeZeroAngleErrorIsAPhiOffset) {
  // beta only: Rz(-phi) Rz(beta) = Rz(-(phi - beta)): the point is nominal at phi - beta.
  const double beta = 0.02;
  EXPECT_PRED_FORMAT3(MatrixNear, ScmsPoint(Only(kBeta, beta), kTheta, kPhi, kR, kD),
                      Nominal(kTheta, kPhi - beta, kR, kD), kTolerance);
}

TEST(ScmsPoint, ProbeTiltLeavesThePhiPlane) {
  // epsilon only: q = [0, -z cos eps, -z sin eps]; Rz(-phi) q = [-z cos eps sin phi,
  // -z cos eps cos phi, -z sin eps]; Rx(pi/2) gives [x, z sin eps, y]; then Rz(theta).
  const double eps = -0.015;
  const double z = kR - kD;
  const Eigen::Vector3d s(-z * std::cos(eps) * std::sin(kPhi), z * std::sin(eps), -z * std::cos(eps) * std::cos(kPhi));
  const Eigen::Vector3d expected(std::cos(kTheta) * s.x() - std::sin(kTheta) * s.y(),
                                 std::sin(kTheta) * s.x() + std::cos(kTheta) * s.y(), s.z());
  EXPECT_PRED_FORMAT3(MatrixNear, ScmsPoint(Only(kEpsilon, eps), kTheta, kPhi, kR, kD), expected, kTolerance);
}

TEST(ScmsPoint, FastFormEqualsTheMatrixProduct) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> angle(-4.0, 4.0), small(-0.05, 0.05), reading(0.0, 10.0);
  for (int i = 0; i < 200; ++i) {
    ScmsGeometry g;
    for (double& v : g) v = small(rng);
    const double theta = angle(rng), phi = angle(rng), r = reading(rng);
    EXPECT_PRED_FORMAT3(MatrixNear, ScmsPoint(g, theta, phi, r, kD), ScmsPointDh(g.data(), theta, phi, r, kD),
                        kTolerance);
  }
}

TEST(ScmsPoint, FloatInstantiationAgreesWithDouble) {
  const ScmsGeometry g{1e-3, 2e-3, -1e-3, 1e-3, 2e-3, -2e-3, -0.06};
  std::array<float, kNumScmsParams> gf;
  for (std::size_t i = 0; i < g.size(); ++i) gf[i] = static_cast<float>(g[i]);
  const Vec3<float> pf = ScmsPoint(gf.data(), 0.4f, 1.1f, 5.0f, 25.0f);
  EXPECT_PRED_FORMAT3(MatrixNear, pf, ScmsPoint(g, 0.4, 1.1, 5.0, 25.0), 1e-4);
}

TEST(ScmsParamInfo, UnitConversionRoundTrips) {
  for (int p = 0; p < kNumScmsParams; ++p) {
    EXPECT_DOUBLE_EQ(FromReportUnits(p, ToReportUnits(p, 0.0123)), 0.0123);
  }
  EXPECT_DOUBLE_EQ(ToReportUnits(kAlpha, kPi), 180.0);
  EXPECT_DOUBLE_EQ(ToReportUnits(kA, 2.5), 2.5);
}

}  // namespace
}  // namespace sph
