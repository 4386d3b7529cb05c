#include "sph/simulation/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>
#include <utility>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "sph/simulation/simulation_options.hpp"
#include "sph/model/scms_model.hpp"
#include "sph/model/spherical_harmonics.hpp"
#include "sph/model/units.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

TEST(GridPattern, IsThePapersGrid) {
  const auto grid = GridPattern(24, 12);
  ASSERT_EQ(grid.size(), 288u);
  EXPECT_DOUBLE_EQ(grid.front().theta_deg, 0.0);
  EXPECT_DOUBLE_EQ(grid.front().phi_deg, 7.5);
  EXPECT_DOUBLE_EQ(grid[23].theta_deg, 345.0);
  EXPECT_DOUBLE_EQ(grid.back().phi_deg, 172.5);
}

TEST(ProbeReading, NominalMachineMeasuresDistanceToTheSurface) {
  // Errors zero, sphere at the origin: r = d - R0 everywhere.
  const auto r = ProbeReading(ScmsGeometry{}, 0.3, 1.2, 25.0, Eigen::Vector3d::Zero(), 20.0);
  ASSERT_TRUE(r);
  EXPECT_NEAR(*r, 5.0, 1e-12);
  // Sphere shifted along +x by e: at theta = 0, phi = 90 deg the surface is e closer to the probe.
  const auto r2 = ProbeReading(ScmsGeometry{}, 0.0, kPi / 2, 25.0, Eigen::Vector3d(2.0, 0.0, 0.0), 20.0);
  ASSERT_TRUE(r2);
  EXPECT_NEAR(*r2, 3.0, 1e-12);
  // ... and at phi = 0 (the pole): the ray along z hits the shifted sphere at height sqrt(R0^2 - e^2).
  const auto r3 = ProbeReading(ScmsGeometry{}, 0.0, 0.0, 25.0, Eigen::Vector3d(2.0, 0.0, 0.0), 20.0);
  ASSERT_TRUE(r3);
  EXPECT_NEAR(*r3, 25.0 - std::sqrt(400.0 - 4.0), 1e-12);
}

TEST(ProbeReading, MissesASphereOutOfReach) {
  EXPECT_FALSE(ProbeReading(ScmsGeometry{}, 0.0, kPi / 2, 25.0, Eigen::Vector3d(0.0, 30.0, 0.0), 5.0).has_value());
}

TEST(Simulate, NoiseHasTheRequestedSigma) {
  SimulationSpec spec;
  spec.pattern = GridPattern(60, 40);
  spec.noise_r_um = 0.5;
  SimulationSpec exact = spec;
  exact.noise_r_um = 0.0;
  const PointsData noisy = Simulate(spec), clean = Simulate(exact);
  ASSERT_EQ(noisy.samples.size(), 2400u);
  double sum = 0.0, sum2 = 0.0;
  for (std::size_t i = 0; i < noisy.samples.size(); ++i) {
    const double e_um = (noisy.samples[i].r_mm - clean.samples[i].r_mm) * 1e3;
    sum += e_um;
    sum2 += e_um * e_um;
    EXPECT_EQ(noisy.samples[i].theta_deg, clean.samples[i].theta_deg);
  }
  const double n = 2400.0, mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 4 * 0.5 / std::sqrt(n));  // 4 standard errors
  EXPECT_NEAR(sd, 0.5, 4 * 0.5 / std::sqrt(2 * n));
}

TEST(Simulate, SetupsTimesAndSeeds) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 0, 2)};
  spec.sample_period_s = 0.5;
  const PointsData d = Simulate(spec);
  ASSERT_EQ(d.samples.size(), 576u);
  EXPECT_TRUE(d.has_setup);
  EXPECT_EQ(d.samples[287].setup, 0);
  EXPECT_EQ(d.samples[288].setup, 1);
  EXPECT_DOUBLE_EQ(d.samples[3].t_s, 1.5);
  EXPECT_EQ(Simulate(spec).samples[100].r_mm, d.samples[100].r_mm);
  spec.seed = 2;
  EXPECT_NE(Simulate(spec).samples[100].r_mm, d.samples[100].r_mm);
}

// The distance r + gain(u) + nonlinearity(u) that each reading of `read` reports (u by `ref`)
// against the exact distance of `exact` (the same spec without the probe's terms).
void ExpectReadingsReportTheDistances(const PointsData& read, const PointsData& exact, const EffectReference& ref,
                                      double gain_mm, double quadratic_mm) {
  ASSERT_EQ(read.samples.size(), exact.samples.size());
  for (std::size_t i = 0; i < read.samples.size(); ++i) {
    const double r = read.samples[i].r_mm, u = (r - ref.r_ref_mm) / ref.r_half_range_mm;
    EXPECT_NEAR(r + gain_mm * u + quadratic_mm * u * u, exact.samples[i].r_mm, 1e-12) << "sample " << i;
  }
}

