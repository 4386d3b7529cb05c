#include "sph/ceres/sphere_residual.hpp"
#include "sph/ceres/sphere_residual_batch.hpp"

#include <random>

#include <ceres/ceres.h>
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include "calib/calib_test_util.hpp"
#include "ceres_fit.hpp"
#include "fit_problem.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/calib/effect_fit.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/model/effects.hpp"
#include "sph/sphere/sphere_fit.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using sph::testing::MatrixNear;
using Jet10 = ceres::Jet<double, kNumScmsParams + 3>;

constexpr double kD = 25.0;
constexpr double kR0 = 20.0;

ScmsGeometry SomeGeometry() { return {3e-4, 2e-3, -4e-4, 1e-3, 5e-4, -2e-3, -0.062}; }

// The dual-number SinCosOf() of sph/model/dh.hpp with ceres::Jet itself.
TEST(JetSinCos, EqualsCeresSinAndCos) {
  Jet10 x(0.7, 3);
  x.v(5) = -2.0;
  const SinCos<Jet10> t = SinCosOf(x);
  const Jet10 s = ceres::sin(x), c = ceres::cos(x);
  EXPECT_EQ(t.sin.a, s.a);
  EXPECT_EQ(t.cos.a, c.a);
  EXPECT_PRED_FORMAT3(MatrixNear, t.sin.v, s.v, 0.0);
  EXPECT_PRED_FORMAT3(MatrixNear, t.cos.v, c.v, 0.0);
}

TEST(ScmsPointJet, ValuePartEqualsTheDoubleResult) {
  const ScmsGeometry g = SomeGeometry();
  std::array<Jet10, kNumScmsParams> gj;
  for (int i = 0; i < kNumScmsParams; ++i) gj[static_cast<std::size_t>(i)] = Jet10(g[static_cast<std::size_t>(i)], i);
  for (double theta : {0.0, 0.9, 3.5}) {
    for (double phi : {0.2, 1.6, 2.9}) {
      const Vec3<Jet10> pj = ScmsPoint(gj.data(), Jet10(theta), Jet10(phi), Jet10(5.0), Jet10(kD));
      const Eigen::Vector3d pd = ScmsPoint(g, theta, phi, 5.0, kD);
      for (int k = 0; k < 3; ++k) EXPECT_EQ(pj[k].a, pd[k]);
      const Vec3<Jet10> pm = ScmsPointDh(gj.data(), Jet10(theta), Jet10(phi), Jet10(5.0), Jet10(kD));
      for (int k = 0; k < 3; ++k) EXPECT_PRED_FORMAT3(MatrixNear, pj[k].v, pm[k].v, 1e-12);
    }
  }
}

// Every effect of the library at once, instantiated with Jets: the value part is the double result.
TEST(EffectScmsPointJet, ValuePartEqualsTheDoubleResult) {
  using Jet = ceres::Jet<double, 4>;
  EffectModel model;
  std::vector<std::vector<double>> values;
  for (int e = 0; e < kNumEffects; ++e) {
    model.terms.push_back(DefaultTerm(static_cast<Effect>(e), 2, 2));
    std::vector<double> v;
    for (int i = 0; i < model.terms.back().size(); ++i) v.push_back(1e-5 * (i + 1) * (e % 2 ? -1 : 1));
    values.push_back(v);
  }
  model.reference = {5.0, 2.0, 0.0, 100.0};
  const ScmsGeometry g = SomeGeometry();
  std::array<Jet, kNumScmsParams> gj;
  for (int i = 0; i < kNumScmsParams; ++i) gj[static_cast<std::size_t>(i)] = Jet(g[static_cast<std::size_t>(i)], i % 4);
  std::vector<std::vector<Jet>> vj;
  std::vector<const Jet*> blocks;
  for (const auto& v : values) vj.emplace_back(v.begin(), v.end());
  for (const auto& v : vj) blocks.push_back(v.data());
  for (double theta : {0.0, 50.0, 200.0}) {
    for (double phi : {10.0, 90.0, 170.0}) {
      const EffectReading x({theta, phi, 5.3}, 40.0, {theta > 100.0 ? -1 : 1, phi > 50.0 ? 1 : -1});
      const Vec3<Jet> pj = EffectScmsPoint(gj.data(), ErrorTrigOf(gj.data()), model, blocks.data(), x, kD);
      const Eigen::Vector3d pd = EffectScmsPoint(g, model, values, x, kD);
      for (int k = 0; k < 3; ++k) EXPECT_EQ(pj[k].a, pd[k]);
      // The precomputed basis gives the same point.
      const std::vector<double> basis = EffectBasisOf(model, x);
      const Vec3<Jet> pb =
          EffectScmsPoint(gj.data(), ErrorTrigOf(gj.data()), model, blocks.data(), x, kD, basis.data());
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(pb[k].a, pj[k].a);
        EXPECT_PRED_FORMAT3(MatrixNear, pb[k].v, pj[k].v, 0.0);
      }
    }
  }
}

