// What a calibration is told besides its readings: parameters held (CalibrationOptions::fixed),
// priors, bounds, and a robust loss in place of least squares.
#include <cmath>
#include <limits>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "calib_test_util.hpp"
#include "sph/calib/budget.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/calib/effect_fit.hpp"
#include "sph/core/error.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using sph::testing::PaperOptions;
using ::testing::HasSubstr;

// Each of the seven errors and the centre of `a` within `tol` times the standard uncertainties of
// `std` from `b`'s.
void ExpectWithinStd(const CalibrationResult& a, const CalibrationResult& b, const ObservabilityReport& std, double tol,
                     const std::string& what) {
  for (int p = 0; p < kNumScmsParams; ++p) {
    if (std.IsHeld(p)) continue;
    EXPECT_NEAR(a.geometry[static_cast<std::size_t>(p)], b.geometry[static_cast<std::size_t>(p)], tol * std.std(p))
        << kScmsParamInfo[static_cast<std::size_t>(p)].name << ": " << what;
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(a.centers_mm[0](k), b.centers_mm[0](k), tol * std.std(kNumScmsParams + k)) << "centre: " << what;
  }
}

// d' held at the value the free fit found: the others are the free fit's (its optimum is the held
// one's), the held value stays exactly, and the others' uncertainties are those of the rest given
// d' (the covariance conditioned on it).
TEST(FixedParameter, StaysPutAndTheOthersAreTheFitOfTheRest) {
  const PointsData points = Simulate(SimulationSpec{});
  const CalibrationResult free = Calibrate(points, PaperOptions());
  CalibrationOptions o = PaperOptions();
  o.fixed = {{"d_prime", free.geometry[kDPrime]}};
  const CalibrationResult held = Calibrate(points, o);
  ASSERT_TRUE(held.converged) << held.solver_message;
  EXPECT_EQ(held.geometry[kDPrime], free.geometry[kDPrime]);
  ASSERT_TRUE(held.analysis.IsHeld(kDPrime));
  EXPECT_EQ(held.analysis.held[kDPrime], Held::kFixed);
  EXPECT_EQ(held.analysis.std(kDPrime), 0.0);
  EXPECT_TRUE(held.Usable());
  ExpectWithinStd(held, free, free.analysis, 1e-3, "d' held at the free fit's value");
  // a is correlated with d' (-0.9): given d' its uncertainty is sqrt(C_aa - C_ad^2 / C_dd).
  const Eigen::MatrixXd& c = free.analysis.covariance;
  const double conditioned = std::sqrt(c(kA, kA) - c(kA, kDPrime) * c(kA, kDPrime) / c(kDPrime, kDPrime));
  const double sigma_ratio = held.analysis.residual_sigma_mm / free.analysis.residual_sigma_mm;
  EXPECT_NEAR(held.analysis.std(kA), conditioned * sigma_ratio, 1e-6 * conditioned);
  EXPECT_LT(held.analysis.std(kA), 0.5 * free.analysis.std(kA));
}

// A sphere almost on the Theta axis does not determine beta and c (nor b and epsilon): with beta
// and c held they are no longer among the undetermined, and the report says they are held.
TEST(FixedParameter, CentredSphereNoLongerRefusedForThem) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(0.01, 0.0, 0.0)};
  const PointsData points = Simulate(spec);
  const CalibrationResult free = Calibrate(points, PaperOptions());
  ASSERT_FALSE(free.analysis.determined[kBeta]);
  ASSERT_FALSE(free.analysis.determined[kC]);
  CalibrationOptions o = PaperOptions();
  o.fixed = {{"beta", std::nullopt}, {"c", std::nullopt}};
  const CalibrationResult held = Calibrate(points, o);
  EXPECT_EQ(held.geometry[kBeta], 0.0);  // where the fit starts
  EXPECT_EQ(held.geometry[kC], 0.0);
  EXPECT_TRUE(held.analysis.determined[kBeta]);
  EXPECT_TRUE(held.analysis.determined[kC]);
  ASSERT_FALSE(held.warnings.empty());
  EXPECT_THAT(held.warnings[0], HasSubstr("undetermined parameters: alpha"));
  EXPECT_THAT(held.warnings[0], ::testing::Not(HasSubstr("beta")));
  EXPECT_THAT(held.warnings[0], ::testing::Not(HasSubstr(", c (")));
}

TEST(FixedParameter, UnknownNamesAndContradictionsAreRefused) {
  const PointsData points = Simulate(SimulationSpec{});
  CalibrationOptions o = PaperOptions();
  o.fixed = {{"d_primo", std::nullopt}};
  EXPECT_THROW(Calibrate(points, o), Error);
  o.fixed = {{"alpha", std::nullopt}};
  o.priors = {{"alpha", 0.0, 1e-6}};
  try {
    Calibrate(points, o);
    ADD_FAILURE() << "a parameter both held and informed";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("alpha is both held and given a prior"));
  }
  o.priors.clear();
  o.fixed = {{"alpha", 100.0 * kRadPerDeg}};
  try {
    Calibrate(points, o);
    ADD_FAILURE() << "alpha held beyond its physical bound";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("alpha starts at 100 deg, outside its bounds (-90 deg to 90 deg)"));
  }
}