// A gain of half the probe's range (1 mm at the end of a 2 mm range): d(distance)/d(reading) is 2,
// which a fixed-point iteration r <- distance - gain(u(r)) does not converge on (it swaps between
// two values); the readings are the roots, in the range.
TEST(Simulate, AProbeGainOfHalfTheRangeIsReadExactly) {
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  spec.probe_offset_mm = 21.5;
  spec.centers_mm = {Eigen::Vector3d(0.5, 0.0, 0.0)};
  spec.probe_range_mm = 2.0;
  const PointsData exact = Simulate(spec);
  spec.effects.model.terms = {DefaultTerm(Effect::kProbeGain)};
  spec.effects.values = {{1.0}};
  EffectReference ref;
  const PointsData read = Simulate(spec, &ref);
  EXPECT_DOUBLE_EQ(ref.r_ref_mm, 1.0);
  EXPECT_DOUBLE_EQ(ref.r_half_range_mm, 1.0);
  ExpectReadingsReportTheDistances(read, exact, ref, 1.0, 0.0);
  for (const Sample& s : read.samples) {
    EXPECT_GT(s.r_mm, 0.0);
    EXPECT_LT(s.r_mm, 2.0);
  }
}

// Normalised by the readings' own range, the readings and the range they span are solved together:
// a gain of 1 mm on readings that span about 2 mm (d(distance)/d(reading) about 2 again).
TEST(Simulate, AProbeGainNormalisedByTheReadingsOwnRangeIsReadExactly) {
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  const PointsData exact = Simulate(spec);
  for (const auto& [gain_mm, quadratic_mm] : {std::pair{1.0, 0.0}, std::pair{-1.0, 0.3}, std::pair{1e-3, 0.0}}) {
    SCOPED_TRACE(gain_mm);
    spec.effects.model.terms = {DefaultTerm(Effect::kProbeGain), DefaultTerm(Effect::kProbeNonlinearity)};
    spec.effects.values = {{gain_mm}, {quadratic_mm, 0.0}};
    EffectReference ref;
    const PointsData read = Simulate(spec, &ref);
    const EffectReference own = EffectReferenceOf(read.samples);
    EXPECT_DOUBLE_EQ(ref.r_ref_mm, own.r_ref_mm);
    EXPECT_DOUBLE_EQ(ref.r_half_range_mm, own.r_half_range_mm);
    ExpectReadingsReportTheDistances(read, exact, own, gain_mm, quadratic_mm);
  }
}

TEST(Simulate, RefusesAProbeThatCannotReadTheDistances) {
  const auto message = [](SimulationSpec spec) {
    try {
      Simulate(spec);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  SimulationSpec spec;
  spec.probe_range_mm = 1.0;  // the readings are 3 to 7 mm
  EXPECT_THAT(message(spec), ::testing::HasSubstr("288 of 288 distances (the first: 4.77605 mm at theta 0 deg, phi "
                                                  "7.5 deg, setup 0) lie beyond what the probe reads over its range 0 "
                                                  "to 1 mm (probe_range_mm)"));
  spec.probe_offset_mm = 20.7;  // readings 0.44 to 0.84 mm
  spec.centers_mm = {Eigen::Vector3d(0.2, 0.0, 0.0)};
  spec.effects.model.terms = {DefaultTerm(Effect::kProbeGain)};
  spec.effects.values = {{-0.6}};  // the distance falls by 0.2 mm per mm of reading
  EXPECT_THAT(message(spec), ::testing::HasSubstr("with probe_gain.u1 -600 um, the distance the probe reports does "
                                                  "not rise with its reading over its range 0 to 1 mm "
                                                  "(probe_range_mm): d(distance)/d(reading) is -0.2 at r = 0 mm"));
  spec = SimulationSpec();
  spec.effects.model.terms = {DefaultTerm(Effect::kProbeNonlinearity)};
  spec.effects.values = {{1.0, 0.0}};  // u^2 of 1 mm over readings that span 2 mm each way
  EXPECT_THAT(message(spec), ::testing::HasSubstr("does not rise with its reading over the readings' own range"));
}

TEST(Simulate, RejectsImpossibleSpecs) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(0, 40, 0)};
  EXPECT_THROW(Simulate(spec), Error);
  spec = SimulationSpec();
  spec.sphere_radius_mm = 0.0;
  EXPECT_THROW(Simulate(spec), Error);
}

}  // namespace
}  // namespace sph