// Central differences of the residual in double against the autodiff Jacobian of the cost function.
TEST(SphereResidual, AutodiffJacobianEqualsCentralDifferences) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> angle(0.0, 6.2), polar(0.1, 3.0);
  ScmsGeometry g = SomeGeometry();
  std::array<double, 3> center{2.0, -0.3, 0.4};
  for (int trial = 0; trial < 20; ++trial) {
    const double theta = angle(rng), phi = polar(rng), r = 4.9;
    std::unique_ptr<ceres::CostFunction> cost(SphereResidual::Create(theta, phi, r, kD, kR0));
    const double* params[] = {g.data(), center.data()};
    double residual = 0.0;
    Eigen::Matrix<double, 1, kNumScmsParams, Eigen::RowMajor> j_g;
    Eigen::Matrix<double, 1, 3, Eigen::RowMajor> j_c;
    double* jacobians[] = {j_g.data(), j_c.data()};
    ASSERT_TRUE(cost->Evaluate(params, &residual, jacobians));

    const SphereResidual functor(theta, phi, r, kD, kR0);
    auto eval = [&](const ScmsGeometry& gg, const std::array<double, 3>& cc) {
      double e = 0.0;
      functor(gg.data(), cc.data(), &e);
      return e;
    };
    EXPECT_EQ(residual, eval(g, center));
    // Step sizes: angles 1e-6 rad, lengths 1e-5 mm; truncation error ~h^2 * |f'''| < 1e-9.
    for (int i = 0; i < kNumScmsParams; ++i) {
      const double h = kScmsParamInfo[static_cast<std::size_t>(i)].quantity == Quantity::kAngle ? 1e-6 : 1e-5;
      ScmsGeometry gp = g, gm = g;
      gp[static_cast<std::size_t>(i)] += h;
      gm[static_cast<std::size_t>(i)] -= h;
      const double numeric = (eval(gp, center) - eval(gm, center)) / (2 * h);
      EXPECT_NEAR(j_g(i), numeric, 1e-7 * std::max(1.0, std::abs(numeric))) << "parameter " << i;
    }
    for (int i = 0; i < 3; ++i) {
      const double h = 1e-5;
      auto cp = center, cm = center;
      cp[static_cast<std::size_t>(i)] += h;
      cm[static_cast<std::size_t>(i)] -= h;
      EXPECT_NEAR(j_c(i), (eval(g, cp) - eval(g, cm)) / (2 * h), 1e-8) << "centre " << i;
    }
  }
}

