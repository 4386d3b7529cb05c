#include "sph/calib/budget.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "calib_test_util.hpp"
#include "sph/core/error.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using sph::testing::PaperOptions;
using ::testing::HasSubstr;

constexpr int kDPrime = 6;

Eigen::VectorXd Parameters(const CalibrationResult& r) {
  Eigen::VectorXd v(kNumScmsParams + 3 * static_cast<Eigen::Index>(r.centers_mm.size()));
  for (int p = 0; p < kNumScmsParams; ++p) v(p) = r.geometry[static_cast<std::size_t>(p)];
  for (std::size_t k = 0; k < r.centers_mm.size(); ++k) v.segment<3>(kNumScmsParams + 3 * k) = r.centers_mm[k];
  return v;
}

struct Case {
  PointsData points;
  CalibrationOptions options;
  CalibrationResult result;
  BudgetRefit refit;
};

// The paper's set-up (ray-traced by the simulator, 2 mm eccentricity, sigma_r 0.05 um).
Case PaperCase() {
  Case c;
  SimulationSpec spec;
  c.points = Simulate(spec);
  c.options = PaperOptions();
  c.result = Calibrate(c.points, c.options);
  c.refit = [](const PointsData& p, const CalibrationOptions& o) { return Parameters(Calibrate(p, o)); };
  return c;
}

TEST(CalibrationBudget, RadiusSensitivityIsTheLinearisationOfTheFit) {
  const Case c = PaperCase();
  ASSERT_TRUE(c.result.Usable());
  CalibrationInputs in;
  in.sphere_radius_u_um = 0.1;
  const CalibrationBudget b =
      MakeCalibrationBudget(c.points, c.options, c.result.analysis, c.result.n_points, in, c.refit);
  // A change dR0 of the radius changes every residual by -dR0; the least-squares parameters move by
  // (J^T J)^-1 J^T 1 dR0 (J from ResidualJacobian, independent of the refits).
  const Eigen::MatrixXd j = ResidualJacobian(c.points, c.options, c.result.geometry, c.result.centers_mm);
  const Eigen::VectorXd linear =
      (j.transpose() * j).ldlt().solve(j.transpose() * Eigen::VectorXd::Ones(j.rows())) / kUmPerMm;
  ASSERT_EQ(b.inputs[0].per_unit.size(), linear.size());
  // The refits converge to about 1e-11 mm in the weakest direction (beta R0 + c); over the step of
  // the central difference that is 1e-6 of the largest sensitivity, d'`s.
  for (Eigen::Index i = 0; i < linear.size(); ++i) {
    EXPECT_NEAR(b.inputs[0].per_unit(i), linear(i), 1e-5 * linear.cwiseAbs().maxCoeff()) << "parameter " << i;
  }
  // d' takes an error of R0 almost one for one (the probe line is nearly normal to the surface at
  // 2 mm eccentricity; the centre and a take a little of it).
  const double s = std::abs(b.inputs[0].per_unit(kDPrime) * kUmPerMm);
  EXPECT_GE(s, 1.0);
  EXPECT_LE(s, 1.01);
}