namespace sph {
namespace {

// ---- the sphere's form on its body frame, turned on its mount -------------------------------------

// The Schmidt semi-normalised harmonics written out by hand (x, y, z a unit direction).
double HandHarmonic(int l, int m, const Eigen::Vector3d& u) {
  const double x = u.x(), y = u.y(), z = u.z();
  if (l == 1 && m == -1) return y;
  if (l == 2 && m == 0) return (3 * z * z - 1) / 2;
  if (l == 2 && m == 1) return std::sqrt(3.0) * z * x;
  if (l == 2 && m == -1) return std::sqrt(3.0) * z * y;
  if (l == 2 && m == 2) return std::sqrt(3.0) / 2 * (x * x - y * y);
  if (l == 2 && m == -2) return std::sqrt(3.0) * x * y;
  if (l == 3 && m == 0) return (5 * z * z * z - 3 * z) / 2;
  if (l == 3 && m == 1) return std::sqrt(3.0 / 8.0) * (5 * z * z - 1) * x;
  if (l == 3 && m == -3) return std::sqrt(5.0 / 8.0) * (3 * x * x * y - y * y * y);
  if (l == 4 && m == 0) return (35 * std::pow(z, 4) - 30 * z * z + 3) / 8;
  ADD_FAILURE() << "no hand formula for l " << l << ", m " << m;
  return 0.0;
}

// Rodrigues' formula, written out: the rotation by |v| deg about v.
Eigen::Matrix3d HandRotation(const Eigen::Vector3d& v_deg) {
  const double angle = v_deg.norm() * kPi / 180.0;
  const Eigen::Vector3d k = v_deg.normalized();
  Eigen::Matrix3d K;
  K << 0, -k.z(), k.y(), k.z(), 0, -k.x(), -k.y(), k.x(), 0;
  return Eigen::Matrix3d::Identity() + std::sin(angle) * K + (1 - std::cos(angle)) * K * K;
}

Eigen::Vector3d Direction(double theta_deg, double phi_deg) {
  const double t = theta_deg * kPi / 180.0, p = phi_deg * kPi / 180.0;
  return {std::sin(p) * std::cos(t), std::sin(p) * std::sin(t), std::cos(p)};
}

// The reading of a machine without errors, sphere at `center`, turned by `rotation_deg`.
double Reading(const SimulatedEffects& e, double theta_deg, double phi_deg, const Eigen::Vector3d& center,
               const Eigen::Vector3d& rotation_deg = Eigen::Vector3d::Zero(), const ScmsGeometry& g = ScmsGeometry{}) {
  const auto r = TrueProbeDistance(g, e, theta_deg * kPi / 180.0, phi_deg * kPi / 180.0, 25.0, center, 20.0,
                                   RotationOfVectorDeg(rotation_deg));
  EXPECT_TRUE(r.has_value()) << "theta " << theta_deg << ", phi " << phi_deg;
  return r.value_or(0.0);
}

// The incidence of the beam, worked by hand: at theta = 0, phi = 90 deg the ideal machine's beam
// runs along the x axis through the axes' common point, so for a sphere of radius R centred at O
// sin psi = |e_x x O| / R (the beam's distance from the centre over the radius): 0 with the centre
// on the beam, (2 / 20)^2 and (4 / 20)^2 off it; the probe then reads i1 sin^2 psi short of the
// distance (TrueProbeDistance(), ProbeReadingOfDistance()).
TEST(TrueProbeDistance, GivesTheSineOfTheBeamsIncidenceOnTheSurfaceAndTheProbeReadsItsError) {
  const double i1 = 30 * kMmPerUm;
  SimulatedEffects e;
  e.model.terms = {{Effect::kProbeIncidence, {{1, 0, false}}}};
  e.values = {{i1}};
  e.model.reference.r_ref_mm = 5.0;
  e.model.reference.r_half_range_mm = 5.0;
  for (const auto& [center, sin2] : {std::pair{Eigen::Vector3d(3, 0, 0), 0.0}, std::pair{Eigen::Vector3d(0, 2, 0), 0.01},
                                     std::pair{Eigen::Vector3d(0, 0, 4), 0.04}}) {
    double got = -1.0;
    const auto r = TrueProbeDistance(ScmsGeometry{}, e, 0.0, kPi / 2, 25.0, center, 20.0, Eigen::Matrix3d::Identity(),
                                     &got);
    ASSERT_TRUE(r.has_value());
    // The hit lies at x = O_x + sqrt(R^2 - |O_yz|^2) from the axes' point, 25 mm from the probe's zero.
    const double hit_x = center.x() + std::sqrt(400.0 - center.y() * center.y() - center.z() * center.z());
    EXPECT_NEAR(*r, 25.0 - hit_x, 1e-12) << center.transpose();
    EXPECT_NEAR(got, sin2, 1e-15) << center.transpose();
    const auto reading = ProbeReadingOfDistance(e, *r, 0.0, got);
    ASSERT_TRUE(reading.has_value());
    EXPECT_NEAR(*reading, *r - i1 * sin2, 1e-14) << center.transpose();
  }
}

TEST(FormHarmonic, EqualsTheHandFormulas) {
  const std::vector<std::pair<int, int>> lm{{1, -1}, {2, 0}, {2, 1}, {2, -1}, {2, 2},
                                            {2, -2}, {3, 0}, {3, 1}, {3, -3}, {4, 0}};
  for (const Eigen::Vector3d& u : {Direction(0, 0), Direction(30, 40), Direction(200, 110), Direction(300, 179)}) {
    for (const auto& [l, m] : lm) EXPECT_NEAR(FormHarmonic(l, m, u), HandHarmonic(l, m, u), 1e-15) << l << " " << m;
  }
}

TEST(FormHarmonic, EqualsTheModelsHarmonicsUpToDegreeTwenty) {
  // Two independent evaluations: the simulator's Schmidt recurrence with (x + iy)^m, and the
  // model's associated Legendre functions with their factorial normalisation.
  for (const Eigen::Vector3d& u : {Direction(10, 20), Direction(123, 77), Direction(250, 150), Direction(5, 1)}) {
    const double lon = std::atan2(u.y(), u.x());
    for (int l = 0; l <= 20; ++l) {
      for (int m = -l; m <= l; ++m) {
        EXPECT_NEAR(FormHarmonic(l, m, u), SchmidtHarmonic(l, m, lon, u.z()), 1e-12) << l << " " << m;
        EXPECT_LE(std::abs(FormHarmonic(l, m, u)), 1.0 + 1e-12);
      }
    }
  }
}

TEST(RotationOfVectorDeg, IsRodriguesFormulaAndTakesTheBodyIntoTheThetaFrame) {
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, RotationOfVectorDeg(Eigen::Vector3d(30, -20, 50)),
                      HandRotation(Eigen::Vector3d(30, -20, 50)), 1e-15);
  // 90 deg about z takes the body's x axis to the Theta frame's y axis.
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear,
                      RotationOfVectorDeg(Eigen::Vector3d(0, 0, 90)) * Eigen::Vector3d::UnitX(),
                      Eigen::Vector3d::UnitY(), 1e-15);
  EXPECT_EQ(RotationOfVectorDeg(Eigen::Vector3d::Zero()), Eigen::Matrix3d::Identity());
}

