#include "sph/calib/design.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "sph/calib/calibrator.hpp"
#include "sph/calib/montecarlo.hpp"

namespace sph {
namespace {

SimulationSpec AtEccentricity(double e_mm) {
  SimulationSpec s;
  s.centers_mm = {Eigen::Vector3d(e_mm, 0.0, 0.0)};
  return s;
}

TEST(PredictUncertainty, TangentialErrorsFallAsOneOverESquared) {
  const PredictedUncertainty u1 = PredictUncertainty(AtEccentricity(1.0));
  const PredictedUncertainty u2 = PredictUncertainty(AtEccentricity(2.0));
  for (int p : {kB, kC, kBeta, kEpsilon}) EXPECT_NEAR(u1.std(p) / u2.std(p), 4.0, 0.1);
  // d' and a are radial: hardly affected by the eccentricity.
  EXPECT_NEAR(u1.std(kA) / u2.std(kA), 1.0, 0.05);
}

TEST(PredictUncertainty, ScalesWithTheNoise) {
  SimulationSpec s = AtEccentricity(2.0);
  const PredictedUncertainty a = PredictUncertainty(s);
  s.noise_r_um *= 3.0;
  const PredictedUncertainty b = PredictUncertainty(s);
  for (int p = 0; p < kNumScmsParams; ++p) EXPECT_NEAR(b.std(p) / a.std(p), 3.0, 1e-6);
}

// The calibrator's reported std (from the residuals of one noisy fit) estimates the same thing.
TEST(PredictUncertainty, AgreesWithTheCalibratorsReportedStd) {
  const SimulationSpec s = AtEccentricity(2.0);
  CalibrationOptions o;
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  const CalibrationResult r = Calibrate(Simulate(s), o);
  const PredictedUncertainty u = PredictUncertainty(s);
  // The reported std carries the residual sigma of 288 points: 4 % scatter (1 sigma).
  for (int p = 0; p < kNumScmsParams + 3; ++p) EXPECT_NEAR(r.analysis.std(p) / u.std(p), 1.0, 0.12) << p;
}

TEST(PredictUncertainty, AngleNoiseAddsVariance) {
  SimulationSpec s = AtEccentricity(2.0);
  const PredictedUncertainty a = PredictUncertainty(s);
  s.noise_theta_arcsec = 0.5;
  const PredictedUncertainty b = PredictUncertainty(s);
  for (int p = 0; p < kNumScmsParams; ++p) EXPECT_GE(b.std(p), a.std(p)) << p;
}

TEST(SmallestEccentricityMm, MeetsTheTargetExactlyThere) {
  const SimulationSpec base;
  const std::vector<Eigen::Vector3d> x{Eigen::Vector3d::UnitX()};
  const auto e = SmallestEccentricityMm(base, x, 2.0, 1e-3, 10.0);
  ASSERT_TRUE(e.has_value());
  const double worst = PredictUncertainty(AtEccentricity(*e)).WorstErrorStdUm();
  EXPECT_NEAR(worst, 2.0, 1e-3);
  EXPECT_GT(PredictUncertainty(AtEccentricity(0.95 * *e)).WorstErrorStdUm(), 2.0);
  EXPECT_FALSE(SmallestEccentricityMm(base, x, 1e-6, 1e-3, 10.0).has_value());
}

// The plan's predictions against the Monte Carlo: 500 trials give the std to 3.2 % (1 sigma),
// so 10 % is three sigma. Over 300 such runs the ratio of the six errors other than d' has a mean of
// 0.996-0.999 and a std of 0.032-0.034, as that says.
//
// d' is not first order at 1 mm: a tangential error of 10 um changes the measured radius by
// delta^2 / 2 R0, which d' absorbs, so its Monte Carlo std exceeds the first-order bound
// (docs/validation.md, the paper's study; 3.7 times the bound at 0.5 mm). Over those 300 runs its ratio has a
// mean of 1.045 and a std of 0.035: 17 of them lie beyond 1.10. The bound is then a lower bound, and
// the ratio is held to three of its sampling std about that measured excess.
TEST(PredictUncertainty, MatchesTheMonteCarloSpread) {
  MonteCarloStudyOptions mc;
  mc.eccentricities_mm = {1.0};
  mc.trials = 500;
  mc.seed = 11;
  mc.threads = 2;
  const MonteCarloStudy r = RunMonteCarlo(mc);
  const PredictedUncertainty u = PredictUncertainty(AtEccentricity(1.0));
  for (int p = 0; p < kNumScmsParams; ++p) {
    const double ratio = r.rows[0].params[static_cast<std::size_t>(p)].std / u.std(p);
    const double expected = p == kDPrime ? 1.045 : 1.0,
                 sampling_std = p == kDPrime ? 0.035 : 1.0 / std::sqrt(2.0 * 499);
    EXPECT_NEAR(ratio, expected, 3.0 * sampling_std) << kScmsParamInfo[static_cast<std::size_t>(p)].name;
  }
}

}  // namespace
}  // namespace sph
