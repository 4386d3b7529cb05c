#include "sph/measure/sphere_measurement.hpp"

#include <cmath>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/io/calibration_file.hpp"
#include "sph/core/error.hpp"
#include "sph/stats/gum.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/model/compensation.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using sph::testing::MatrixNear;
using ::testing::HasSubstr;

std::vector<RawReading> ReadingsOf(const PointsData& data) {
  std::vector<RawReading> r;
  for (const Sample& s : data.samples) r.push_back({s.theta_deg, s.phi_deg, s.r_mm});
  return r;
}

// Readings of the paper's machine (Table 1 errors, R0 20 mm, d 25 mm, 24 x 12 grid) measuring a
// sphere at `center`, ray-traced independently of the model, with noise on r [um].
std::vector<RawReading> PaperReadings(const Eigen::Vector3d& center, double noise_r_um) {
  SimulationSpec spec;
  spec.centers_mm = {center};
  spec.noise_r_um = noise_r_um;
  return ReadingsOf(Simulate(spec));
}

Calibration TruthCalibration() {
  Calibration cal;
  cal.geometry = SimulationSpec::PaperTruth();
  cal.probe_offset_mm = 25.0;
  return cal;
}

// A plausible calibration covariance (rad, mm): angles 2e-5 rad, lengths 0.5 um, and the strong
// b-c-beta-epsilon correlations an eccentric calibration leaves.
ScmsCovariance PlausibleCovariance() {
  Eigen::Matrix<double, kNumScmsParams, 1> sd;
  sd << 2e-6, 2e-4, 2e-5, 5e-4, 2e-5, 5e-4, 1e-4;
  ScmsCovariance corr = ScmsCovariance::Identity();
  corr(kBeta, kC) = corr(kC, kBeta) = 0.9;
  corr(kEpsilon, kB) = corr(kB, kEpsilon) = -0.8;
  return sd.asDiagonal() * corr * sd.asDiagonal();
}

// Points evenly (Fibonacci lattice) over the cap within half_angle_deg of +z.
std::vector<Eigen::Vector3d> Cap(double radius, double half_angle_deg, int n) {
  const double z_min = std::cos(half_angle_deg * kRadPerDeg);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (1.0 - z_min) * (i + 0.5) / n, s = std::sqrt(1.0 - z * z), a = 2.39996323 * i;
    pts.push_back(radius * Eigen::Vector3d(s * std::cos(a), s * std::sin(a), z));
  }
  return pts;
}

TEST(EvaluateSphere, CompensatedRayTracedReadingsLieOnTheSphere) {
  // The compensation with the true errors inverts the independent ray tracer.
  const SphereEvaluation ev =
      EvaluateSphere(CompensateAll(TruthCalibration(), PaperReadings({5, 1, -0.5}, 0.0)), "sim");
  EXPECT_PRED_FORMAT3(MatrixNear, ev.ls.sphere.center, Eigen::Vector3d(5, 1, -0.5), 1e-9);
  EXPECT_NEAR(ev.ls.sphere.radius, 20.0, 1e-9);
  EXPECT_LT(ev.sphericity_ls_mm, 1e-9);
  EXPECT_LT(ev.mz.width, 1e-9);
  EXPECT_EQ(ev.n_points, 288);
  EXPECT_FALSE(ev.poorly_determined);
  EXPECT_TRUE(ev.warnings.empty());
  EXPECT_GT(ev.coverage.cap_half_angle_deg, 170.0);
  EXPECT_LT(ev.radius_dilution, 1.2);
}

TEST(EvaluateSphere, TheNominalModelShowsTheGeometricErrors) {
  // The paper's Table 3 "before": about 3.5 um of sphericity at 2 mm eccentricity.
  Calibration nominal;
  nominal.probe_offset_mm = 25.0;
  const SphereEvaluation ev = EvaluateSphere(CompensateAll(nominal, PaperReadings({2, 0, 0}, 0.0)), "sim");
  EXPECT_NEAR(ev.sphericity_ls_mm * 1e3, 3.53, 0.01);
  EXPECT_LE(ev.mz.width, ev.sphericity_ls_mm);
}