// A prior of a tiny uncertainty is a fix; one of a huge uncertainty is no prior at all.
TEST(Prior, TinyUncertaintyIsAFixHugeIsNone) {
  const PointsData points = Simulate(SimulationSpec{});
  const CalibrationResult free = Calibrate(points, PaperOptions());
  const double value = free.geometry[kAlpha] + 3.0 * free.analysis.std(kAlpha);  // 3 std from the data's
  CalibrationOptions fixed = PaperOptions();
  fixed.fixed = {{"alpha", value}};
  const CalibrationResult held = Calibrate(points, fixed);

  CalibrationOptions tiny = PaperOptions();
  tiny.priors = {{"alpha", value, 1e-6 * free.analysis.std(kAlpha)}};
  const CalibrationResult t = Calibrate(points, tiny);
  ASSERT_TRUE(t.converged) << t.solver_message;
  EXPECT_NEAR(t.geometry[kAlpha], value, 1e-5 * free.analysis.std(kAlpha));
  ExpectWithinStd(t, held, held.analysis, 1e-3, "a prior of a tiny uncertainty against the fix");
  EXPECT_NEAR(t.analysis.std(kAlpha), 1e-6 * free.analysis.std(kAlpha), 1e-8 * free.analysis.std(kAlpha));
  for (int p = 0; p < kNumScmsParams; ++p) {
    if (p == kAlpha) continue;
    EXPECT_NEAR(t.analysis.std(p), held.analysis.std(p), 1e-3 * held.analysis.std(p));
  }
  EXPECT_GT(t.prior_sigma_mm, 0.0);

  CalibrationOptions huge = PaperOptions();
  huge.priors = {{"alpha", value, 1e6 * free.analysis.std(kAlpha)}};
  const CalibrationResult h = Calibrate(points, huge);
  ExpectWithinStd(h, free, free.analysis, 1e-3, "a prior of a huge uncertainty against none");
  for (int p = 0; p < kNumScmsParams; ++p) {
    EXPECT_NEAR(h.analysis.std(p), free.analysis.std(p), 1e-3 * free.analysis.std(p));
  }
}

// The budget lists a prior as an input of its own: the fit's Type A part is then what the readings
// contribute, and the combined uncertainty the fit's.
TEST(Prior, IsAnInputOfTheBudget) {
  const PointsData points = Simulate(SimulationSpec{});
  const CalibrationResult free = Calibrate(points, PaperOptions());
  CalibrationOptions o = PaperOptions();
  o.priors = {{"alpha", free.geometry[kAlpha], 0.5 * free.analysis.std(kAlpha)}};
  const CalibrationResult fit = Calibrate(points, o);
  const BudgetRefit refit = [&](const PointsData& p, const CalibrationOptions& q) {
    CalibrationOptions from = q;
    from.initial_geometry = fit.geometry;
    const CalibrationResult r = Calibrate(p, from);
    Eigen::VectorXd v(kNumScmsParams + 3);
    for (int k = 0; k < kNumScmsParams; ++k) v(k) = r.geometry[static_cast<std::size_t>(k)];
    v.tail<3>() = r.centers_mm[0];
    return v;
  };
  const CalibrationBudget b = MakeCalibrationBudget(points, o, fit, CalibrationInputs{}, refit);
  ASSERT_EQ(b.inputs.size(), 4u);
  EXPECT_EQ(b.inputs[3].input, "prior on alpha");
  EXPECT_EQ(b.inputs[3].unit, "urad");
  EXPECT_NEAR(b.inputs[3].u, 0.5 * free.analysis.std(kAlpha) * kUradPerRad, 1e-9);
  const gum::UncertaintyStatement& alpha = b.statements[kAlpha];
  EXPECT_NEAR(alpha.u, fit.analysis.std(kAlpha), 1e-3 * fit.analysis.std(kAlpha));
  EXPECT_LT(alpha.inputs[0].standard_uncertainty, 0.99 * fit.analysis.std(kAlpha));  // the readings' part
  // The prior, half the readings' std, carries 4/5 of the weight: of the combined variance the
  // readings' part is 1/5.
  EXPECT_NEAR(alpha.inputs[0].standard_uncertainty, fit.analysis.std(kAlpha) * std::sqrt(0.2),
              0.05 * fit.analysis.std(kAlpha));
}