// The batch must give what the per-reading AutoDiffCostFunctions give, to the last bit of the
// value and to rounding in the derivatives (same operations, but the shared angle-error trig).
TEST(SphereResidualBatch, EqualsThePerReadingCostFunctions) {
  ScmsGeometry g = SomeGeometry();
  std::array<double, 3> center{1.0, 0.5, -0.2};
  std::vector<SphereResidual> functors;
  std::vector<std::unique_ptr<ceres::CostFunction>> singles;
  for (const AnglePair& a : GridPattern(6, 5)) {
    functors.emplace_back(a.theta_deg * kRadPerDeg, a.phi_deg * kRadPerDeg, 5.1, kD, kR0);
    singles.emplace_back(SphereResidual::Create(a.theta_deg * kRadPerDeg, a.phi_deg * kRadPerDeg, 5.1, kD, kR0));
  }
  const SphereResidualBatch batch(functors);
  ASSERT_EQ(batch.num_residuals(), 30);
  const double* params[] = {g.data(), center.data()};
  std::vector<double> res(30), jg(30 * kNumScmsParams), jc(30 * 3);
  double* jac[] = {jg.data(), jc.data()};
  ASSERT_TRUE(batch.Evaluate(params, res.data(), jac));
  std::vector<double> res_only(30);
  ASSERT_TRUE(batch.Evaluate(params, res_only.data(), nullptr));
  for (int i = 0; i < 30; ++i) {
    double e = 0.0, sg[kNumScmsParams], sc[3];
    double* sj[] = {sg, sc};
    ASSERT_TRUE(singles[static_cast<std::size_t>(i)]->Evaluate(params, &e, sj));
    EXPECT_EQ(res[static_cast<std::size_t>(i)], e);
    EXPECT_EQ(res_only[static_cast<std::size_t>(i)], e);
    for (int k = 0; k < kNumScmsParams; ++k)
      EXPECT_NEAR(jg[static_cast<std::size_t>(i * kNumScmsParams + k)], sg[k], 1e-14);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(jc[static_cast<std::size_t>(i * 3 + k)], sc[k], 1e-15);
  }
  // A block held constant: Ceres passes a null Jacobian for it.
  double* only_centre[] = {nullptr, jc.data()};
  ASSERT_TRUE(batch.Evaluate(params, res.data(), only_centre));
}

// The simulator intersects the probe ray with the sphere by its own geometry code; the functor
// must see exactly zero residual on its readings.
TEST(SphereResidual, ZeroOnRayTracedReadings) {
  const ScmsGeometry g = SomeGeometry();
  const Eigen::Vector3d c(1.5, -0.7, 0.9);
  for (const AnglePair& a : GridPattern(8, 6)) {
    const double theta = a.theta_deg * kRadPerDeg, phi = a.phi_deg * kRadPerDeg;
    const auto r = ProbeReading(g, theta, phi, kD, c, kR0);
    ASSERT_TRUE(r.has_value());
    const SphereResidual functor(theta, phi, *r, kD, kR0);
    double e = 1.0;
    functor(g.data(), c.data(), &e);
    EXPECT_NEAR(e, 0.0, 1e-12);
  }
}

