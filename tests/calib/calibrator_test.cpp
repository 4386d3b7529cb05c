#include "sph/calib/calibrator.hpp"

#include <algorithm>
#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "calib_test_util.hpp"
#include "sph/core/error.hpp"
#include "sph/simulation/simulate.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using ::testing::HasSubstr;

using sph::testing::PaperOptions;

// Every estimate of the ten parameters (rad, mm) against the truth.
void ExpectRecovered(const CalibrationResult& r, const SimulationSpec& spec, double tol) {
  for (int p = 0; p < kNumScmsParams; ++p) {
    EXPECT_NEAR(r.geometry[static_cast<std::size_t>(p)], spec.truth[static_cast<std::size_t>(p)], tol)
        << kScmsParamInfo[static_cast<std::size_t>(p)].name;
  }
  ASSERT_EQ(r.centers_mm.size(), spec.centers_mm.size());
  for (std::size_t k = 0; k < spec.centers_mm.size(); ++k) {
    EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, r.centers_mm[k], spec.centers_mm[k], tol);
  }
}

TEST(Calibrate, NoiseFreeDataRecoversAllTenParameters) {
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  const CalibrationResult r = Calibrate(Simulate(spec), PaperOptions());
  EXPECT_TRUE(r.converged) << r.solver_message;
  // 1e-9 in mm and in deg; the angles are held in rad, so the bound there is 1e-9 deg in rad.
  for (int p = 0; p < kNumScmsParams; ++p) {
    const double tol =
        kScmsParamInfo[static_cast<std::size_t>(p)].quantity == Quantity::kAngle ? 1e-9 * kRadPerDeg : 1e-9;
    EXPECT_NEAR(r.geometry[static_cast<std::size_t>(p)], spec.truth[static_cast<std::size_t>(p)], tol)
        << kScmsParamInfo[static_cast<std::size_t>(p)].name;
  }
  EXPECT_PRED_FORMAT3(sph::testing::MatrixNear, r.centers_mm[0], spec.centers_mm[0], 1e-9);
  EXPECT_LT(r.rms_um, 1e-6);
}

TEST(Calibrate, ASetupOnAnotherSphereIsFittedAtThatSpheresRadius) {
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 1, 0)};
  spec.sphere_radii_mm = {{1, 10.0}};
  const PointsData points = Simulate(spec);
  CalibrationOptions options = PaperOptions();
  // The header names another sphere: a fit without its radius is refused, not fitted at R0.
  try {
    Calibrate(points, options);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("setup 1 measured another sphere (sphere_radius_mm@1), but the fit was given no "
                                    "radius for it"));
  }
  options.sphere_radii_mm = points.header.sphere_radii_mm;
  const CalibrationResult r = Calibrate(points, options);
  EXPECT_TRUE(r.converged) << r.solver_message;
  EXPECT_LT(r.rms_um, 1e-6);
  ExpectRecovered(r, spec, 1e-9);
  // Its residuals are taken against its own radius.
  ASSERT_EQ(r.residuals_mm.size(), points.samples.size());
  for (double e : r.residuals_mm) EXPECT_LT(std::abs(e), 1e-9);
}

TEST(Calibrate, NoiseFreeDataWithAngleErrorsFarFromTheStart) {
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  spec.truth = {0.3 * kRadPerDeg, 0.05, -0.2 * kRadPerDeg, -0.03, 0.25 * kRadPerDeg, 0.04, 0.5};
  spec.centers_mm = {Eigen::Vector3d(1.0, -1.5, 0.7)};
  const CalibrationResult r = Calibrate(Simulate(spec), PaperOptions());
  EXPECT_TRUE(r.converged) << r.solver_message;
  ExpectRecovered(r, spec, 1e-9);
  EXPECT_TRUE(r.outliers.empty());  // the large errors' own residuals at the start are no outliers
}

TEST(Calibrate, NoisyPaperCaseIsWithinThreeReportedStd) {
  SimulationSpec spec;  // paper truth, 2 mm, 0.05 um
  const CalibrationResult r = Calibrate(Simulate(spec), PaperOptions());
  ASSERT_TRUE(r.Usable()) << r.solver_message;
  EXPECT_NEAR(r.rms_um, 0.05, 0.01);
  for (int p = 0; p < kNumScmsParams; ++p) {
    const double sd = r.analysis.std(p);
    EXPECT_LT(std::abs(r.geometry[static_cast<std::size_t>(p)] - spec.truth[static_cast<std::size_t>(p)]), 3 * sd)
        << kScmsParamInfo[static_cast<std::size_t>(p)].name;
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(std::abs(r.centers_mm[0](k) - spec.centers_mm[0](k)), 3 * r.analysis.std(kNumScmsParams + k));
  }
}

