// The effect terms of sph/model/effects.hpp against values worked by hand, each effect alone on
// the nominal machine (all seven errors zero), where p = rho (sin phi cos theta, sin phi sin theta,
// cos phi) with rho = d - r.
#include "sph/model/effects.hpp"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "sph/model/units.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

constexpr double kD = 25.0;
constexpr double kTol = 1e-12;  // mm: rounding of a few operations on 20 mm

// The point of one reading with one term of one component.
Eigen::Vector3d PointWith(Effect e, EffectComponent c, double value, double theta_deg, double phi_deg, double r_mm,
                          double t_s = 0.0, EffectReference ref = {}) {
  EffectModel model;
  model.terms = {{e, {c}}};
  model.reference = ref;
  return EffectScmsPoint(ScmsGeometry{}, model, {{value}}, EffectReading(theta_deg, phi_deg, r_mm, t_s), kD);
}

Eigen::Vector3d Nominal(double theta_rad, double phi_rad, double rho) {
  return rho * Eigen::Vector3d(std::sin(phi_rad) * std::cos(theta_rad), std::sin(phi_rad) * std::sin(theta_rad),
                               std::cos(phi_rad));
}

TEST(EffectScmsPoint, WithoutTermsIsScmsPointBitForBit) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    ScmsGeometry g;
    for (double& v : g) v = 1e-3 * u(rng);
    const EffectReading x(180 * (1 + u(rng)), 90 * (1 + u(rng)), 5 + u(rng), 0.0);
    const Eigen::Vector3d a = EffectScmsPoint(g, EffectModel{}, {}, x, kD);
    const Eigen::Vector3d b = ScmsPoint(g, x.theta_rad, x.phi_rad, x.r_mm, kD);
    EXPECT_EQ(a, b);
  }
}

TEST(EffectScmsPoint, ThetaEncoderTurnsThePointAboutTheThetaAxis) {
  // c1 = delta at theta = 0: theta_true = delta.
  const double delta = 20 * kRadPerArcsec;
  const Eigen::Vector3d p = PointWith(Effect::kThetaEncoder, {1, 0, false}, delta, 0.0, 60.0, 5.0);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, p, Nominal(delta, 60 * kRadPerDeg, 20.0), kTol);
  // s2 at theta = 45 deg: sin(90 deg) = 1, so theta_true = 45 deg + value.
  const Eigen::Vector3d q = PointWith(Effect::kThetaEncoder, {2, 0, true}, delta, 45.0, 60.0, 5.0);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, q, Nominal(45 * kRadPerDeg + delta, 60 * kRadPerDeg, 20.0), kTol);
}

TEST(EffectScmsPoint, PhiEncoderChangesThePolarAngle) {
  const double delta = -15 * kRadPerArcsec;
  const Eigen::Vector3d p = PointWith(Effect::kPhiEncoder, {1, 0, false}, delta, 30.0, 0.0, 5.0);  // cos(0) = 1
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, p, Nominal(30 * kRadPerDeg, delta, 20.0), kTol);
}

// ISO 230-2's reversal value b: the axis stands at reading + b/2 when approached from below (d =
// +1), at reading - b/2 from above (d = -1), at the reading when the direction is not known.
TEST(EffectScmsPoint, ReversalShiftsTheAxisByHalfItsValueInTheDirectionOfApproach) {
  const double b = 8 * kRadPerArcsec;
  EffectModel model;
  model.terms = {DefaultTerm(Effect::kThetaReversal), DefaultTerm(Effect::kPhiReversal)};
  ASSERT_EQ(model.terms[0].size(), 1);
  EXPECT_EQ(model.terms[0].ParamName(0), "theta_reversal.b");
  EXPECT_EQ(model.terms[1].ParamName(0), "phi_reversal.b");
  const double th = 40 * kRadPerDeg, ph = 70 * kRadPerDeg;
  auto point = [&](double theta_b, double phi_b, MotionDirection d) {
    return EffectScmsPoint(ScmsGeometry{}, model, {{theta_b}, {phi_b}}, EffectReading({40.0, 70.0, 5.0}, 0.0, d), kD);
  };
  // Theta: 40 deg + 4 arcsec from below, 40 deg - 4 arcsec from above; phi stays.
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, point(b, 0.0, {1, 1}), Nominal(th + 0.5 * b, ph, 20.0), kTol);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, point(b, 0.0, {-1, 1}), Nominal(th - 0.5 * b, ph, 20.0), kTol);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, point(b, 0.0, {0, 1}), Nominal(th, ph, 20.0), kTol);
  // Phi the same (a negative value: the positive approach falls short).
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, point(0.0, -b, {1, -1}), Nominal(th, ph + 0.5 * b, 20.0), kTol);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, point(0.0, -b, {1, 1}), Nominal(th, ph - 0.5 * b, 20.0), kTol);
  // The two differ by b between the directions: rho b sin phi along the Theta circle, 20 mm *
  // 8 arcsec * sin 70 deg = 0.7289 um.
  EXPECT_NEAR((point(b, 0.0, {1, 1}) - point(b, 0.0, {-1, 1})).norm() * kUmPerMm, 20.0 * b * std::sin(ph) * kUmPerMm,
              1e-9);
  EXPECT_NEAR(20.0 * b * std::sin(ph) * kUmPerMm, 0.7289, 1e-4);
}