TEST(TrueProbeDistance, ARotatedHarmonicIsTheHarmonicOfTheRotatedDirection) {
  // No machine errors, the sphere's centre at the axes' common point: the ray runs through the
  // centre, so r = d - R0 - a S_lm(R^T u) exactly.
  SimulatedEffects e;
  e.form = {{3, 1, 0.3}, {2, -2, 0.2}, {4, 0, -0.1}};
  const Eigen::Vector3d rv(30, -20, 50);
  const Eigen::Matrix3d R = HandRotation(rv);
  for (double theta : {0.0, 37.0, 150.0, 290.0}) {
    for (double phi : {5.0, 60.0, 95.0, 170.0}) {
      const Eigen::Vector3d u_body = R.transpose() * Direction(theta, phi);
      const double form_mm = 1e-3 * (0.3 * HandHarmonic(3, 1, u_body) + 0.2 * HandHarmonic(2, -2, u_body) -
                                     0.1 * HandHarmonic(4, 0, u_body));
      EXPECT_NEAR(Reading(e, theta, phi, Eigen::Vector3d::Zero(), rv), 5.0 - form_mm, 1e-13) << theta << " " << phi;
    }
  }
}

TEST(TrueProbeDistance, TurnsAboutZMapHarmonicsAsTheirLongitudesShift) {
  // Turned by gamma about z, S_lm(lon) is seen at lon - gamma: 45 deg takes S_2,2 = cos 2lon to
  // +S_2,-2 = sin 2lon, 90 deg takes S_2,1 to +S_2,-1 and S_2,2 to -S_2,2. The transposed
  // rotation would give -S_2,-2 and -S_2,-1. Any machine, any centre: the surfaces are the same.
  const ScmsGeometry table1 = SimulationSpec::PaperTruth();
  const Eigen::Vector3d center(2, 0.5, -1);
  const auto with = [](int l, int m) {
    SimulatedEffects e;
    e.form = {{l, m, 0.5}};
    return e;
  };
  SimulatedEffects minus_22;
  minus_22.form = {{2, 2, -0.5}};
  for (double theta : {0.0, 20.0, 135.0, 250.0}) {
    for (double phi : {30.0, 80.0, 140.0}) {
      const double d22_45 = Reading(with(2, 2), theta, phi, center, {0, 0, 45}, table1);
      EXPECT_NEAR(d22_45, Reading(with(2, -2), theta, phi, center, {0, 0, 0}, table1), 1e-13);
      const double d21_90 = Reading(with(2, 1), theta, phi, center, {0, 0, 90}, table1);
      EXPECT_NEAR(d21_90, Reading(with(2, -1), theta, phi, center, {0, 0, 0}, table1), 1e-13);
      const double d22_90 = Reading(with(2, 2), theta, phi, center, {0, 0, 90}, table1);
      EXPECT_NEAR(d22_90, Reading(minus_22, theta, phi, center, {0, 0, 0}, table1), 1e-13);
    }
  }
  // ... and the form is really there: a reading differs from that of the round sphere.
  EXPECT_GT(std::abs(Reading(with(2, -2), 45, 90, center, {0, 0, 0}, table1) -
                     Reading(SimulatedEffects{}, 45, 90, center, {0, 0, 0}, table1)),
            4e-4);
}

TEST(TrueProbeDistance, ATiltAboutXTakesTheBodysPoleToMinusY) {
  // 90 deg about x: body z -> Theta frame -y. A bump at the body's pole is seen at theta 270,
  // phi 90 (direction -y); with the transposed rotation it would be at +y.
  SimulatedEffects e;
  e.bumps = {{0.8, 4.0, Eigen::Vector3d::UnitZ()}};
  const Eigen::Vector3d tilt(90, 0, 0);
  EXPECT_NEAR(Reading(e, 270, 90, Eigen::Vector3d::Zero(), tilt), 5.0 - 0.8e-3, 1e-13);
  EXPECT_NEAR(Reading(e, 90, 90, Eigen::Vector3d::Zero(), tilt), 5.0, 1e-13);
  EXPECT_NEAR(Reading(e, 0, 0, Eigen::Vector3d::Zero(), tilt), 5.0, 1e-13);
  EXPECT_NEAR(Reading(e, 0, 0, Eigen::Vector3d::Zero()), 5.0 - 0.8e-3, 1e-13);  // not turned: at the pole
}