TEST(CalibrationBudget, CombinesTypeAAndTypeBAsTheGumDoes) {
  const Case c = PaperCase();
  CalibrationInputs in;
  in.sphere_radius_u_um = 0.1;
  in.sphere_temperature_c = 20.5;
  in.sphere_temperature_u_c = 0.2;
  in.sphere_cte_per_k = 11.5e-6;
  in.probe_scale_u = 2e-5;
  const CalibrationBudget b =
      MakeCalibrationBudget(c.points, c.options, c.result.analysis, c.result.n_points, in, c.refit);
  ASSERT_EQ(b.inputs.size(), 3u);
  EXPECT_DOUBLE_EQ(b.type_a_dof, 288.0 - 10.0);
  // Temperature acts through R0: s_T = s_R0 R0 cte (R0 at 20 deg C).
  const double r0_20 = c.options.sphere_radius_mm / (1.0 + 11.5e-6 * 0.5);
  EXPECT_NEAR(b.inputs[1].per_unit(kDPrime), b.inputs[0].per_unit(kDPrime) * kUmPerMm * r0_20 * 11.5e-6, 1e-15);
  for (std::size_t i = 0; i < b.statements.size(); ++i) {
    const gum::UncertaintyStatement& st = b.statements[i];
    ASSERT_EQ(st.inputs.size(), 4u);
    double sum2 =
        c.result.analysis.std(static_cast<Eigen::Index>(i)) * c.result.analysis.std(static_cast<Eigen::Index>(i));
    sum2 += std::pow(b.inputs[0].per_unit(static_cast<Eigen::Index>(i)) * 0.1, 2);
    sum2 += std::pow(b.inputs[1].per_unit(static_cast<Eigen::Index>(i)) * 0.2, 2);
    sum2 += std::pow(b.inputs[2].per_unit(static_cast<Eigen::Index>(i)) * 2e-5, 2);
    EXPECT_NEAR(st.u, std::sqrt(sum2), 1e-12 * std::sqrt(sum2));
    EXPECT_DOUBLE_EQ(st.k, 2.0);
    EXPECT_DOUBLE_EQ(st.U, 2.0 * st.u);
    // The combined covariance has the same variances.
    EXPECT_NEAR(b.covariance(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)), sum2, 1e-9 * sum2);
  }
  // d': R0's 0.1 um and the probe scale dominate, the fit's 0.007 um does not.
  EXPECT_GT(b.statements[kDPrime].u * kUmPerMm, 0.1);
}

TEST(CalibrationBudget, ProbeScaleActsOnDPrimeLikeTheMeanReading) {
  // Hand-worked: with the sphere near the axes' common point every reading is close to the mean
  // r = d - R0 - d' (5.06 mm), so a scale error kappa shifts the points as a change of d' by
  // about kappa r does.
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(0.5, 0.0, 0.0)};
  const PointsData points = Simulate(spec);
  const CalibrationOptions options = PaperOptions();
  const CalibrationResult r = Calibrate(points, options);
  ASSERT_TRUE(r.converged);
  double mean_r = 0.0;
  for (const Sample& s : points.samples) mean_r += s.r_mm / static_cast<double>(points.samples.size());
  CalibrationInputs in;
  in.probe_scale_u = 1e-4;
  const CalibrationBudget b = MakeCalibrationBudget(
      points, options, r.analysis, r.n_points, in,
      [](const PointsData& p, const CalibrationOptions& o) { return Parameters(Calibrate(p, o)); });
  EXPECT_NEAR(std::abs(b.inputs[2].per_unit(kDPrime)), mean_r, 0.02 * mean_r);
}

TEST(CalibrationBudget, CoverageProbabilityUsesTheEffectiveDegreesOfFreedom) {
  const Case c = PaperCase();
  CalibrationInputs in;
  in.coverage.probability = 0.95;
  const CalibrationBudget b =
      MakeCalibrationBudget(c.points, c.options, c.result.analysis, c.result.n_points, in, c.refit);
  // Type A alone: nu_eff = m - n = 278, k = t_0.975(278).
  const gum::UncertaintyStatement& st = b.statements[0];
  EXPECT_DOUBLE_EQ(st.dof, 278.0);
  EXPECT_NEAR(st.k, gum::CoverageFactor(0.95, 278.0), 1e-12);
  EXPECT_NEAR(st.k, 1.9686, 1e-3);  // t table
}

TEST(CalibrationBudget, ACertificateUncertaintyOfR0RulesDPrimeAndLeavesTypeAAlone) {
  const Case c = PaperCase();
  CalibrationInputs in;
  in.sphere_radius_u_um = 0.2;
  const CalibrationBudget b =
      MakeCalibrationBudget(c.points, c.options, c.result.analysis, c.result.n_points, in, c.refit);
  const gum::UncertaintyStatement& d = b.statements[kDPrime];
  EXPECT_GE(d.u * kUmPerMm, 0.2);
  ASSERT_EQ(d.Largest(), 1);
  EXPECT_EQ(d.inputs[1].name, "R0 (certificate)");
  // The Type A input is the fit's std, as it was.
  EXPECT_DOUBLE_EQ(d.inputs[0].standard_uncertainty, c.result.analysis.std(kDPrime));
}