TEST(EffectScmsPoint, SpindleMotionsMoveTheSphereInTheMachineFrame) {
  // x_c2 = A at theta = 0: the sphere moves by +A along machine x, so the point relative to it by -A.
  const double a = 0.3e-3;
  const Eigen::Vector3d p = PointWith(Effect::kThetaRadialMotion, {2, 0, false}, a, 0.0, 70.0, 5.0);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, p, Nominal(0.0, 70 * kRadPerDeg, 20.0) - Eigen::Vector3d(a, 0, 0),
                      kTol);
  // y_s3 at theta = 30 deg (sin 90 deg = 1): machine y, turned by theta into the sphere frame.
  const double th = 30 * kRadPerDeg;
  const Eigen::Vector3d q = PointWith(Effect::kThetaRadialMotion, {3, 1, true}, a, 30.0, 70.0, 5.0);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, q,
                      Nominal(th, 70 * kRadPerDeg, 20.0) - a * Eigen::Vector3d(-std::sin(th), std::cos(th), 0), kTol);
  // Axial c1 = A at theta = 0: along the Theta axis.
  const Eigen::Vector3d z = PointWith(Effect::kThetaAxialMotion, {1, 0, false}, a, 0.0, 70.0, 5.0);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, z, Nominal(0.0, 70 * kRadPerDeg, 20.0) - Eigen::Vector3d(0, 0, a),
                      kTol);
}

TEST(EffectScmsPoint, PhiWobbleTiltsThePhiFrame) {
  // x_c1 = w: a tilt w cos(phi) about the Phi frame's x axis. On the nominal machine the point in
  // the Phi frame is rho (sin phi, cos phi, 0); Rx(t) makes it rho (sin phi, cos phi cos t,
  // cos phi sin t), and the machine frame (Rx(pi/2)) rho (sin phi, -cos phi sin t, cos phi cos t).
  const double w = 30 * kRadPerArcsec, phi = 50 * kRadPerDeg, t = w * std::cos(phi), rho = 20.0;
  const Eigen::Vector3d p = PointWith(Effect::kPhiWobble, {1, 0, false}, w, 0.0, 50.0, 5.0);
  const Eigen::Vector3d expected(rho * std::sin(phi), -rho * std::cos(phi) * std::sin(t),
                                 rho * std::cos(phi) * std::cos(t));
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, p, expected, kTol);
}

TEST(EffectScmsPoint, PhiWobblePivotsAtTheBearing) {
  // x_c1 = w with the pivot L along the Phi axis: s - L e_z = (rho sin phi, rho cos phi, -L) turned
  // by t = w cos(phi) about x, L e_z added back: (rho sin phi, rho cos phi cos t + L sin t,
  // rho cos phi sin t + L (1 - cos t)); in the machine frame (x, -z, y).
  const double w = 30 * kRadPerArcsec, phi = 50 * kRadPerDeg, t = w * std::cos(phi), rho = 20.0, pivot = 80.0;
  EffectModel model;
  model.terms = {{Effect::kPhiWobble, {{1, 0, false}}}};
  model.phi_wobble_pivot_mm = pivot;
  const Eigen::Vector3d p = EffectScmsPoint(ScmsGeometry{}, model, {{w}}, EffectReading(0.0, 50.0, 5.0, 0.0), kD);
  const Eigen::Vector3d expected(rho * std::sin(phi),
                                 -(rho * std::cos(phi) * std::sin(t) + pivot * (1.0 - std::cos(t))),
                                 rho * std::cos(phi) * std::cos(t) + pivot * std::sin(t));
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, p, expected, kTol);
  // At first order the probe moves by L t along the Phi frame's y, machine z: 80 mm x 70 urad.
  EXPECT_NEAR(p.z() - rho * std::cos(phi), pivot * t, 1e-6);
}