TEST(TrueProbeDistance, ABumpHasItsGaussianProfile) {
  // Radial rays: r = d - R0 - h exp(-g^2 / 2w^2) at the angle g from the bump's centre.
  SimulatedEffects e;
  e.bumps = {{0.6, 3.0, Eigen::Vector3d(1, 1, 0)}};  // centre at theta 45, phi 90
  for (double g : {0.0, 1.0, 3.0, 6.0, 12.0}) {
    const double expected = 5.0 - 0.6e-3 * std::exp(-g * g / (2 * 9.0));
    EXPECT_NEAR(Reading(e, 45.0 + g, 90, Eigen::Vector3d::Zero()), expected, 1e-13) << g;
    EXPECT_NEAR(Reading(e, 45.0, 90 - g, Eigen::Vector3d::Zero()), expected, 1e-13) << g;
  }
  // An oblique ray (the sphere 2 mm off the axis): the hit x lies on the bump's surface, by hand.
  const Eigen::Vector3d center(2, 0, 0), c = Eigen::Vector3d(1, 1, 0).normalized();
  for (double theta : {40.0, 44.0, 47.0, 52.0}) {
    const Eigen::Vector3d x = (25.0 - Reading(e, theta, 88, center)) * Direction(theta, 88) - center;
    const double g = std::acos(std::min(1.0, x.normalized().dot(c)));
    EXPECT_NEAR(x.norm(), 20.0 + 0.6e-3 * std::exp(-g * g / (2 * std::pow(3.0 * kPi / 180, 2))), 1e-12) << theta;
  }
}

TEST(TrueProbeDistance, AFlatIsTheSphereCutByItsPlaneAcrossItsRim) {
  // The sphere 2 mm off the axis with a flat of 50 um normal to +x: the solid is the ball cut by
  // the half-space x <= 2 + R0 - depth. Along the ray (d - r) u (r growing inwards) it is entered
  // where the later of the two is entered: r = max(r_sphere, r_plane). By hand, for rays that
  // sweep across the flat's rim (half-angle 4 deg seen from the centre), the kink included.
  const double depth_mm = 0.05, R0 = 20.0, d = 25.0;
  const Eigen::Vector3d center(2, 0, 0);
  SimulatedEffects e;
  e.flats = {{depth_mm * 1e3, Eigen::Vector3d(3, 0, 0)}};
  int on_flat = 0, on_sphere = 0;
  for (double theta = 0.0; theta <= 6.0; theta += 0.01) {
    const Eigen::Vector3d u = Direction(theta, 89.0);
    // sphere: |(d - r) u - O| = R0, the root nearest the probe; plane: (d - r) u_x = 2 + R0 - depth.
    const double b = u.dot(center), r_sphere = d - (b + std::sqrt(b * b - center.squaredNorm() + R0 * R0));
    const double r_plane = d - (2.0 + R0 - depth_mm) / u.x();
    const double expected = std::max(r_sphere, r_plane);
    (r_plane > r_sphere ? on_flat : on_sphere)++;
    EXPECT_NEAR(Reading(e, theta, 89.0, center), expected, 1e-12) << "theta " << theta;
  }
  EXPECT_GT(on_flat, 50);
  EXPECT_GT(on_sphere, 50);
  // Turned 90 deg about z, the flat faces +y: the ray at theta 90 meets it, the one at theta 0 not.
  const Eigen::Vector3d turn(0, 0, 90);
  EXPECT_NEAR(Reading(e, 90, 90, Eigen::Vector3d::Zero(), turn), d - (R0 - depth_mm), 1e-13);
  EXPECT_NEAR(Reading(e, 0, 90, Eigen::Vector3d::Zero(), turn), d - R0, 1e-13);
}

TEST(TrueProbeDistance, FormsAddUpAndAFlatCutsTheHarmonicSurface) {
  SimulatedEffects e;
  e.form = {{2, 0, 0.4}};
  e.bumps = {{0.3, 5.0, Eigen::Vector3d::UnitX()}};
  e.flats = {{2.0, -Eigen::Vector3d::UnitX()}};
  // At +x: R0 + 0.4 S_2,0 (= -0.2) + 0.3; at -x the flat: R0 - 2 um, below the harmonic's R0 - 0.2 um.
  EXPECT_NEAR(Reading(e, 0, 90, Eigen::Vector3d::Zero()), 5.0 - 0.1e-3, 1e-13);
  EXPECT_NEAR(Reading(e, 180, 90, Eigen::Vector3d::Zero()), 5.0 + 2e-3, 1e-13);
  EXPECT_NEAR(Reading(e, 0, 0, Eigen::Vector3d::Zero()), 5.0 - 0.4e-3, 1e-13);  // the pole: S_2,0 = 1
}

TEST(FormSizeOf, GivesTheHarmonicsRmsAndLeavesOutDegreesZeroAndOne) {
  SimulatedEffects e;
  e.form = {{4, 3, 0.2}, {2, 0, 0.1}};
  const FormSize size = FormSizeOf(e, 20.0);
  EXPECT_NEAR(size.rms_um, std::sqrt(0.04 / 9 + 0.01 / 5), 1e-5);
  e.form = {{2, 0, 0.1}, {0, 0, 5.0}, {1, 1, 3.0}};  // a radius change and a centre shift: no form
  const FormSize s20 = FormSizeOf(e, 20.0);
  EXPECT_NEAR(s20.rms_um, 0.1 / std::sqrt(5.0), 1e-5);
  EXPECT_NEAR(s20.pv_um, 0.15, 0.15 * 0.01);  // S_2,0 spans -1/2 .. 1; the grid's last band is 0.2 deg from the pole
}

// ---- scan orders -----------------------------------------------------------------------------------

std::vector<std::pair<double, double>> Sorted(const std::vector<AnglePair>& p) {
  std::vector<std::pair<double, double>> out;
  for (const AnglePair& a : p) out.emplace_back(a.theta_deg, a.phi_deg);
  std::sort(out.begin(), out.end());
  return out;
}

