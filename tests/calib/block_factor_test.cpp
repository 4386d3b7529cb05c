// The analysis of a fit of many setups through the block structure of its Jacobian
// (src/calib/block_factor.hpp) against the dense analysis of all its columns.
#include "block_factor.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "calib/calib_test_util.hpp"
#include "effect_fit_rows.hpp"
#include "fit_problem.hpp"
#include "sph/calib/effect_fit.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"
#include "sph/select/residual_structure.hpp"
#include "structure_jacobian.hpp"

namespace sph {
namespace {

// `setups` placements of the 4 x 3 grid (12 readings each) at 2 mm eccentricity turned about the
// Theta axis and at heights between -1.2 and 1.2 mm; with `on_axis` every centre on the Theta axis.
SimulationSpec ManySetups(int setups, bool on_axis, const SimulatedEffects& effects = {}) {
  SimulationSpec spec;
  spec.pattern = GridPattern(4, 3);
  spec.effects = effects;
  spec.centers_mm.clear();
  for (int k = 0; k < setups; ++k) {
    const double a = 7.0 * 2.0 * kPi * k / setups;
    const double e = on_axis ? 0.0 : 2.0;
    spec.centers_mm.emplace_back(e * std::cos(a), e * std::sin(a), 0.3 * (k % 9 - 4));
  }
  return spec;
}

struct Inverses {
  NormalInverse dense, blocks;
};

// Both analyses of the Jacobian of `model` at the truth of `spec` (any point of the parameter space
// serves to compare two analyses of one Jacobian; this one is near the solution).
Inverses BothAt(const SimulationSpec& spec, const EffectModel& model) {
  const PointsData points = Simulate(spec);
  const internal::ReadingTable table(points);
  const internal::SphereFitProblem problem(table, internal::AllRows(table), model, sph::testing::PaperOptions());
  const Eigen::VectorXd x = problem.Pack(spec.truth, spec.centers_mm, spec.effects.values);
  const auto rows = static_cast<Eigen::Index>(problem.NumRows());
  return {InvertNormalFactor(problem.FactorJacobian(x.data()).r(), rows), problem.FactorBlocks(x.data()).Invert()};
}

// The largest |a - b| relative to the largest |a| over the entries both have (NaN where null).
double RelativeDifference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  double worst = 0.0, size = 0.0;
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    for (Eigen::Index j = 0; j < a.cols(); ++j) {
      if (std::isnan(a(i, j)) != std::isnan(b(i, j))) return std::numeric_limits<double>::infinity();
      if (std::isnan(a(i, j))) continue;
      worst = std::max(worst, std::abs(a(i, j) - b(i, j)));
      size = std::max(size, std::abs(a(i, j)));
    }
  }
  return worst / size;
}

// The weakest direction of each, the same up to its sign.
double WeakestDirectionDifference(const NormalInverse& a, const NormalInverse& b) {
  const Eigen::VectorXd va = a.v.col(a.v.cols() - 1), vb = b.v.col(b.v.cols() - 1);
  return std::min((va - vb).cwiseAbs().maxCoeff(), (va + vb).cwiseAbs().maxCoeff());
}

TEST(BlockFactor, InvertsAsTheDenseAnalysisWithTwentySetups) {
  const Inverses r = BothAt(ManySetups(20, false), EffectModel{});
  EXPECT_EQ(r.blocks.in_null, r.dense.in_null);
  EXPECT_LE(RelativeDifference(r.dense.inverse, r.blocks.inverse), 1e-9);
  EXPECT_NEAR(r.blocks.condition_number, r.dense.condition_number, 1e-8 * r.dense.condition_number);
  EXPECT_NEAR(r.blocks.singular_values(0), r.dense.singular_values(0), 1e-10 * r.dense.singular_values(0));
  // The weakest singular values: the block analysis lists the largest, then the weakest ones.
  const Eigen::Index nb = r.blocks.singular_values.size(), nd = r.dense.singular_values.size();
  ASSERT_GE(nb, 3);
  for (Eigen::Index i = 1; i <= 3; ++i) {
    EXPECT_NEAR(r.blocks.singular_values(nb - i), r.dense.singular_values(nd - i), 1e-9 * r.dense.singular_values(0))
        << "the " << i << "-th weakest";
  }
  EXPECT_LE(WeakestDirectionDifference(r.dense, r.blocks), 1e-8);
}

TEST(BlockFactor, InvertsAsTheDenseAnalysisWithEffects) {
  SimulatedEffects effects;
  effects.model.terms = {{Effect::kThetaEncoder, {{2, 0, false}, {3, 0, true}}},
                         {Effect::kProbeDrift, {{1, 0, false}}}};
  effects.values = {{6 * kRadPerArcsec, -4 * kRadPerArcsec}, {0.6 * kMmPerUm}};
  const SimulationSpec spec = ManySetups(24, false, effects);
  EffectModel model = effects.model;
  model.reference = EffectReferenceOf(Simulate(spec).samples);
  const Inverses r = BothAt(spec, model);
  EXPECT_EQ(r.blocks.in_null, r.dense.in_null);
  EXPECT_LE(RelativeDifference(r.dense.inverse, r.blocks.inverse), 1e-9);
  EXPECT_NEAR(r.blocks.condition_number, r.dense.condition_number, 1e-8 * r.dense.condition_number);
}