TEST(EffectScmsPoint, PhiAxisMotionsMoveTheProbeInThePhiFrame) {
  // On the nominal machine the Phi frame's x, y, z are machine x, z, -y (Rx(pi/2)).
  const double a = 0.4e-3, th = 30 * kRadPerDeg;
  const auto turned = [&](const Eigen::Vector3d& m) {  // Rz(theta) of a machine-frame displacement
    return Eigen::Vector3d(std::cos(th) * m.x() - std::sin(th) * m.y(), std::sin(th) * m.x() + std::cos(th) * m.y(),
                           m.z());
  };
  // Radial x_c2 at phi = 60 deg: cos(120 deg) = -1/2 along the Phi frame's x.
  const Eigen::Vector3d p = PointWith(Effect::kPhiRadialMotion, {2, 0, false}, a, 30.0, 60.0, 5.0);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, p,
                      Nominal(th, 60 * kRadPerDeg, 20.0) + turned(Eigen::Vector3d(-0.5 * a, 0, 0)), kTol);
  // Radial y_s2 at phi = 45 deg: sin(90 deg) = 1 along the Phi frame's y, the Theta axis.
  const Eigen::Vector3d q = PointWith(Effect::kPhiRadialMotion, {2, 1, true}, a, 30.0, 45.0, 5.0);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, q, Nominal(th, 45 * kRadPerDeg, 20.0) + Eigen::Vector3d(0, 0, a), kTol);
  // Axial c1 at phi = 60 deg: cos(60 deg) = 1/2 along the Phi axis, machine -y.
  const Eigen::Vector3d z = PointWith(Effect::kPhiAxialMotion, {1, 0, false}, a, 30.0, 60.0, 5.0);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, z,
                      Nominal(th, 60 * kRadPerDeg, 20.0) + turned(Eigen::Vector3d(0, -0.5 * a, 0)), kTol);
}

TEST(EffectScmsPoint, ThetaTiltTurnsThePointBackAboutTheMachineAxes) {
  // y_c2 = t at theta = 0: the spindle tilts by t about machine y, so the machine point
  // rho (sin phi, 0, cos phi) is seen from the sphere turned by -t: (c x - s z, 0, s x + c z).
  const double t = 25 * kRadPerArcsec, phi = 70 * kRadPerDeg, rho = 20.0;
  const double x = rho * std::sin(phi), zc = rho * std::cos(phi);
  const Eigen::Vector3d p = PointWith(Effect::kThetaTiltMotion, {2, 1, false}, t, 0.0, 70.0, 5.0);
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, p,
                      Eigen::Vector3d(std::cos(t) * x - std::sin(t) * zc, 0.0, std::sin(t) * x + std::cos(t) * zc),
                      kTol);
  // x_s2 = t at theta = 45 deg (sin 90 deg = 1): about machine x, (x, s z, c z), then Rz(45 deg).
  const double th = 45 * kRadPerDeg;
  const Eigen::Vector3d k(x, std::sin(t) * zc, std::cos(t) * zc);
  const Eigen::Vector3d q = PointWith(Effect::kThetaTiltMotion, {2, 0, true}, t, 45.0, 70.0, 5.0);
  EXPECT_PRED_FORMAT3(
      sph::testing::MatrixNear, q,
      Eigen::Vector3d(std::cos(th) * k.x() - std::sin(th) * k.y(), std::sin(th) * k.x() + std::cos(th) * k.y(), k.z()),
      kTol);
}