// A prior on an effect's parameter, the effect fitted with the seven errors.
TEST(Prior, OnAnEffectParameter) {
  SimulationSpec spec;
  spec.effects.model.terms = {{Effect::kThetaEncoder, {{2, 0, false}}}};
  spec.effects.values = {{6 * kRadPerArcsec}};
  const PointsData points = Simulate(spec);
  EffectModel model = spec.effects.model;
  model.reference = EffectReferenceOf(points.samples);
  const CalibrationResult base = Calibrate(points, PaperOptions());
  const EffectFit free = FitEffects(points, PaperOptions(), model, EffectFitStart::From(base));
  const int c2 = free.TermOffset(0);
  CalibrationOptions o = PaperOptions();
  o.priors = {{"theta_encoder.c2", 6 * kRadPerArcsec, 1e-3 * free.calibration.analysis.std(c2)}};
  const EffectFit informed = FitEffects(points, o, model, EffectFitStart::From(base));
  EXPECT_NEAR(informed.values[0][0], 6 * kRadPerArcsec, 1e-2 * free.calibration.analysis.std(c2));
  EXPECT_LT(informed.calibration.analysis.std(c2), 2e-3 * free.calibration.analysis.std(c2));
}

// A bound the data push against: the parameter ends at it, held there, and the others are the fit
// with it fixed there.
TEST(Bound, AParameterAtItsBoundIsHeldThere) {
  const PointsData points = Simulate(SimulationSpec{});
  const CalibrationResult free = Calibrate(points, PaperOptions());
  const double upper = free.geometry[kAlpha] - 3.0 * free.analysis.std(kAlpha);
  CalibrationOptions bounded = PaperOptions();
  bounded.bounds = {{"alpha", -std::numeric_limits<double>::infinity(), upper}};
  const CalibrationResult b = Calibrate(points, bounded);
  ASSERT_TRUE(b.converged) << b.solver_message;
  EXPECT_EQ(b.geometry[kAlpha], upper);
  EXPECT_EQ(b.analysis.held[kAlpha], Held::kAtUpperBound);
  CalibrationOptions fixed = PaperOptions();
  fixed.fixed = {{"alpha", upper}};
  const CalibrationResult f = Calibrate(points, fixed);
  // Two solves along different paths (Ceres projects the bounded one's steps), each stopped on a
  // relative change of the cost below 1e-6: short of the optimum by up to sqrt(1e-6 (m - n)) =
  // 0.017 standard uncertainties.
  ExpectWithinStd(b, f, f.analysis, 0.05, "at the bound against fixed there");
  // A bound the fit does not reach changes nothing.
  CalibrationOptions loose = PaperOptions();
  loose.bounds = {{"alpha", -1.0, 1.0}};
  const CalibrationResult l = Calibrate(points, loose);
  EXPECT_FALSE(l.analysis.IsHeld(kAlpha));
  ExpectWithinStd(l, free, free.analysis, 1e-3, "a bound not reached");
}

// 2 % of the readings with gross errors of 20 um (400 times the noise), every reading kept: least
// squares is pulled away by more than a standard uncertainty, a robust loss stays within one of
// the clean readings' fit, and names the readings it weighted down.
TEST(RobustLoss, GrossErrorsWeightedDownNotFitted) {
  SimulationSpec spec;
  const PointsData clean = Simulate(spec);
  spec.effects.outlier_fraction = 0.02;
  spec.effects.outlier_um = 20.0;
  const PointsData dirty = Simulate(spec);
  CalibrationOptions o = PaperOptions();
  const CalibrationResult reference = Calibrate(clean, o);
  o.outlier_sigma = 0.0;  // every reading kept
  const CalibrationResult plain = Calibrate(dirty, o);
  double worst = 0.0;
  for (int p = 0; p < kNumScmsParams; ++p) {
    worst = std::max(
        worst, std::abs(plain.geometry[static_cast<std::size_t>(p)] - reference.geometry[static_cast<std::size_t>(p)]) /
                   reference.analysis.std(p));
  }
  EXPECT_GT(worst, 1.0) << "least squares on the gross errors";
  for (const RobustLoss loss : {RobustLoss::kHuber, RobustLoss::kCauchy}) {
    CalibrationOptions robust = o;
    robust.robust_loss = loss;
    const CalibrationResult r = Calibrate(dirty, robust);
    ASSERT_TRUE(r.converged) << r.solver_message;
    ExpectWithinStd(r, reference, reference.analysis, 1.0, loss == RobustLoss::kHuber ? "huber" : "cauchy");
    EXPECT_TRUE(r.outliers.empty());
    EXPECT_EQ(r.n_points, static_cast<int>(dirty.samples.size()));
    EXPECT_NEAR(r.robust_sigma_mm, 0.05e-3, 0.02e-3);  // the noise, 0.05 um
    // Every gross error weighted down to a few percent at most.
    int gross = 0;
    for (std::size_t i = 0; i < dirty.samples.size(); ++i) {
      if (std::abs(dirty.samples[i].r_mm - clean.samples[i].r_mm) < 1e-3) continue;
      ++gross;
      const auto it =
          std::find_if(r.weighted.begin(), r.weighted.end(), [&](const WeightedReading& w) { return w.sample == i; });
      ASSERT_NE(it, r.weighted.end()) << "sample " << i + 1;
      EXPECT_LT(it->weight, 0.05) << "sample " << i + 1;
    }
    EXPECT_GE(gross, 3);
    ASSERT_FALSE(r.warnings.empty());
    EXPECT_THAT(r.warnings.back(), HasSubstr("readings weighted down"));
  }
}

}  // namespace
}  // namespace sph