// The calibration's Jacobian is derived by hand (sph/model/residual_gradient.hpp); it must be
// the automatic differentiation of the per-reading functors, row by row.
TEST(ResidualJacobian, EqualsTheAutodiffJacobianOfThePerReadingFunctors) {
  SimulationSpec spec;
  spec.truth = SomeGeometry();
  spec.centers_mm = {Eigen::Vector3d(2.0, 0.0, 0.0), Eigen::Vector3d(0.0, -1.5, 0.5)};
  const PointsData points = Simulate(spec);
  const std::vector<Eigen::Vector3d> centers{{2.001, 0.002, -0.001}, {0.0, -1.499, 0.503}};
  const Eigen::MatrixXd jac = ResidualJacobian(points, sph::testing::PaperOptions(), spec.truth, centers);
  ASSERT_EQ(jac.rows(), static_cast<Eigen::Index>(points.samples.size()));
  ASSERT_EQ(jac.cols(), kNumScmsParams + 6);
  double worst = 0.0;
  for (std::size_t i = 0; i < points.samples.size(); ++i) {
    const Sample& s = points.samples[i];
    std::unique_ptr<ceres::CostFunction> cost(
        SphereResidual::Create(s.theta_deg * kRadPerDeg, s.phi_deg * kRadPerDeg, s.r_mm, kD, kR0));
    const std::size_t k = static_cast<std::size_t>(s.setup);
    const double* params[] = {spec.truth.data(), centers[k].data()};
    double e = 0.0, jg[kNumScmsParams], jc[3];
    double* jacobians[] = {jg, jc};
    ASSERT_TRUE(cost->Evaluate(params, &e, jacobians));
    const auto row = static_cast<Eigen::Index>(i);
    for (int j = 0; j < kNumScmsParams; ++j) worst = std::max(worst, std::abs(jac(row, j) - jg[j]));
    for (int j = 0; j < 3; ++j) {
      worst = std::max(worst, std::abs(jac(row, kNumScmsParams + 3 * static_cast<Eigen::Index>(k) + j) - jc[j]));
      EXPECT_EQ(jac(row, kNumScmsParams + 3 * static_cast<Eigen::Index>(1 - k) + j), 0.0);
    }
  }
  EXPECT_LE(worst, 1e-13);  // the derivatives are O(1) to O(20) (mm per rad)
}

// The reference for the effects: EffectScmsPoint() differentiated by Ceres, one reading at a time.
struct EffectReadingResidual {
  const EffectModel* model;
  EffectReading reading;
  template <typename T>
  bool operator()(T const* const* params, T* residual) const {
    using std::sqrt;
    const T* g = params[0];
    const T* c = params[1];
    const Vec3<T> p = EffectScmsPoint(g, ErrorTrigOf(g), *model, params + 2, reading, kD, nullptr, c);
    const T dx = p[0] - c[0], dy = p[1] - c[1], dz = p[2] - c[2];
    residual[0] = sqrt(dx * dx + dy * dy + dz * dz) - T(kR0);
    return true;
  }
};

TEST(JacobianAt, EqualsTheAutodiffJacobianWithEveryEffect) {
  SimulationSpec spec;
  spec.pattern = GridPattern(12, 6);
  spec.scan_order = ScanOrder::kShuffled;  // both axes move both ways: the reversal terms count
  const PointsData points = Simulate(spec);
  const std::vector<MotionDirection> approach = MotionDirections(points.samples);
  EffectFit fit;
  for (int e = 0; e < kNumEffects; ++e) {
    fit.model.terms.push_back(DefaultTerm(static_cast<Effect>(e), 2, 2));
    std::vector<double> v;
    for (int i = 0; i < fit.model.terms.back().size(); ++i) v.push_back(2e-5 * (i + 1) * (e % 2 ? -1 : 1));
    fit.values.push_back(v);
  }
  fit.model.reference = EffectReferenceOf(points.samples);
  fit.model.phi_wobble_pivot_mm = 60.0;
  // An incidence error of a real size (50 um at 90 deg, 0.5 um at the eccentricity's 6 deg), so that
  // its chain through the beam and the normal counts.
  fit.values[static_cast<std::size_t>(fit.model.Find(Effect::kProbeIncidence))] = {50e-3};
  fit.calibration.geometry = SomeGeometry();
  fit.calibration.setup_ids = {0};
  fit.calibration.centers_mm = {Eigen::Vector3d(2.0, 0.01, -0.02)};
  const Eigen::MatrixXd jac = JacobianAt(points, sph::testing::PaperOptions(), fit);
  const int n = kNumScmsParams + 3 + fit.model.NumParams();
  ASSERT_EQ(jac.cols(), n);
  std::vector<const double*> blocks{fit.calibration.geometry.data(), fit.calibration.centers_mm[0].data()};
  for (const auto& v : fit.values) blocks.push_back(v.data());
  double worst = 0.0;
  for (std::size_t i = 0; i < points.samples.size(); ++i) {
    const Sample& s = points.samples[i];
    ceres::DynamicAutoDiffCostFunction<EffectReadingResidual, 8> cost(
        new EffectReadingResidual{&fit.model, EffectReading(s, s.t_s, approach[i])});
    cost.AddParameterBlock(kNumScmsParams);
    cost.AddParameterBlock(3);
    for (const auto& v : fit.values) cost.AddParameterBlock(static_cast<int>(v.size()));
    cost.SetNumResiduals(1);
    std::vector<std::vector<double>> jb;
    std::vector<double*> jp;
    for (int size : cost.parameter_block_sizes()) jb.emplace_back(static_cast<std::size_t>(size));
    for (auto& b : jb) jp.push_back(b.data());
    double e = 0.0;
    ASSERT_TRUE(cost.Evaluate(blocks.data(), &e, jp.data()));
    int col = 0;
    for (const auto& b : jb) {
      for (const double d : b) worst = std::max(worst, std::abs(jac(static_cast<Eigen::Index>(i), col++) - d));
    }
    ASSERT_EQ(col, n);
  }
  // Basis functions by recurrence against std::cos and std::pow in the reference: rounding apart.
  EXPECT_LE(worst, 1e-12);
}