// The reported std is the linearised one; it must describe the real spread of repeated calibrations.
TEST(Calibrate, ReportedStdMatchesTheSpreadOverSeeds) {
  constexpr int kSeeds = 200;
  SimulationSpec spec;
  const int n = kNumScmsParams + 3;
  Eigen::ArrayXd sum = Eigen::ArrayXd::Zero(n), sum2 = Eigen::ArrayXd::Zero(n), reported = Eigen::ArrayXd::Zero(n);
  for (int s = 0; s < kSeeds; ++s) {
    spec.seed = 1000 + static_cast<std::uint64_t>(s);
    const CalibrationResult r = Calibrate(Simulate(spec), PaperOptions());
    ASSERT_TRUE(r.converged);
    Eigen::ArrayXd x(n);
    for (int p = 0; p < kNumScmsParams; ++p) x(p) = r.geometry[static_cast<std::size_t>(p)];
    x.tail<3>() = r.centers_mm[0].array();
    sum += x;
    sum2 += x * x;
    reported += r.analysis.std.array();
  }
  const Eigen::ArrayXd mean = sum / kSeeds;
  const Eigen::ArrayXd spread = ((sum2 - kSeeds * mean * mean) / (kSeeds - 1)).sqrt();
  reported /= kSeeds;
  // The sample std of 200 draws scatters by 1/sqrt(2 * 199) = 5 % (1 sigma); 15 % is 3 sigma.
  for (int p = 0; p < n; ++p) {
    EXPECT_NEAR(reported(p) / spread(p), 1.0, 0.15) << "parameter " << p;
  }
}

TEST(Calibrate, CentredSphereNamesTheUndeterminedParameters) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(0.01, 0.0, 0.0)};
  const CalibrationResult r = Calibrate(Simulate(spec), PaperOptions());
  EXPECT_FALSE(r.Usable());
  std::vector<std::string> undetermined;
  for (std::size_t i = 0; i < r.analysis.parameters.size(); ++i) {
    if (!r.analysis.determined[i]) undetermined.push_back(r.analysis.parameters[i].name);
  }
  EXPECT_THAT(undetermined, ::testing::IsSupersetOf({"b", "c", "beta", "epsilon"}));
  std::string all;
  for (const auto& w : r.warnings) all += w + "\n";
  EXPECT_THAT(all, HasSubstr("eccentricity"));
  EXPECT_THAT(all, HasSubstr("undetermined parameters"));
  ASSERT_FALSE(r.analysis.weak.empty());
  EXPECT_GT(r.analysis.condition_number, 1e3);
}

// Centres 2 mm off along x and along y: each alone determines everything, together better.
TEST(Calibrate, TwoSetupsBeatEitherAlone) {
  SimulationSpec both;
  both.centers_mm = {Eigen::Vector3d(2.0, 0.0, 0.0), Eigen::Vector3d(0.0, 2.0, 0.0)};
  const CalibrationResult r = Calibrate(Simulate(both), PaperOptions());
  ASSERT_TRUE(r.Usable());
  ASSERT_EQ(r.centers_mm.size(), 2u);
  EXPECT_EQ(r.analysis.parameters[kNumScmsParams + 3].name, "center_x@1");
  for (int p = 0; p < kNumScmsParams; ++p) {
    EXPECT_LT(std::abs(r.geometry[static_cast<std::size_t>(p)] - both.truth[static_cast<std::size_t>(p)]),
              3 * r.analysis.std(p));
  }
  for (std::size_t k = 0; k < 2; ++k) {
    for (int i = 0; i < 3; ++i) {
      EXPECT_LT(std::abs(r.centers_mm[k](i) - both.centers_mm[k](i)),
                3 * r.analysis.std(kNumScmsParams + 3 * static_cast<int>(k) + i));
    }
  }
  for (const auto& centre : both.centers_mm) {
    SimulationSpec one;
    one.centers_mm = {centre};
    const CalibrationResult single = Calibrate(Simulate(one), PaperOptions());
    for (int p : {kB, kC, kBeta, kEpsilon}) {
      EXPECT_LT(r.analysis.std(p), single.analysis.std(p)) << kScmsParamInfo[static_cast<std::size_t>(p)].name;
    }
  }
}

// A centre on the Theta axis (2 mm along it) looks the same from every theta: azimuthal
// shifts (b, epsilon) and the axis errors cannot be told from the centre; the report says so.
TEST(Calibrate, CentreOnTheThetaAxisLeavesAzimuthalErrorsUndetermined) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(0.0, 0.0, 2.0)};
  auto warnings = [](const CalibrationResult& r) {
    std::string all;
    for (const auto& w : r.warnings) all += w + "\n";
    return all;
  };
  // The design itself, without noise: b and epsilon are undetermined, c is determined, and the
  // report places the centre on the axis.
  spec.noise_r_um = 0.0;
  const CalibrationResult exact = Calibrate(Simulate(spec), PaperOptions());
  EXPECT_FALSE(exact.Usable());
  EXPECT_FALSE(exact.analysis.determined[kB]);
  EXPECT_FALSE(exact.analysis.determined[kEpsilon]);
  EXPECT_TRUE(exact.analysis.determined[kC]);
  EXPECT_THAT(warnings(exact), HasSubstr("mm off the Theta axis and 2 mm along it"));
  // With noise the fit stops at an arbitrary point of the valley of the undetermined parameters
  // (alpha 0.036 rad from the truth in the median of 300 seeds, 3 rad at most) and the centre's
  // height is itself undetermined. At some of those points c is coupled to them: in 18 of 300 seeds
  // its reported std exceeds 10 um (c is then 22-81 um off, so the report is right). What holds for
  // every realisation: b and epsilon undetermined, the calibration not usable, and why.
  spec.noise_r_um = 0.05;
  const CalibrationResult r = Calibrate(Simulate(spec), PaperOptions());
  EXPECT_FALSE(r.Usable());
  EXPECT_FALSE(r.analysis.determined[kB]);
  EXPECT_FALSE(r.analysis.determined[kEpsilon]);
  EXPECT_THAT(warnings(r), HasSubstr("a centre on the Theta axis moreover looks the same from every theta"));
}