TEST(EvaluateSphere, WarnsWhenTheCoverageLeavesTheSphereIllPosed) {
  const SphereEvaluation hemisphere = EvaluateSphere(Cap(20.0, 90.0, 400), "hemi");
  EXPECT_FALSE(hemisphere.poorly_determined);
  EXPECT_NEAR(hemisphere.coverage.cap_half_angle_deg, 90.0, 0.5);

  const SphereEvaluation cap = EvaluateSphere(Cap(20.0, 30.0, 400), "cap");
  EXPECT_TRUE(cap.poorly_determined);
  ASSERT_EQ(cap.warnings.size(), 1u);
  EXPECT_THAT(
      cap.warnings[0],
      HasSubstr(
          "ill-posed for the coverage: seen from the centre, the points lie within 30 deg of their mean direction"));
  EXPECT_THAT(cap.warnings[0], HasSubstr("determine the radius 24.1 times"));

  SphereEvaluationOptions loose;
  loose.max_dilution = 30.0;
  EXPECT_FALSE(EvaluateSphere(Cap(20.0, 30.0, 400), "cap", loose).poorly_determined);
}

TEST(EvaluateSphere, RefusesPointsThatDetermineNoSphere) {
  try {
    EvaluateSphere({{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, "three.xyz");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("three.xyz: 3 points are too few to determine a sphere (at least 4)"));
  }
  std::vector<Eigen::Vector3d> plane;
  for (int i = 0; i < 10; ++i) plane.emplace_back(std::cos(i), std::sin(i), 0.0);
  try {
    EvaluateSphere(plane, "plane.xyz");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("plane.xyz: the points determine no sphere"));
  }
}