// A Theta encoder error of 4 per turn on 4 theta positions: sin 4 theta is zero there (a zero
// column) and cos 4 theta one, a constant turn that every centre takes up (a null direction
// through all the centres): both analyses find the same parameters in the null space.
TEST(BlockFactor, FindsTheNullSpaceOfTheDenseAnalysis) {
  SimulationSpec spec = ManySetups(20, false);
  spec.effects.model.terms = {{Effect::kThetaEncoder, {{4, 0, false}, {4, 0, true}}}};
  spec.effects.values = {{0.0, 0.0}};
  const Inverses r = BothAt(spec, spec.effects.model);
  int in_null = 0;
  for (const bool b : r.dense.in_null) in_null += b ? 1 : 0;
  ASSERT_GT(in_null, 2);  // the two encoder terms and centres
  EXPECT_EQ(r.blocks.in_null, r.dense.in_null);
  EXPECT_LE(RelativeDifference(r.dense.inverse, r.blocks.inverse), 1e-8);
  EXPECT_GT(r.blocks.condition_number, 1e12);
}

// The residual structure analysis eliminates each setup's centre from its rows when there are many
// setups (StructureFactor::eliminated): the same tests and figures as the factor of all columns.
TEST(BlockFactor, ResidualStructureAsWithEveryColumn) {
  SimulatedEffects effects;
  effects.model.terms = {{Effect::kProbeDrift, {{1, 0, false}}}};
  effects.values = {{0.2 * kMmPerUm}};
  SimulationSpec spec = ManySetups(20, false, effects);
  spec.pattern = GridPattern(24, 3);  // every theta harmonic the analysis tests is a function of its own
  const PointsData points = Simulate(spec);
  const CalibrationOptions options = sph::testing::PaperOptions();
  CalibrationOptions plain = options;
  plain.outlier_sigma = 0.0;
  EffectFit fit;
  fit.calibration = Calibrate(points, plain);
  fit.model.reference = EffectReferenceOf(points.samples);
  std::vector<Eigen::Vector3d> directions = OffsetsFromCentre(points, options, fit);
  for (Eigen::Vector3d& d : directions) d.normalize();
  const internal::ReadingTable table(points);
  std::vector<double> r_mm;  // both at the measured readings
  for (const Sample& s : points.samples) r_mm.push_back(s.r_mm);
  const internal::StructureJacobian grouped(table, options, fit, r_mm);
  const Eigen::MatrixXd jacobian = JacobianAt(points, options, fit);
  const DenseJacobianBlocks dense(jacobian);
  const std::vector<double>& e = fit.calibration.residuals_mm;
  const StructureFactor by_setup = FactorResidualStructure({points, e, r_mm, grouped, fit.model.reference, directions});
  const StructureFactor all = FactorResidualStructure({points, e, r_mm, dense, fit.model.reference, directions});
  ASSERT_EQ(by_setup.eliminated, 3 * 20);
  ASSERT_EQ(all.eliminated, 0);
  const ResidualStructure a = AnalyseResidualStructure(by_setup), b = AnalyseResidualStructure(all);
  ASSERT_EQ(a.groups.size(), b.groups.size());
  auto same = [](const StructureGroup& x, const StructureGroup& y) {
    EXPECT_EQ(x.rank, y.rank) << x.variable;
    EXPECT_NEAR(x.f, y.f, 1e-5 * y.f) << x.variable;
    EXPECT_NEAR(x.explained_rms_um, y.explained_rms_um, 1e-6 * y.explained_rms_um) << x.variable;
    EXPECT_NEAR(x.delta_bic, y.delta_bic, 1e-3) << x.variable;
    EXPECT_EQ(x.strongest, y.strongest) << x.variable;
  };
  for (std::size_t g = 0; g < a.groups.size(); ++g) same(a.groups[g], b.groups[g]);
  same(a.all, b.all);
  EXPECT_LT(b.groups[3].p_value, 1e-100);  // the drift shows, in t
  for (std::size_t k = 0; k < b.theta_harmonics_um.size(); ++k) {
    EXPECT_NEAR(a.theta_harmonics_um[k], b.theta_harmonics_um[k], 1e-6 * b.theta_harmonics_um[k]) << k + 1;
  }
  const SpherePattern pa = BestSpherePattern(by_setup), pb = BestSpherePattern(all);
  EXPECT_EQ(pa.functions, pb.functions);
  EXPECT_NEAR(pa.delta_bic, pb.delta_bic, 1e-3);
  EXPECT_NEAR(DeltaBicBeyondSphere(by_setup, "t", {0}), DeltaBicBeyondSphere(all, "t", {0}), 1e-3);
}

}  // namespace
}  // namespace sph