// What Ceres solves: the fits' cost functions (src/calib/ceres_fit.cpp, the hand-derived Jacobian
// of every reading of a setup in one residual block) as Ceres evaluates them, against the
// per-reading functors differentiated by Ceres, with every effect of the library and two setups
// (of too few readings each to be compressed, so that each reading is a row).
TEST(FitSolver, CeresSeesThePerReadingFunctorsDifferentiated) {
  SimulationSpec spec;
  spec.pattern = GridPattern(12, 6);
  spec.centers_mm = {Eigen::Vector3d(2.0, 0.0, 0.0), Eigen::Vector3d(0.0, -1.5, 0.5)};
  spec.scan_order = ScanOrder::kShuffled;
  const PointsData points = Simulate(spec);
  const std::vector<MotionDirection> approach = MotionDirections(points.samples);
  EffectModel model;
  std::vector<std::vector<double>> values;
  for (int e = 0; e < kNumEffects; ++e) {
    model.terms.push_back(DefaultTerm(static_cast<Effect>(e), 2, 2));
    std::vector<double> v;
    for (int i = 0; i < model.terms.back().size(); ++i) v.push_back(2e-5 * (i + 1) * (e % 2 ? -1 : 1));
    values.push_back(v);
  }
  values[static_cast<std::size_t>(model.Find(Effect::kProbeIncidence))] = {50e-3};
  model.reference = EffectReferenceOf(points.samples);
  model.phi_wobble_pivot_mm = 60.0;
  const ScmsGeometry g = SomeGeometry();
  const std::vector<Eigen::Vector3d> centers{{2.001, 0.002, -0.001}, {0.0, -1.499, 0.503}};
  const internal::ReadingTable table(points);
  const internal::SphereFitProblem problem(table, internal::AllRows(table), model, sph::testing::PaperOptions());
  const Eigen::VectorXd x = problem.Pack(g, centers, values);
  internal::FitSolver solver(problem);
  Eigen::VectorXd e;
  Eigen::MatrixXd jac;
  solver.Evaluate(x, &e, &jac);
  ASSERT_EQ(e.size(), static_cast<Eigen::Index>(points.samples.size()));
  ASSERT_EQ(jac.cols(), x.size());
  double worst = 0.0, worst_e = 0.0;
  Eigen::Index row = 0;
  for (int k = 0; k < problem.NumSetups(); ++k) {
    for (const std::uint32_t i : problem.RowsOf(k)) {
      const Sample& s = points.samples[i];
      ceres::DynamicAutoDiffCostFunction<EffectReadingResidual, 8> cost(
          new EffectReadingResidual{&model, EffectReading(s, s.t_s, approach[i])});
      cost.AddParameterBlock(kNumScmsParams);
      cost.AddParameterBlock(3);
      for (const auto& v : values) cost.AddParameterBlock(static_cast<int>(v.size()));
      cost.SetNumResiduals(1);
      std::vector<const double*> blocks{g.data(), centers[static_cast<std::size_t>(k)].data()};
      for (const auto& v : values) blocks.push_back(v.data());
      std::vector<std::vector<double>> jb;
      std::vector<double*> jp;
      for (int size : cost.parameter_block_sizes()) jb.emplace_back(static_cast<std::size_t>(size));
      for (auto& b : jb) jp.push_back(b.data());
      double reference = 0.0;
      ASSERT_TRUE(cost.Evaluate(blocks.data(), &reference, jp.data()));
      worst_e = std::max(worst_e, std::abs(e(row) - reference));
      // The columns of x: the seven errors, the centre of setup k, then the effects.
      std::vector<Eigen::Index> columns;
      for (int j = 0; j < kNumScmsParams; ++j) columns.push_back(j);
      for (int j = 0; j < 3; ++j) columns.push_back(kNumScmsParams + 3 * k + j);
      for (int j = 0; j < model.NumParams(); ++j) columns.push_back(problem.FirstEffectColumn() + j);
      std::size_t c = 0;
      Eigen::RowVectorXd expected = Eigen::RowVectorXd::Zero(x.size());
      for (const auto& b : jb) {
        for (const double d : b) expected(columns[c++]) = d;
      }
      worst = std::max(worst, (jac.row(row) - expected).cwiseAbs().maxCoeff());
      ++row;
    }
  }
  EXPECT_LE(worst_e, 1e-12);
  EXPECT_LE(worst, 1e-12);
}