TEST(InScanOrder, EveryOrderIsAPermutationOfThePattern) {
  const std::vector<AnglePair> grid = GridPattern(24, 12);
  for (ScanOrder order :
       {ScanOrder::kRings, ScanOrder::kReversed, ScanOrder::kSerpentine, ScanOrder::kColumns, ScanOrder::kShuffled}) {
    EXPECT_EQ(Sorted(InScanOrder(grid, order, 3)), Sorted(grid)) << ScanOrderName(order);
    ScanOrder back;
    ASSERT_TRUE(ScanOrderFromName(ScanOrderName(order), &back));
    EXPECT_EQ(back, order);
  }
  ScanOrder none;
  EXPECT_FALSE(ScanOrderFromName("spiral", &none));
}

TEST(InScanOrder, EachOrderIsTheOneNamed) {
  const std::vector<AnglePair> grid = GridPattern(24, 12);
  const auto at = [](const std::vector<AnglePair>& p, std::size_t i) {
    return std::make_pair(p[i].theta_deg, p[i].phi_deg);
  };
  const auto rings = InScanOrder(grid, ScanOrder::kRings, 1);
  EXPECT_EQ(at(rings, 1), std::make_pair(15.0, 7.5));
  const auto reversed = InScanOrder(grid, ScanOrder::kReversed, 1);
  EXPECT_EQ(at(reversed, 0), std::make_pair(345.0, 172.5));
  const auto serpentine = InScanOrder(grid, ScanOrder::kSerpentine, 1);
  EXPECT_EQ(at(serpentine, 23), std::make_pair(345.0, 7.5));   // ring 0 forwards
  EXPECT_EQ(at(serpentine, 24), std::make_pair(345.0, 22.5));  // ring 1 backwards
  EXPECT_EQ(at(serpentine, 47), std::make_pair(0.0, 22.5));
  EXPECT_EQ(at(serpentine, 48), std::make_pair(0.0, 37.5));  // ring 2 forwards
  const auto columns = InScanOrder(grid, ScanOrder::kColumns, 1);
  EXPECT_EQ(at(columns, 1), std::make_pair(0.0, 22.5));
  EXPECT_EQ(at(columns, 11), std::make_pair(0.0, 172.5));
  EXPECT_EQ(at(columns, 12), std::make_pair(15.0, 7.5));
  // Shuffled: the same for a seed, another for another seed, and far from any ring order.
  const auto a = InScanOrder(grid, ScanOrder::kShuffled, 5), b = InScanOrder(grid, ScanOrder::kShuffled, 5),
             c = InScanOrder(grid, ScanOrder::kShuffled, 6);
  EXPECT_EQ(Sorted(a), Sorted(b));
  int same_ab = 0, same_ac = 0, same_rings = 0;
  for (std::size_t i = 0; i < grid.size(); ++i) {
    same_ab += at(a, i) == at(b, i);
    same_ac += at(a, i) == at(c, i);
    same_rings += at(a, i) == at(grid, i);
  }
  EXPECT_EQ(same_ab, 288);
  EXPECT_LT(same_ac, 10);
  EXPECT_LT(same_rings, 10);
}

TEST(Simulate, ScanOrdersChangeTheTimesNotThePoints) {
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(-2, 0, 0)};
  spec.scan_order = ScanOrder::kColumns;
  spec.scan_orders = {{1, ScanOrder::kShuffled}, {2, ScanOrder::kSerpentine}};
  spec.effects.form = {{3, 2, 0.1}};
  const PointsData d = Simulate(spec);
  SimulationSpec in_rings = spec;
  in_rings.scan_order = ScanOrder::kRings;
  in_rings.scan_orders.clear();
  const PointsData ref = Simulate(in_rings);
  ASSERT_EQ(d.samples.size(), 864u);
  std::map<std::tuple<int, double, double>, double> reading;
  for (const Sample& s : ref.samples) reading[{s.setup, s.theta_deg, s.phi_deg}] = s.r_mm;
  for (int setup = 0; setup < 3; ++setup) {
    std::vector<AnglePair> seen;
    for (const Sample& s : d.samples) {
      if (s.setup == setup) seen.push_back({s.theta_deg, s.phi_deg});
    }
    EXPECT_EQ(Sorted(seen), Sorted(spec.pattern)) << "setup " << setup;
  }
  for (std::size_t i = 0; i < d.samples.size(); ++i) {
    const Sample& s = d.samples[i];
    EXPECT_EQ(s.t_s, static_cast<double>(i));  // times follow the rows
    EXPECT_EQ(s.r_mm, (reading[{s.setup, s.theta_deg, s.phi_deg}])) << "the same point reads the same";
  }
  EXPECT_EQ(d.samples[1].theta_deg, 0.0);  // setup 0 in columns
  EXPECT_EQ(d.samples[1].phi_deg, 22.5);
  EXPECT_EQ(d.samples[576 + 24].theta_deg, 345.0);  // setup 2, ring 1 backwards
  // A drift follows the time, so in another order the same point reads differently.
  spec.effects.model.terms.push_back({Effect::kProbeDrift, {{1, 0, false}}});  // t1
  spec.effects.values.push_back({0.5e-3});
  in_rings.effects.model = spec.effects.model;
  in_rings.effects.values = spec.effects.values;
  const PointsData drift = Simulate(spec), drift_rings = Simulate(in_rings);
  EXPECT_NE(drift.samples[1].r_mm, drift_rings.samples[24].r_mm);  // (0, 22.5) at t 1 and t 24
  // r_read = distance - t1 (t - t0) / T: the earlier reading is the larger, by t1 * 23 s / 863 s.
  EXPECT_NEAR(drift.samples[1].r_mm - drift_rings.samples[24].r_mm, 0.5e-3 * 23.0 / 863.0, 1e-12);
}

