#include "sph/calib/error_curves.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "calib_test_util.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"
#include "sph/select/trace.hpp"

namespace sph {
namespace {

using sph::testing::PaperOptions;

// The paper's study (24 x 12 grid, 2 mm eccentricity) with an encoder error of the given
// components [arcsec], traced as sph_calibrate traces it.
struct Traced {
  PointsData points;
  TraceResult trace;
};
Traced TraceEncoder(Effect e, const std::vector<EffectComponent>& components, const std::vector<double>& arcsec,
                    std::uint64_t seed) {
  SimulationSpec spec;
  spec.seed = seed;
  spec.effects.model.terms = {{e, components}};
  std::vector<double> values;
  for (double a : arcsec) values.push_back(a * kRadPerArcsec);
  spec.effects.values = {values};
  Traced t;
  t.points = Simulate(spec);
  t.trace = TraceResidual(t.points, PaperOptions(), Calibrate(t.points, PaperOptions()), TraceOptions{});
  return t;
}

const ErrorCurve* CurveOf(const TraceResult& r, Effect e) {
  const auto it = std::find_if(r.curves.begin(), r.curves.end(), [&](const ErrorCurve& c) { return c.effect == e; });
  return it == r.curves.end() ? nullptr : &*it;
}

// The true curve [arcsec] of components `c` with values `arcsec` at `deg`.
double TrueAt(const std::vector<EffectComponent>& c, const std::vector<double>& arcsec, double deg) {
  double v = 0.0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const double x = c[i].order * deg * kRadPerDeg;
    v += arcsec[i] * (c[i].sine ? std::sin(x) : std::cos(x));
  }
  return v;
}

TEST(ErrorCurves, AThetaEncoderOverAFullTurnIsItsCurveAboutItsMeanWithTheBandOfTheCovariance) {
  const Traced t = TraceEncoder(Effect::kThetaEncoder, {{2, 0, false}, {3, 0, true}}, {6.0, 4.0}, 2);
  const ErrorCurve* c = CurveOf(t.trace, Effect::kThetaEncoder);
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->name, "theta_encoder");
  EXPECT_EQ(c->iso_name, "ECC");
  EXPECT_EQ(c->unit, "arcsec");
  EXPECT_TRUE(c->encoder);
  EXPECT_TRUE(c->full_turn);
  EXPECT_EQ(c->range_lo_deg, 0.0);
  EXPECT_EQ(c->range_hi_deg, 360.0);
  ASSERT_EQ(c->angle_deg.size(), 24u);  // the grid's 24 angles of theta, 0 to 345 deg
  EXPECT_NEAR(c->angle_deg[1], 15.0, 1e-9);
  // The table's values are the curve's, about their mean over the pattern's angles.
  double mean = 0.0;
  for (std::size_t i = 0; i < c->angle_deg.size(); ++i) {
    EXPECT_DOUBLE_EQ(c->value[i], c->ValueAt(c->angle_deg[i]));
    mean += c->value[i] / static_cast<double>(c->angle_deg.size());
  }
  EXPECT_NEAR(mean, 0.0, 1e-9);
  // The band is that of the curve: k sqrt(g^T C g) from the fit's covariance of its components.
  const EffectFit& fit = t.trace.after.fit;
  const int term = fit.model.Find(Effect::kThetaEncoder);
  ASSERT_GE(term, 0);
  const int offset = fit.TermOffset(static_cast<std::size_t>(term));
  const auto n = static_cast<Eigen::Index>(fit.model.terms[static_cast<std::size_t>(term)].components.size());
  const Eigen::MatrixXd cov =
      fit.calibration.analysis.covariance.block(offset, offset, n, n) / (kRadPerArcsec * kRadPerArcsec);
  const Eigen::VectorXd g = c->Basis(45.0);
  EXPECT_NEAR(c->U95At(45.0), c->coverage_factor * std::sqrt(g.dot(cov * g)), 1e-9);
  EXPECT_NEAR(c->coverage_factor, 1.96, 0.02);
  // The range (max - min) is the curve's over the turn.
  const auto [lo, hi] = std::minmax_element(c->value.begin(), c->value.end());
  EXPECT_GE(c->pv, *hi - *lo);
  EXPECT_NEAR(c->ValueAt(c->max_angle_deg) - c->ValueAt(c->min_angle_deg), c->pv, 1e-12);
  EXPECT_GT(c->pv_u95, 0.0);
}

TEST(ErrorCurves, APhiEncoderOverHalfATurnNamesItsRangeAndWhatTheFittedComponentsRepresent) {
  const Traced t = TraceEncoder(Effect::kPhiEncoder, {{1, 0, false}}, {8.0}, 1);
  const ErrorCurve* c = CurveOf(t.trace, Effect::kPhiEncoder);
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->iso_name, "EBB");
  EXPECT_FALSE(c->full_turn);
  EXPECT_NEAR(c->range_lo_deg, 7.5, 1e-9);  // the grid's phi: 7.5, 22.5, ..., 172.5 deg
  EXPECT_NEAR(c->range_hi_deg, 172.5, 1e-9);
  ASSERT_EQ(c->angle_deg.size(), 12u);
  EXPECT_NEAR(c->angle_deg.front(), 7.5, 1e-9);
  // Every component searched is fitted or left out, with its share represented in [0, 1].
  const std::size_t searched = 2 * static_cast<std::size_t>(t.trace.harmonics.phi);
  EXPECT_EQ(c->fitted.size() + c->left_out.size(), searched);
  for (const LeftOutComponent& l : c->left_out) {
    EXPECT_GE(l.represented, 0.0);
    EXPECT_LE(l.represented, 1.0);
  }
}

// The certificate-style check: the true encoder curve lies in the reported 95 % band at about 95 %
// of the table's angles, over seeds (bench/curve_study runs many more).
TEST(ErrorCurves, TheTrueThetaEncoderCurveLiesInTheBandAtAbout95PercentOfTheAngles) {
  const std::vector<EffectComponent> comps = {{2, 0, false}, {3, 0, true}};
  const std::vector<double> arcsec = {6.0, 4.0};
  int runs = 0, inside = 0, total = 0;
  double u95_sum = 0.0, pv_sum = 0.0;
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    const Traced t = TraceEncoder(Effect::kThetaEncoder, comps, arcsec, seed);
    const ErrorCurve* c = CurveOf(t.trace, Effect::kThetaEncoder);
    if (!c) continue;
    ++runs;
    // The truth about its mean over the pattern's angles (the 24 angles of a full turn: mean 0).
    for (std::size_t i = 0; i < c->angle_deg.size(); ++i) {
      inside += std::abs(c->value[i] - TrueAt(comps, arcsec, c->angle_deg[i])) <= c->u95[i];
      ++total;
      u95_sum += c->u95[i];
    }
    pv_sum += c->pv;
  }
  ASSERT_GE(runs, 8) << "the encoder was added in too few runs to judge its band";
  const double fraction = static_cast<double>(inside) / total;
  EXPECT_GE(fraction, 0.85) << inside << " of " << total;
  // A band that says something: far narrower than the curve's range.
  EXPECT_LT(u95_sum / total, 0.25 * pv_sum / runs);
}

}  // namespace
}  // namespace sph