// A setup of many readings is one residual block of n + 1 rows (n its parameters) that has the
// readings' normal equations: Ceres' J^T J, J^T e and cost equal those summed over the readings,
// with two setups, an effect and a form (every kind of parameter block), and without a loss only.
TEST(FitSolver, ASetupOfManyReadingsIsCompressedToItsNormalEquations) {
  SimulationSpec spec;
  spec.pattern = GridPattern(24, 12);
  spec.centers_mm = {Eigen::Vector3d(2.0, 0.0, 0.0), Eigen::Vector3d(0.0, -1.5, 0.5)};
  spec.noise_r_um = 0.05;
  const PointsData points = Simulate(spec);
  EffectModel model;
  model.terms.push_back(DefaultTerm(Effect::kThetaEncoder, 2, 2));
  model.reference = EffectReferenceOf(points.samples);
  model.form = FormModelOf(points, FormTermsOfDegrees(2, 2));
  const internal::ReadingTable table(points);
  const internal::SphereFitProblem problem(table, internal::AllRows(table), model, sph::testing::PaperOptions());
  ASSERT_GT(problem.NumFormTerms(), 0);
  const std::vector<Eigen::Vector3d> centers{{2.001, 0.002, -0.001}, {0.0, -1.499, 0.503}};
  std::vector<std::vector<double>> values{std::vector<double>(static_cast<std::size_t>(model.NumParams()), 3e-5)};
  Eigen::VectorXd x = problem.Pack(SomeGeometry(), centers, values);
  x.tail(problem.NumParams() - problem.FirstFormColumn(0)).setConstant(1e-5);
  internal::NormalEquations ne;
  ASSERT_TRUE(problem.Evaluate(x.data(), &ne));
  const int n = kNumScmsParams + 3 + problem.NumEffectParams() + problem.NumFormTerms();
  for (const bool loss : {false, true}) {
    internal::SolveConstraints c;
    if (loss) {
      c.loss = internal::LossKind::kHuber;
      c.loss_scale_mm = 1.0;  // far beyond every residual: the loss does not act
    }
    internal::FitSolver solver(problem, c);
    Eigen::VectorXd e;
    Eigen::MatrixXd jac;
    solver.Evaluate(x, &e, &jac);
    EXPECT_EQ(e.size(), loss ? problem.NumRows() : problem.NumSetups() * (n + 1)) << "loss " << loss;
    EXPECT_NEAR(0.5 * e.squaredNorm(), ne.cost, 1e-12 * ne.cost);
    const Eigen::MatrixXd jtj = jac.transpose() * jac;
    const Eigen::MatrixXd sym = ne.jtj.selfadjointView<Eigen::Lower>();
    EXPECT_LE((jtj - sym).cwiseAbs().maxCoeff(), 1e-12 * sym.cwiseAbs().maxCoeff()) << "loss " << loss;
    // J^T e: each entry against what rounding of the sum allows, |J_j| |e|.
    const Eigen::VectorXd jte = jac.transpose() * e;
    for (Eigen::Index j = 0; j < x.size(); ++j) {
      EXPECT_LE(std::abs(jte(j) - ne.jte(j)), 1e-12 * std::sqrt(sym(j, j) * 2.0 * ne.cost)) << "column " << j;
    }
  }
}