// A point that is not finite (a NaN rotation of the form, say) or that lies beyond any machine (a
// coordinate of 1e153) is named as such; only points that genuinely lie on a plane or line, or are
// one point, are said to.
TEST(EvaluateSphere, NamesAPointThatIsNotFiniteOrBeyondAnyMachine) {
  std::vector<Eigen::Vector3d> points{{20, 0, 0}, {0, 20, 0}, {0, 0, 20}, {-20, 0, 0}, {0, -20, 0}, {0, 0, -20}};
  const auto message = [](const std::vector<Eigen::Vector3d>& p) {
    try {
      EvaluateSphere(p, "p.xyz");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::vector<Eigen::Vector3d> nan = points;
  nan[2].y() = std::nan("");
  EXPECT_EQ(message(nan), "p.xyz: point 3 of 6 (0 nan 20 mm) is not a finite point: no sphere is fitted through it");
  std::vector<Eigen::Vector3d> far = points;
  for (Eigen::Vector3d& p : far) p *= 1e151;
  EXPECT_EQ(message(far),
            "p.xyz: point 1 of 6 (2e+152 0 0 mm) lies beyond 1e+06 mm from the origin, which no "
            "measuring machine reaches: are the coordinates in mm?");
  std::vector<Eigen::Vector3d> shifted = points;
  for (Eigen::Vector3d& p : shifted) p.x() += 1e153;  // the sphere's x is lost in the rounding
  EXPECT_THAT(message(shifted), HasSubstr("p.xyz: point 1 of 6 (1e+153 0 0 mm) lies beyond 1e+06 mm"));
  EXPECT_EQ(message(std::vector<Eigen::Vector3d>(5, Eigen::Vector3d(1, 2, 3))),
            "p.xyz: the 5 points are all one point (1 2 3 mm)");
  for (Eigen::Vector3d& p : points) p *= 5e4;  // 1 km from the origin: still a sphere
  EXPECT_NEAR(EvaluateSphere(points, "p.xyz").ls.sphere.radius, 1e6, 1e-6);
}

// The form of the calibration sphere is taken off in the orientation its setup gives, and only
// off the calibration sphere.
TEST(CalibrationSphereRotation, IsTheSetupsMountRotationOfTheCalibrationSphere) {
  PointsHeader h;
  h.mount_rotations[1] = MountRotation::Known(Eigen::Vector3d(0, 0, 90));
  h.mount_rotations[2] = MountRotation::Unknown();
  h.mount_rotations[3] = MountRotation::Known(Eigen::Vector3d(1e308, 0, 0));
  h.sphere_radii_mm[4] = 10.0;
  EXPECT_TRUE(CalibrationSphereRotation(h, 0, "p.txt").isIdentity());
  EXPECT_TRUE(CalibrationSphereRotation(h, 1, "p.txt").isApprox(MountRotationMatrix(Eigen::Vector3d(0, 0, 90))));
  const auto message = [&](int setup) {
    try {
      CalibrationSphereRotation(h, setup, "p.txt");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(message(2), HasSubstr("p.txt: the mount rotation of setup 2 is unknown"));
  EXPECT_EQ(message(3),
            "p.txt: setup 3: mount_rotation_deg@3 1e+308 0 0 gives no rotation (its sines and cosines "
            "are not finite numbers)");
  EXPECT_EQ(message(4),
            "p.txt: setup 4 measured another sphere (sphere_radius_mm@4: 10 mm), not the calibration "
            "sphere whose form the calibration file holds: its form cannot be taken off these points");
}

TEST(EvaluateSphere, SaysThatFivePointsSayLittleAboutTheForm) {
  const SphereEvaluation ev =
      EvaluateSphere({{10, 0, 0}, {0, 10, 0}, {0, 0, 10}, {-10, 0, 0}, {0, -10.01, 0}}, "five.xyz");
  ASSERT_FALSE(ev.warnings.empty());
  EXPECT_THAT(ev.warnings.back(), HasSubstr("only 5 points"));
}

TEST(PropagateCalibrationUncertainty, SampledRadiusStdMatchesTheLinearisation) {
  Calibration cal = TruthCalibration();
  cal.covariance = PlausibleCovariance();
  const std::vector<RawReading> readings = PaperReadings({5, 0, 0}, 0.0);
  const SphereEvaluation nominal = EvaluateSphere(CompensateAll(cal, readings), "sim");
  // Linearised: dR/dg by central differences, sigma_R^2 = J Sigma J^T.
  Eigen::Matrix<double, 1, kNumScmsParams> j;
  for (int k = 0; k < kNumScmsParams; ++k) {
    const double h = 1e-3 * std::sqrt((*cal.covariance)(k, k));
    Calibration plus = cal, minus = cal;
    plus.geometry[static_cast<std::size_t>(k)] += h;
    minus.geometry[static_cast<std::size_t>(k)] -= h;
    j(k) = (FitSphereLeastSquares(CompensateAll(plus, readings)).sphere.radius -
            FitSphereLeastSquares(CompensateAll(minus, readings)).sphere.radius) /
           (2.0 * h);
  }
  const double linear = std::sqrt((j * *cal.covariance * j.transpose())(0, 0));
  UncertaintyOptions options;
  options.samples = 400;
  const CalibrationUncertainty u = PropagateCalibrationUncertainty(readings, cal, nominal, options);
  EXPECT_EQ(u.samples, 400);
  // The std of a std from 400 draws is 3.5 %: 15 % is over four of them.
  EXPECT_NEAR(u.radius_std_mm / linear, 1.0, 0.15) << "sampled " << u.radius_std_mm << " linearised " << linear;
  EXPECT_GT(u.sphericity_ls_std_mm, 0.0);
  EXPECT_GT(u.sphericity_mz_std_mm, 0.0);
  EXPECT_GT(u.calibration_form_p95_mm, 0.0);
  // The true form is nil: what is measured is within what the calibration alone produces.
  EXPECT_FALSE(u.form_exceeds_calibration);
}

TEST(PropagateCalibrationUncertainty, ARealFormErrorExceedsTheCalibration) {
  Calibration cal = TruthCalibration();
  cal.covariance = PlausibleCovariance();
  const std::vector<RawReading> readings = PaperReadings({5, 0, 0}, 0.5);  // 0.5 um of noise: ~3 um p-v
  const SphereEvaluation nominal = EvaluateSphere(CompensateAll(cal, readings), "sim");
  const CalibrationUncertainty u = PropagateCalibrationUncertainty(readings, cal, nominal);
  EXPECT_GT(nominal.sphericity_ls_mm, 2e-3);
  EXPECT_LT(u.calibration_form_p95_mm, 0.5 * nominal.sphericity_ls_mm);
  EXPECT_TRUE(u.form_exceeds_calibration);
}

TEST(PropagateCalibrationUncertainty, IsReproducibleAndZeroForAnExactCalibration) {
  Calibration cal = TruthCalibration();
  cal.covariance = PlausibleCovariance();
  const std::vector<RawReading> readings = PaperReadings({3, 0, 0}, 0.05);
  const SphereEvaluation nominal = EvaluateSphere(CompensateAll(cal, readings), "sim");
  UncertaintyOptions options;
  options.samples = 50;
  const CalibrationUncertainty a = PropagateCalibrationUncertainty(readings, cal, nominal, options);
  const CalibrationUncertainty b = PropagateCalibrationUncertainty(readings, cal, nominal, options);
  EXPECT_EQ(a.radius_std_mm, b.radius_std_mm);
  EXPECT_EQ(a.calibration_form_p95_mm, b.calibration_form_p95_mm);
  options.seed = 2;
  EXPECT_NE(PropagateCalibrationUncertainty(readings, cal, nominal, options).radius_std_mm, a.radius_std_mm);

  cal.covariance = ScmsCovariance::Zero();
  const CalibrationUncertainty zero = PropagateCalibrationUncertainty(readings, cal, nominal, options);
  EXPECT_EQ(zero.radius_std_mm, 0.0);
  EXPECT_EQ(zero.sphericity_ls_std_mm, 0.0);
  EXPECT_EQ(zero.calibration_form_p95_mm, 0.0);
}

TEST(PropagateCalibrationUncertainty, TheSameOnAnyNumberOfThreadsWithProgressForEveryDraw) {
  Calibration cal = TruthCalibration();
  cal.covariance = PlausibleCovariance();
  const std::vector<RawReading> readings = PaperReadings({3, 0, 0}, 0.05);
  const SphereEvaluation nominal = EvaluateSphere(CompensateAll(cal, readings), "sim");
  UncertaintyOptions options;
  options.samples = 40;
  options.threads = 1;
  const CalibrationUncertainty one = PropagateCalibrationUncertainty(readings, cal, nominal, options);
  std::vector<int> done;
  options.threads = 3;
  options.progress = [&](int d, int total) {
    EXPECT_EQ(total, 40);
    done.push_back(d);
  };
  const CalibrationUncertainty three = PropagateCalibrationUncertainty(readings, cal, nominal, options);
  EXPECT_EQ(one.radius_std_mm, three.radius_std_mm);
  EXPECT_EQ(one.center_std_mm, three.center_std_mm);
  EXPECT_EQ(one.sphericity_ls_std_mm, three.sphericity_ls_std_mm);
  EXPECT_EQ(one.sphericity_mz_std_mm, three.sphericity_mz_std_mm);
  EXPECT_EQ(one.calibration_form_p95_mm, three.calibration_form_p95_mm);
  ASSERT_EQ(done.size(), 40u);
  for (int i = 0; i < 40; ++i) EXPECT_EQ(done[static_cast<std::size_t>(i)], i + 1);
}

// A calibration with a probe gain and a Theta encoder term, and the joint covariance of the seven
// errors and their three parameters (internal units), as a calibration file holds it.
AppliedCalibration EffectBearingCalibration() {
  CalibrationFile file;
  file.geometry = SimulationSpec::PaperTruth();
  file.probe_offset_mm = 25.0;
  file.effects.terms = {{Effect::kThetaEncoder, {{2, 0, false}, {3, 0, true}}}, {Effect::kProbeGain, {{1, 0, false}}}};
  file.effect_values = {{6 * kRadPerArcsec, -4 * kRadPerArcsec}, {0.3 * kMmPerUm}};
  file.effects.reference = {2.0, 2.2, 0.0, 288.0};  // u = (r - 2 mm) / 2.2 mm: about 1.4 on these readings
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(10, 10);
  c.topLeftCorner<7, 7>() = PlausibleCovariance();
  c(7, 7) = std::pow(0.7 * kRadPerArcsec, 2);
  c(8, 8) = std::pow(0.6 * kRadPerArcsec, 2);
  c(9, 9) = std::pow(0.2 * kMmPerUm, 2);
  c(9, kDPrime) = c(kDPrime, 9) = -0.5 * std::sqrt(c(9, 9) * c(kDPrime, kDPrime));
  file.parameter_covariance = c;
  file.covariance = c.topLeftCorner<7, 7>();
  return AppliedCalibration::Of(file, false);
}

TEST(PropagateCalibrationUncertainty, DrawsTheEffectsWithTheSevenErrors) {
  const AppliedCalibration applied = EffectBearingCalibration();
  ASSERT_TRUE(applied.effects_in_covariance);
  ASSERT_EQ(applied.covariance.rows(), 10);
  EXPECT_EQ(applied.names.back(), "probe_gain.u1");
  const std::vector<RawReading> readings = PaperReadings({5, 0, 0}, 0.0);
  const SphereEvaluation nominal = EvaluateSphere(ApplyCalibration(applied, readings), "sim");
  UncertaintyOptions options;
  options.samples = 400;
  const CalibrationUncertainty full = PropagateCalibrationUncertainty(readings, applied, nominal, options);
  AppliedCalibration seven = applied;
  seven.covariance = applied.covariance.topLeftCorner<7, 7>();
  seven.effects_in_covariance = false;
  const CalibrationUncertainty alone = PropagateCalibrationUncertainty(readings, seven, nominal, options);
  // The linear budget: sqrt(c^T C c) with c by central differences.
  const std::array<ResultSensitivity, 3> c = SensitivitiesOf(readings, applied, nominal);
  ASSERT_EQ(c[0].per_parameter.size(), 10);
  const double linear = MeasurementBudget("", 0.0, gum::kInfiniteDof, c[0], applied, {}).u;
  EXPECT_NEAR(full.radius_std_mm / linear, 1.0, 0.15) << "sampled " << full.radius_std_mm << " linear " << linear;
  // The gain's 0.2 um at u = 1 moves the radius by about 0.2 * 1.4 um, more than the seven errors'
  // covariance alone (0.1 um of d').
  EXPECT_GT(full.radius_std_mm, 1.5 * alone.radius_std_mm);
  // The gain alone, worked out from the geometry: it adds du_i = (r_i - r_ref) / r_half per unit
  // of u1 to each reading, which moves the point along the probe line (towards the axes, the
  // direction -p_i / |p_i|) and so its residual about the sphere by -du_i (n_i . p_i / |p_i|);
  // the least-squares sphere takes the radius of those changes through its normal equations.
  const Sphere& sphere = nominal.ls.sphere;
  const std::vector<Eigen::Vector3d> points = ApplyCalibration(applied, readings);
  Eigen::MatrixXd jac(static_cast<Eigen::Index>(points.size()), 4);
  Eigen::VectorXd de(static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d n = (points[i] - sphere.center).normalized();
    const auto row = static_cast<Eigen::Index>(i);
    jac.row(row) << -n.transpose(), -1.0;  // d(|p - c| - R) / d(c, R)
    de(row) = -(readings[i].r_mm - 2.0) / 2.2 * n.dot(points[i].normalized());
  }
  const Eigen::Vector4d moved = -(jac.transpose() * jac).ldlt().solve(jac.transpose() * de);
  EXPECT_NEAR(c[0].per_parameter(9), moved(3), 0.01 * std::abs(moved(3)));
  // The radius is linear in the parameters: the JCGM 101 check agrees with the GUM interval.
  gum::PropagationOptions mo;
  mo.probability = 0.9545;
  mo.batch_trials = 1000;
  mo.max_trials = 40000;
  mo.significant_digits = 1;
  const gum::UncertaintyStatement st = MeasurementBudget("", 0.0, gum::kInfiniteDof, c[0], applied, {});
  const gum::PropagationResult mc =
      CheckByMonteCarlo(MeasuredResult::kRadius, readings, applied, nominal, 0.0, gum::kInfiniteDof, mo);
  EXPECT_TRUE(mc.converged);
  EXPECT_TRUE(gum::GufValidated(nominal.ls.sphere.radius, st.U, mc))
      << "GUM " << st.U << " MC [" << mc.low - nominal.ls.sphere.radius << ", " << mc.high - nominal.ls.sphere.radius
      << "] tolerance " << mc.tolerance;
}

// The calibration file's Type B inputs split the calibration's share: the contributions of its
// Type A part and of R0 combine to what the whole covariance gives; the probe scale acts through
// the calibration and through the readings at once.
TEST(MeasurementBudget, SplitsTheCalibrationIntoItsTypeAPartAndItsInputs) {
  AppliedCalibration applied = EffectBearingCalibration();
  const Eigen::MatrixXd type_a = applied.covariance;
  Eigen::VectorXd s_r0 = Eigen::VectorXd::Zero(10), s_scale = Eigen::VectorXd::Zero(10);
  s_r0(kDPrime) = 1.0056e-3;  // d' per um of R0
  s_scale(kDPrime) = 5.0;     // d' per unit of relative scale: the mean reading [mm]
  applied.inputs = {{"R0 (certificate)", "um", 0.2, s_r0}, {kProbeScaleInput, "relative", 1e-4, s_scale}};
  for (const auto& in : applied.inputs) applied.covariance += in.per_unit * in.per_unit.transpose() * in.u * in.u;
  applied.type_a_dof = 500;
  EXPECT_TRUE(applied.TypeACovariance().isApprox(type_a, 1e-12));
  const std::vector<RawReading> readings = PaperReadings({5, 0, 0}, 0.0);
  const SphereEvaluation nominal = EvaluateSphere(ApplyCalibration(applied, readings), "sim");
  const std::array<ResultSensitivity, 3> c = SensitivitiesOf(readings, applied, nominal);
  const gum::UncertaintyStatement st = MeasurementBudget("measurement", 1e-6, 284, c[0], applied, gum::CoverageSpec{});
  ASSERT_EQ(st.inputs.size(), 4u);
  EXPECT_EQ(st.inputs[1].name, "calibration: fit (scatter of its points)");
  EXPECT_EQ(st.inputs[1].dof, 500);
  EXPECT_NEAR(st.inputs[1].standard_uncertainty, std::sqrt(c[0].per_parameter.dot(type_a * c[0].per_parameter)), 1e-15);
  EXPECT_EQ(st.inputs[2].name, "calibration: R0 (certificate)");
  EXPECT_NEAR(st.inputs[2].sensitivity, c[0].per_parameter.dot(s_r0), 1e-15);
  // The scale through the readings: a larger reading is a point nearer the axes, so the measured
  // radius shrinks as the scale grows (about -mean(r) per unit of scale).
  EXPECT_NEAR(st.inputs[3].sensitivity, c[0].per_parameter.dot(s_scale) + c[0].per_probe_scale, 1e-15);
  EXPECT_LT(c[0].per_probe_scale, 0.0);
  // Uncorrelated inputs: the GUM's sum of squares equals c^T C c of the whole covariance plus the
  // direct part of the scale, cross term included.
  double expect = c[0].per_parameter.dot(applied.covariance * c[0].per_parameter) + 1e-12;
  expect +=
      2.0 * c[0].per_parameter.dot(s_scale) * c[0].per_probe_scale * 1e-8 + std::pow(c[0].per_probe_scale * 1e-4, 2);
  EXPECT_NEAR(st.u * st.u, expect, 1e-9 * expect);
  // The sampled propagation draws the same inputs (the scale on the readings too): its radius std
  // is the budget's calibration part, where the two paths of the scale nearly cancel.
  UncertaintyOptions options;
  options.samples = 400;
  const CalibrationUncertainty sampled = PropagateCalibrationUncertainty(readings, applied, nominal, options);
  double calibration2 = 0.0;
  for (std::size_t i = 1; i < st.inputs.size(); ++i) calibration2 += std::pow(st.inputs[i].Contribution(), 2);
  EXPECT_NEAR(sampled.radius_std_mm / std::sqrt(calibration2), 1.0, 0.15);
  EXPECT_LT(std::abs(st.inputs[3].sensitivity), 0.2 * std::abs(c[0].per_parameter.dot(s_scale)));
}

TEST(PropagateCalibrationUncertainty, NeedsACovarianceAndTwoSamples) {
  Calibration cal = TruthCalibration();
  const std::vector<RawReading> readings = PaperReadings({2, 0, 0}, 0.0);
  const SphereEvaluation nominal = EvaluateSphere(CompensateAll(cal, readings), "sim");
  EXPECT_THROW(PropagateCalibrationUncertainty(readings, cal, nominal), std::invalid_argument);
  cal.covariance = PlausibleCovariance();
  UncertaintyOptions one;
  one.samples = 1;
  EXPECT_THROW(PropagateCalibrationUncertainty(readings, cal, nominal, one), std::invalid_argument);
}

}  // namespace
}  // namespace sph