TEST(EffectScmsPoint, ProbeIncidenceFollowsTheAngleBetweenBeamAndNormal) {
  // theta = 0, phi = 90 deg, r = 5: the point p0 = (20, 0, 0) mm, the beam along -x (r grows
  // towards the axes' common point). The sphere's centre at (0, 2, 0): n0 = (20, -2, 0) / sqrt(404),
  // cos psi = 20 / sqrt(404), sin^2 psi = 4 / 404.
  const double i1 = 30e-3, i2 = -50e-3, sin2 = 4.0 / 404.0;
  EffectModel model;
  model.terms = {{Effect::kProbeIncidence, {{1, 0, false}, {2, 0, false}}}};
  const Eigen::Vector3d center(0.0, 2.0, 0.0);
  const EffectReading x(0.0, 90.0, 5.0, 0.0);
  const Eigen::Vector3d p = EffectScmsPoint(ScmsGeometry{}, model, {{i1, i2}}, x, kD, &center);
  const double error = i1 * sin2 + i2 * sin2 * sin2;
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, p, Eigen::Vector3d(kD - 5.0 - error, 0, 0), kTol);
  const std::vector<double> block{i1, i2};
  const double* blocks[] = {block.data()};
  const ScmsGeometry g{};
  EXPECT_NEAR(ProbeIncidenceError(g.data(), ErrorTrigOf(g.data()), model, blocks, x, kD, center.data()), error, 1e-15);
  // Without the centre the term cannot be evaluated and is left out; at normal incidence it is 0.
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, EffectScmsPoint(ScmsGeometry{}, model, {{i1, i2}}, x, kD),
                      Eigen::Vector3d(kD - 5.0, 0, 0), kTol);
  const Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, EffectScmsPoint(ScmsGeometry{}, model, {{i1, i2}}, x, kD, &origin),
                      Eigen::Vector3d(kD - 5.0, 0, 0), kTol);
}

TEST(EffectScmsPoint, ProbeTermsCorrectTheReading) {
  const EffectReference ref{5.0, 2.0, 100.0, 400.0};
  const double phi = 40 * kRadPerDeg;
  // Gain: r_true = r + k (r - 5) / 2; at r = 6: r + k / 2.
  const double k = 0.4e-3;
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, PointWith(Effect::kProbeGain, {1, 0, false}, k, 0.0, 40.0, 6.0, 0, ref),
                      Nominal(0.0, phi, kD - 6.0 - k / 2), kTol);
  // Cubic: q3 u^3 at r = 4: u = -0.5.
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear,
                      PointWith(Effect::kProbeNonlinearity, {3, 0, false}, k, 0.0, 40.0, 4.0, 0, ref),
                      Nominal(0.0, phi, kD - 4.0 + 0.125 * k), kTol);
  // Drift v2 tau^2 at t = 300 s: tau = 0.5.
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear,
                      PointWith(Effect::kProbeDrift, {2, 0, false}, k, 0.0, 40.0, 5.0, 300.0, ref),
                      Nominal(0.0, phi, kD - 5.0 - 0.25 * k), kTol);
}

TEST(EffectTerm, NamesAndDefaults) {
  const EffectTerm radial = DefaultTerm(Effect::kThetaRadialMotion, 3, 1);
  ASSERT_EQ(radial.size(), 8);  // k = 2, 3; cos and sin; x and y
  EXPECT_EQ(radial.ParamName(0), "theta_radial_motion.x_c2");
  EXPECT_EQ(radial.ParamName(7), "theta_radial_motion.y_s3");
  EXPECT_EQ(DefaultTerm(Effect::kProbeDrift, 4, 2).ParamName(1), "probe_drift.t2");
  EffectComponent c;
  ASSERT_TRUE(FindComponent(Effect::kPhiWobble, "phi_wobble.y_s4", &c));
  EXPECT_EQ(c.order, 4);
  EXPECT_EQ(c.axis, 1);
  EXPECT_TRUE(c.sine);
  EXPECT_FALSE(FindComponent(Effect::kProbeGain, "probe_gain.u2", &c));
  // The once-per-turn radial motions and tilt are parameters of the set-up, not error motions.
  EXPECT_FALSE(FindComponent(Effect::kPhiRadialMotion, "phi_radial_motion.x_c1", &c));
  EXPECT_FALSE(FindComponent(Effect::kThetaTiltMotion, "theta_tilt_motion.y_s1", &c));
  ASSERT_TRUE(FindComponent(Effect::kPhiAxialMotion, "phi_axial_motion.s1", &c));
  EXPECT_EQ(DefaultTerm(Effect::kThetaTiltMotion, 3, 1).ParamName(5), "theta_tilt_motion.y_s2");
  Effect e;
  EXPECT_TRUE(EffectFromId("probe_nonlinearity", &e));
  EXPECT_EQ(e, Effect::kProbeNonlinearity);
  EXPECT_FALSE(EffectFromId("probe_temperature", &e));
}

}  // namespace
}  // namespace sph