TEST(CalibrationBudget, NinetyFivePercentIntervalsCoverTheTruth) {
  // 500 calibrations of independently simulated (ray-traced) readings: each determined
  // parameter's 95 % interval (Type A only: the simulation has no Type B error) holds the truth
  // about 95 % of the time (binomial: 93.1 % to 96.9 % hold 99 % of such runs).
  SimulationSpec spec;  // the paper's set-up, 2 mm, sigma_r 0.05 um
  const CalibrationOptions options = PaperOptions();
  CalibrationInputs in;
  in.coverage.probability = 0.95;
  constexpr int kRuns = 500;
  std::array<int, kNumScmsParams> covered{}, determined{};
  for (int run = 0; run < kRuns; ++run) {
    spec.seed = 1000 + static_cast<std::uint64_t>(run);
    const PointsData points = Simulate(spec);
    const CalibrationResult r = Calibrate(points, options);
    ASSERT_TRUE(r.converged);
    for (int p = 0; p < kNumScmsParams; ++p) {
      const auto q = static_cast<std::size_t>(p);
      if (!r.analysis.determined[q]) continue;
      // Type A only: U = k std with k = t_0.975(m - n), what the budget gives without Type B inputs.
      const double k = gum::CoverageFactor(0.95, static_cast<double>(r.n_points - 10));
      ++determined[q];
      if (std::abs(r.geometry[q] - spec.truth[q]) <= k * r.analysis.std(p)) ++covered[q];
    }
  }
  for (int p = 0; p < kNumScmsParams; ++p) {
    const auto q = static_cast<std::size_t>(p);
    ASSERT_EQ(determined[q], kRuns) << kScmsParamInfo[q].name;
    const double rate = static_cast<double>(covered[q]) / kRuns;
    EXPECT_GE(rate, 0.93) << kScmsParamInfo[q].name;
    EXPECT_LE(rate, 0.97) << kScmsParamInfo[q].name;
  }
}

TEST(CalibrationInputs, RadiusAtTemperature) {
  CalibrationInputs in;
  EXPECT_DOUBLE_EQ(in.RadiusAtTemperatureMm(20.0), 20.0);  // no coefficient: no correction
  in.sphere_cte_per_k = 11.5e-6;
  in.sphere_temperature_c = 21.0;
  EXPECT_NEAR(in.RadiusAtTemperatureMm(20.0) - 20.0, 0.23e-3, 1e-12);  // 0.23 um per kelvin at 20 mm
}

TEST(CalibrationInputs, HeaderFieldsAreReadAndChecked) {
  std::istringstream ok(
      "# sphere_radius_mm: 20\n# probe_offset_mm: 25\n# sphere_radius_u_um: 0.05\n"
      "# sphere_temperature_c: 20.4\n0 90 5\n");
  const SphereConditions c = ConditionsOf(ParsePoints(ok, "p.txt").header);
  ASSERT_TRUE(c.sphere_radius_u_um && c.sphere_temperature_c);
  EXPECT_DOUBLE_EQ(*c.sphere_radius_u_um, 0.05);
  EXPECT_DOUBLE_EQ(*c.sphere_temperature_c, 20.4);
  EXPECT_FALSE(c.probe_scale_u);
  const CalibrationInputs in = CalibrationInputs().With(c);
  EXPECT_DOUBLE_EQ(in.sphere_radius_u_um, 0.05);
  EXPECT_DOUBLE_EQ(in.probe_scale_u, 0.0);

  std::istringstream negative("# sphere_radius_mm: 20\n# sphere_radius_u_um: -1\n0 90 5\n");
  EXPECT_THAT([&] { ParsePoints(negative, "p.txt"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("p.txt:2: sphere_radius_u_um must be within [0, 1000] um")));
  std::istringstream text("# sphere_cte_per_k: steel\n0 90 5\n");
  EXPECT_THAT([&] { ParsePoints(text, "p.txt"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("p.txt:1: sphere_cte_per_k: 'steel' is not a number")));
}

}  // namespace
}  // namespace sph