TEST(Calibrate, TooFewSamplesIsAnError) {
  SimulationSpec spec;
  spec.pattern = GridPattern(5, 2);  // 10 samples for 10 parameters
  try {
    Calibrate(Simulate(spec), PaperOptions());
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("10 samples are too few to fit 10 parameters"));
  }
}

TEST(Calibrate, AnalysisCanBeSkipped) {
  CalibrationOptions o = PaperOptions();
  o.analyse = false;
  const CalibrationResult r = Calibrate(Simulate(SimulationSpec()), o);
  EXPECT_TRUE(r.converged);
  EXPECT_TRUE(r.analysis.Empty());
  EXPECT_TRUE(r.Usable());
}

}  // namespace
}  // namespace sph

namespace sph {
namespace {

// Gross errors in otherwise good data: each is found, left out, and the calibration is that of
// the good readings.
TEST(Calibrate, LeavesOutGrossErrorsAndSaysWhich) {
  for (const double size_um : {1000.0, 2.0}) {
    SimulationSpec spec;
    PointsData points = Simulate(spec);
    const CalibrationResult clean = Calibrate(points, PaperOptions());
    for (std::size_t i : {17u, 140u, 263u}) points.samples[i].r_mm += (i % 2 ? 1 : -1) * size_um * kMmPerUm;
    const CalibrationResult r = Calibrate(points, PaperOptions());
    ASSERT_EQ(r.outliers.size(), 3u) << size_um;
    EXPECT_EQ(r.outliers[0].sample, 17u);
    EXPECT_EQ(r.outliers[1].sample, 140u);
    EXPECT_EQ(r.outliers[2].sample, 263u);
    EXPECT_NEAR(std::abs(r.outliers[1].residual_um), size_um, 0.5 + 0.01 * size_um);
    EXPECT_TRUE(r.Usable());
    EXPECT_EQ(r.n_points, 285);
    EXPECT_EQ(r.residuals_mm.size(), points.samples.size());
    for (int p = 0; p < kNumScmsParams; ++p) {
      // Three readings fewer: the estimates move by a small fraction of their std.
      EXPECT_NEAR(r.geometry[static_cast<std::size_t>(p)], clean.geometry[static_cast<std::size_t>(p)],
                  0.5 * clean.analysis.std(p))
          << kScmsParamInfo[static_cast<std::size_t>(p)].name;
    }
    ASSERT_FALSE(r.warnings.empty());
    EXPECT_THAT(r.warnings[0], HasSubstr("3 outlier(s) left out"));
    EXPECT_THAT(r.warnings[0], HasSubstr("sample 18 (theta"));
  }
}

TEST(Calibrate, FindsNoOutliersInGaussianNoise) {
  for (std::uint64_t seed = 1; seed <= 30; ++seed) {
    SimulationSpec spec;
    spec.seed = seed;
    EXPECT_TRUE(Calibrate(Simulate(spec), PaperOptions()).outliers.empty()) << "seed " << seed;
  }
  SimulationSpec exact;
  exact.noise_r_um = 0.0;
  EXPECT_TRUE(Calibrate(Simulate(exact), PaperOptions()).outliers.empty());
}

}  // namespace
}  // namespace sph

namespace sph {
namespace {

// Hostile data: a clear error, never a silently wrong calibration.
TEST(Calibrate, AllPointsEqualOrOnePhiRingIsAnError) {
  PointsData equal;
  equal.source = "equal.txt";
  for (int i = 0; i < 50; ++i) equal.samples.push_back({10.0, 45.0, 5.0, static_cast<double>(i), 0});
  EXPECT_THAT([&] { Calibrate(equal, PaperOptions()); },
              ::testing::ThrowsMessage<Error>(HasSubstr("equal.txt: the points of setup 0 do not determine a sphere")));
  SimulationSpec ring;
  ring.pattern = GridPattern(24, 1);  // phi = 90 deg only: all points on one plane
  PointsData one_ring = Simulate(ring);
  one_ring.source = "ring.txt";
  EXPECT_THAT([&] { Calibrate(one_ring, PaperOptions()); },
              ::testing::ThrowsMessage<Error>(HasSubstr("ring.txt: the points of setup 0 do not determine a sphere")));
}

}  // namespace
}  // namespace sph