TEST(Simulate, MountRotationsGoIntoTheHeaderAndTheReadings) {
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(2, 0, 0)};
  spec.mount_rotations_deg = {{1, Eigen::Vector3d(0, 0, 90)}, {2, Eigen::Vector3d(90, 0, 0)}};
  spec.mount_unknown = {2};
  spec.effects.form = {{2, 1, 0.3}};
  const PointsData d = Simulate(spec);
  ASSERT_EQ(d.header.mount_rotations.size(), 2u);
  EXPECT_EQ(d.header.mount_rotations.at(1), MountRotation::Known(Eigen::Vector3d(0, 0, 90)));
  EXPECT_EQ(d.header.mount_rotations.at(2), MountRotation::Unknown());
  // Setup 1 is turned by 90 deg about z: S_2,1 seen as S_2,-1 (TurnsAboutZ... above).
  SimulationSpec as_21m = spec;
  as_21m.mount_rotations_deg.clear();
  as_21m.mount_unknown.clear();
  as_21m.effects.form = {{2, -1, 0.3}};
  const PointsData e = Simulate(as_21m);
  for (std::size_t i = 288; i < 576; ++i) EXPECT_NEAR(d.samples[i].r_mm, e.samples[i].r_mm, 1e-13);
  // Setup 2 is simulated with its rotation though the header does not say it.
  EXPECT_GT(std::abs(d.samples[600].r_mm - d.samples[600 - 576].r_mm), 1e-5);

  spec.mount_rotations_deg = {{3, Eigen::Vector3d(0, 0, 1)}};
  try {
    Simulate(spec);
    ADD_FAILURE() << "no error";
  } catch (const Error& err) {
    EXPECT_THAT(err.what(),
                ::testing::HasSubstr("a mount rotation is given for setup 3, but the 3 setup(s) are 0 to 2"));
  }
}

TEST(Simulate, AnotherSphereIsReadAtItsRadiusWithoutTheReferenceSpheresForm) {
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  spec.truth = ScmsGeometry{};
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(2, 0, 0)};
  spec.sphere_radii_mm = {{1, 10.0}};
  spec.pattern = {{0.0, 90.0}, {0.0, 0.0}};
  spec.effects.form = {{2, 0, 0.5}};  // the reference sphere's
  const PointsData d = Simulate(spec);
  EXPECT_EQ(d.header.sphere_radii_mm, spec.sphere_radii_mm);
  ASSERT_EQ(d.samples.size(), 4u);
  // By hand, errors zero: at theta 0, phi 90 deg the beam runs along x to the surface at x = e + R;
  // at the pole it hits the sphere of radius R shifted by e at height sqrt(R^2 - e^2).
  EXPECT_NEAR(d.samples[2].r_mm, 25.0 - 12.0, 1e-12);
  EXPECT_NEAR(d.samples[3].r_mm, 25.0 - std::sqrt(100.0 - 4.0), 1e-12);
  // The reference sphere keeps its form: S(2,0) is 1 at the pole, -1/2 on the equator (0.5 um each).
  EXPECT_NEAR(d.samples[0].r_mm, 25.0 - (22.0 - 0.5 * 0.5e-3), 1e-9);  // the surface 0.25 um lower
  EXPECT_GT(std::abs(d.samples[1].r_mm - (25.0 - std::sqrt(400.0 - 4.0))), 4e-4);

  spec.sphere_radii_mm = {{2, 10.0}};
  EXPECT_THROW(Simulate(spec), Error);
  spec.sphere_radii_mm = {{1, 0.0}};
  try {
    Simulate(spec);
    ADD_FAILURE() << "no error";
  } catch (const Error& err) {
    EXPECT_THAT(err.what(), ::testing::HasSubstr("the radius of the sphere of setup 1 must be positive"));
  }
}

TEST(Simulate, ReadingsLieOnTheTurnedFormBearingSurfaceSeenThroughTheModel) {
  // Noise-free readings of the Table 1 machine, mapped back to points by the model header's
  // forward model (Eq. 1), lie on the surface of each setup: |p - O| = rho(R^T (p - O) / |p - O|),
  // with rho written here from the model's harmonics, the bump's Gaussian and the flat's plane.
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(2, 0, 0)};
  spec.mount_rotations_deg = {{1, Eigen::Vector3d(0, 0, 90)}, {2, Eigen::Vector3d(90, 0, 0)}};
  spec.scan_orders = {{2, ScanOrder::kShuffled}};
  spec.effects.form = {{2, 2, 0.3}, {5, -3, 0.1}};
  spec.effects.bumps = {{0.4, 10.0, Eigen::Vector3d(0, 1, 0)}};
  spec.effects.flats = {{1.0, Eigen::Vector3d(0, 0, 1)}};
  const PointsData d = Simulate(spec);
  const ScmsGeometry g = SimulationSpec::PaperTruth();
  const double w = 10.0 * kPi / 180.0;
  double worst = 0.0;
  for (const Sample& s : d.samples) {
    const Eigen::Vector3d x =
        ScmsPoint(g, s.theta_deg * kPi / 180.0, s.phi_deg * kPi / 180.0, s.r_mm, 25.0) - spec.centers_mm[s.setup];
    const Eigen::Vector3d rv = s.setup == 0 ? Eigen::Vector3d::Zero() : spec.mount_rotations_deg.at(s.setup);
    const Eigen::Vector3d u =
        (s.setup == 0 ? Eigen::Matrix3d::Identity() : HandRotation(rv)).transpose() * x.normalized();
    const double lon = std::atan2(u.y(), u.x());
    const double gamma = std::acos(std::clamp(u.y(), -1.0, 1.0));
    const double h_um = 0.3 * SchmidtHarmonic(2, 2, lon, u.z()) + 0.1 * SchmidtHarmonic(5, -3, lon, u.z()) +
                        0.4 * std::exp(-gamma * gamma / (2 * w * w));
    double rho = 20.0 + 1e-3 * h_um;
    if (u.z() > 0.0) rho = std::min(rho, (20.0 - 1e-3) / u.z());
    worst = std::max(worst, std::abs(x.norm() - rho));
  }
  EXPECT_LT(worst, 1e-11);  // the 10 decimals of a points file are not involved: PointsData in memory
}

