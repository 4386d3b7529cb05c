#include "sph/model/residual_gradient.hpp"

#include <random>

#include <gtest/gtest.h>

#include "sph/model/effects.hpp"

namespace sph {
namespace {

constexpr double kD = 25.0;
constexpr double kR0 = 20.0;

// The inputs of ResidualGradient that a fit differentiates: the seven errors, the centre and the
// places where the effects enter (theta', phi', z, the motions and tilts of both axes), as one vector.
struct Point {
  ScmsGeometry g{};
  double center[3] = {};
  double theta = 0.0, phi = 0.0, r = 0.0;
  double motion[3] = {};
  double wx = 0.0, wy = 0.0;
  double pivot_mm = 0.0;
  double phi_motion[3] = {};
  double tx = 0.0, ty = 0.0;
};

template <bool kWobble, bool kTilt = false>
ResidualGradient Evaluate(const Point& p) {
  ResidualInputs in;
  in.theta = SinCosOf(p.theta);
  in.phi = SinCosOf(p.phi);
  in.z = p.r - (kD + p.g[kDPrime]);
  for (int k = 0; k < 3; ++k) in.motion[k] = p.motion[k];
  in.wobble_x = SinCosOf(p.wx);
  in.wobble_y = SinCosOf(p.wy);
  in.pivot_mm = p.pivot_mm;
  for (int k = 0; k < 3; ++k) in.phi_motion[k] = p.phi_motion[k];
  in.tilt_x = SinCosOf(p.tx);
  in.tilt_y = SinCosOf(p.ty);
  ResidualGradient out;
  SphereResidualGradient<kWobble, kTilt>(p.g.data(), ErrorTrigOf(p.g.data()), in, p.center, kR0, &out);
  return out;
}

// Every derivative against central differences of e (steps 1e-6; truncation ~1e-12).
template <bool kWobble, bool kTilt = false>
void ExpectCentralDifferences(const Point& p) {
  const auto Evaluate = [](const Point& q) { return sph::Evaluate<kWobble, kTilt>(q); };
  const ResidualGradient d = Evaluate(p);
  const double h = 1e-6;
  auto check = [&](double Point::*member, double analytic, const char* name) {
    Point plus = p, minus = p;
    plus.*member += h;
    minus.*member -= h;
    const double numeric = (Evaluate(plus).e - Evaluate(minus).e) / (2 * h);
    EXPECT_NEAR(analytic, numeric, 1e-8 * std::max(1.0, std::abs(numeric))) << name;
  };
  for (int k = 0; k < kNumScmsParams; ++k) {
    Point plus = p, minus = p;
    plus.g[static_cast<std::size_t>(k)] += h;
    minus.g[static_cast<std::size_t>(k)] -= h;
    const double numeric = (Evaluate(plus).e - Evaluate(minus).e) / (2 * h);
    EXPECT_NEAR(d.geometry[k], numeric, 1e-8 * std::max(1.0, std::abs(numeric)))
        << kScmsParamInfo[static_cast<std::size_t>(k)].name;
  }
  for (int k = 0; k < 3; ++k) {
    Point plus = p, minus = p;
    plus.center[k] += h;
    minus.center[k] -= h;
    EXPECT_NEAR(d.center[k], (Evaluate(plus).e - Evaluate(minus).e) / (2 * h), 1e-8) << "centre " << k;
    plus = p;
    minus = p;
    plus.motion[k] += h;
    minus.motion[k] -= h;
    EXPECT_NEAR(d.motion[k], (Evaluate(plus).e - Evaluate(minus).e) / (2 * h), 1e-8) << "motion " << k;
    plus = p;
    minus = p;
    plus.phi_motion[k] += h;
    minus.phi_motion[k] -= h;
    EXPECT_NEAR(d.phi_motion[k], (Evaluate(plus).e - Evaluate(minus).e) / (2 * h), 1e-8) << "Phi axis motion " << k;
  }
  check(&Point::theta, d.theta, "theta");
  check(&Point::phi, d.phi, "phi");
  check(&Point::r, d.z, "z");
  if (kWobble) {
    check(&Point::wx, d.wobble_x, "wobble_x");
    check(&Point::wy, d.wobble_y, "wobble_y");
  }
  if (kTilt) {
    check(&Point::tx, d.tilt_x, "tilt_x");
    check(&Point::ty, d.tilt_y, "tilt_y");
  }
}

TEST(SphereResidualGradient, MatchesCentralDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> angle(0.0, 6.2), polar(0.1, 3.0), small(-1e-3, 1e-3);
  for (int trial = 0; trial < 30; ++trial) {
    Point p;
    p.g = {small(rng), small(rng), small(rng), small(rng), small(rng), small(rng), -0.062 + small(rng)};
    p.center[0] = 2.0 + small(rng);
    p.center[1] = -0.3;
    p.center[2] = 0.4;
    p.theta = angle(rng);
    p.phi = polar(rng);
    p.r = 4.9 + small(rng);
    for (double& m : p.motion) m = small(rng);
    p.wx = small(rng);
    p.wy = small(rng);
    for (double& m : p.phi_motion) m = small(rng);
    p.tx = small(rng);
    p.ty = small(rng);
    p.pivot_mm = 60.0 * angle(rng);  // the bearing up to 370 mm along the Phi axis
    ExpectCentralDifferences<false>(p);
    ExpectCentralDifferences<true>(p);
    ExpectCentralDifferences<false, true>(p);
    ExpectCentralDifferences<true, true>(p);
  }
}

// The forward pass is ScmsPoint()'s and EffectScmsPoint()'s: the same residual to the last bit.
TEST(SphereResidualGradient, ResidualIsThatOfTheModel) {
  const ScmsGeometry g{3e-4, 2e-3, -4e-4, 1e-3, 5e-4, -2e-3, -0.062};
  const Eigen::Vector3d c(1.5, -0.7, 0.9);
  for (double theta : {0.0, 0.9, 3.5}) {
    for (double phi : {0.2, 1.6, 2.9}) {
      Point p;
      p.g = g;
      for (int k = 0; k < 3; ++k) p.center[k] = c(k);
      p.theta = theta;
      p.phi = phi;
      p.r = 5.1;
      const double e = (ScmsPoint(g, theta, phi, p.r, kD) - c).norm() - kR0;
      EXPECT_EQ(Evaluate<false>(p).e, e);
      // A tilted Phi axis and a spindle motion as EffectScmsPoint() applies them.
      EffectModel model;
      model.terms = {{Effect::kPhiWobble, {{1, 0, false}, {1, 1, true}}}, {Effect::kThetaAxialMotion, {{2, 0, false}}}};
      const std::vector<std::vector<double>> values{{2e-5, -3e-5}, {4e-4}};
      const EffectReading x(theta * kDegPerRad, phi * kDegPerRad, p.r, 0.0);
      p.theta = x.theta_rad;
      p.phi = x.phi_rad;
      p.wx = 2e-5 * std::cos(x.phi_rad);
      p.wy = -3e-5 * std::sin(x.phi_rad);
      p.motion[2] = 4e-4 * std::cos(2 * x.theta_rad);
      const double e_effects = (EffectScmsPoint(g, model, values, x, kD) - c).norm() - kR0;
      EXPECT_EQ(Evaluate<true>(p).e, e_effects);
      // With the pivot, both axes' motions and the Theta spindle's tilt.
      model.phi_wobble_pivot_mm = 75.0;
      model.terms.push_back({Effect::kPhiRadialMotion, {{2, 1, true}}});
      model.terms.push_back({Effect::kPhiAxialMotion, {{1, 0, false}}});
      model.terms.push_back({Effect::kThetaTiltMotion, {{2, 0, false}, {3, 1, true}}});
      const std::vector<std::vector<double>> more{{2e-5, -3e-5}, {4e-4}, {-6e-4}, {3e-4}, {5e-5, -2e-5}};
      p.pivot_mm = 75.0;
      p.phi_motion[1] = -6e-4 * std::sin(2 * x.phi_rad);
      p.phi_motion[2] = 3e-4 * std::cos(x.phi_rad);
      p.tx = 5e-5 * std::cos(2 * x.theta_rad);
      p.ty = -2e-5 * std::sin(3 * x.theta_rad);
      const double e_all = (EffectScmsPoint(g, model, more, x, kD) - c).norm() - kR0;
      EXPECT_EQ((Evaluate<true, true>(p).e), e_all);
    }
  }
}

}  // namespace
}  // namespace sph