// The calibration (its block cost functions, the hand-derived Jacobian) against Ceres on the
// per-reading autodiff functors (one AutoDiffCostFunction per reading, dense QR), same start and
// tolerances.
TEST(Calibrate, AgreesWithCeresOnThePerReadingFunctors) {
  for (const double noise_um : {0.0, 0.05}) {
    SimulationSpec spec;
    spec.noise_r_um = noise_um;
    const PointsData points = Simulate(spec);
    const CalibrationResult fast = Calibrate(points, sph::testing::PaperOptions());
    ASSERT_TRUE(fast.converged) << fast.solver_message;
    ScmsGeometry g{};
    std::vector<Eigen::Vector3d> nominal;
    for (const Sample& s : points.samples) {
      nominal.push_back(ScmsPoint(g, s.theta_deg * kRadPerDeg, s.phi_deg * kRadPerDeg, s.r_mm, kD));
    }
    Eigen::Vector3d center = FitSphereAlgebraic(nominal).center;
    ceres::Problem problem;
    for (const Sample& s : points.samples) {
      problem.AddResidualBlock(
          SphereResidual::Create(s.theta_deg * kRadPerDeg, s.phi_deg * kRadPerDeg, s.r_mm, kD, kR0), nullptr, g.data(),
          center.data());
    }
    ceres::Solver::Options o;
    o.linear_solver_type = ceres::DENSE_QR;
    o.logging_type = ceres::SILENT;
    o.function_tolerance = 1e-6;
    o.gradient_tolerance = 1e-16;
    o.parameter_tolerance = 1e-12;
    ceres::Solver::Summary summary;
    ceres::Solve(o, &problem, &summary);
    ASSERT_EQ(summary.termination_type, ceres::CONVERGENCE) << summary.message;
    for (int p = 0; p < kNumScmsParams; ++p) {
      // Both stop when the cost changes by less than 1e-6 of itself: they agree to about
      // sqrt(1e-6) of the standard uncertainty (noise-free: to rounding).
      const double tol = noise_um > 0.0 ? 1e-3 * fast.analysis.std(p) : 1e-12;
      EXPECT_NEAR(fast.geometry[static_cast<std::size_t>(p)], g[static_cast<std::size_t>(p)], tol)
          << kScmsParamInfo[static_cast<std::size_t>(p)].name << ", noise " << noise_um << " um";
    }
    EXPECT_PRED_FORMAT3(MatrixNear, fast.centers_mm[0], center, noise_um > 0.0 ? 1e-3 * fast.analysis.std(7) : 1e-12);
  }
}

}  // namespace
}  // namespace sph