TEST(Simulate, RefusesFormsThatCannotBeASurface) {
  SimulationSpec spec;
  spec.effects.flats = {{0.0, Eigen::Vector3d::UnitX()}};
  EXPECT_THROW(Simulate(spec), Error);
  spec.effects.flats = {{1.0, Eigen::Vector3d::Zero()}};
  EXPECT_THROW(Simulate(spec), Error);
  spec.effects.flats = {{20000.0, Eigen::Vector3d::UnitX()}};  // as deep as the radius
  EXPECT_THROW(Simulate(spec), Error);
  spec.effects.flats.clear();
  spec.effects.bumps = {{1.0, 0.0, Eigen::Vector3d::UnitX()}};
  EXPECT_THROW(Simulate(spec), Error);
  spec.effects.bumps.clear();
  spec.effects.form = {{2, 0, 25000.0}};  // 25 mm on a 20 mm sphere
  EXPECT_THROW(Simulate(spec), Error);
}

TEST(SimulationTruthJson, StatesWhatThePointsWereMadeOf) {
  SimulationSpec spec;
  spec.pattern = GridPattern(12, 6);
  spec.seed = 7;
  spec.truth[kB] = 0.01;  // mm
  spec.effects.outlier_fraction = 0.25;
  spec.effects.outlier_um = 3.0;
  EffectReference reference;
  const PointsData data = Simulate(spec, &reference);
  const std::string truth = SimulationTruthJson(spec, reference, data);
  EXPECT_THAT(truth, ::testing::HasSubstr("\"format\": \"sph-truth\""));
  EXPECT_THAT(truth, ::testing::HasSubstr("\"n_points\": 72"));
  EXPECT_THAT(truth, ::testing::HasSubstr("\"seed\": 7"));
  EXPECT_THAT(truth, ::testing::HasSubstr("\"fraction\": 0.25"));
  EXPECT_THAT(truth, ::testing::ContainsRegex("\"b\": \\{\\s*\"unit\": \"mm\",\\s*\"value\": 0.01"));
}

}  // namespace
}  // namespace sph

namespace sph {
namespace {

// A host program's options are checked as the app's are, with the app's words.
TEST(SimulationOptions, ValuesOutOfRangeAreRefusedAsTheAppsOptions) {
  const auto message = [](const SimulationOptions& o) {
    try {
      RunSimulation(o);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  SimulationOptions o;
  o.machine.noise_r_um = -1.0;  // a negative sigma was simulated before
  EXPECT_EQ(message(o), "--noise-r-um: must be >= 0 and <= 1000 um, got -1");
  o = SimulationOptions();
  o.machine.theta_steps = 0;
  EXPECT_EQ(message(o), "--theta-steps: must be >= 1 and <= 1e+06, got 0");
  o = SimulationOptions();
  o.outlier_fraction = 2.0;
  EXPECT_EQ(message(o), "--outlier-fraction: must be >= 0 and <= 1, got 2");
  o = SimulationOptions();
  o.centers_mm = {"1,0"};
  EXPECT_EQ(message(o), "--center-mm '1,0': expected x,y,z in mm");
}

TEST(SimulationOptions, RunSimulationIsSimulateOfTheSpecWithTheAppsHeader) {
  SimulationOptions o;
  o.centers_mm = {"2,0,0", "0,2,0"};
  o.effects_arcsec = {"theta_encoder.c2=6"};
  o.seed = 7;
  const SimulationRun run = RunSimulation(o);
  const PointsData direct = Simulate(SimulationSpecOf(o));
  ASSERT_EQ(run.points.samples.size(), direct.samples.size());
  for (std::size_t i = 0; i < direct.samples.size(); ++i) {
    EXPECT_EQ(run.points.samples[i].r_mm, direct.samples[i].r_mm) << i;
    EXPECT_EQ(run.points.samples[i].setup, direct.samples[i].setup) << i;
  }
  EXPECT_EQ(run.points.header.metadata.front().first, "generator");
  EXPECT_THAT(run.points.header.metadata.front().second, ::testing::StartsWith("sph_simulate "));
  EXPECT_EQ(run.points.header.metadata[1], (std::pair<std::string, std::string>("seed", "7")));
  EXPECT_THAT(run.truth_json, ::testing::HasSubstr("\"sph-truth\""));
}

}  // namespace
}  // namespace sph
