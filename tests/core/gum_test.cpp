#include "sph/stats/gum.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "test_util.hpp"

namespace sph::gum {
namespace {

// Rounds to `decimals` decimals, as a published table prints a value.
double Rounded(double v, int decimals) {
  const double f = std::pow(10.0, decimals);
  return std::round(v * f) / f;
}

TEST(Quantiles, NormalAndStudentTMatchTheTables) {
  // Closed forms for one and two degrees of freedom: tan(pi (p - 1/2)) and (2p - 1) / sqrt(2p(1 - p));
  // the others are the quantile functions of R (qnorm, qt) to 13 significant digits.
  EXPECT_NEAR(NormalQuantile(0.975), 1.959963984540, 1e-12);
  EXPECT_NEAR(NormalQuantile(0.995), 2.575829303549, 1e-12);
  EXPECT_NEAR(NormalQuantile(0.025), -1.959963984540, 1e-12);
  EXPECT_NEAR(NormalQuantile(1e-10), -6.361340902405, 1e-11);
  EXPECT_EQ(NormalQuantile(0.5), 0.0);
  EXPECT_NEAR(StudentTQuantile(0.975, 1), std::tan(3.14159265358979323846 * 0.475), 1e-10);
  EXPECT_NEAR(StudentTQuantile(0.975, 2), 0.95 / std::sqrt(2 * 0.975 * 0.025), 1e-12);
  EXPECT_NEAR(StudentTQuantile(0.975, 10), 2.228138851986, 1e-11);
  EXPECT_NEAR(StudentTQuantile(0.975, 30), 2.042272456301, 1e-11);
  EXPECT_NEAR(StudentTQuantile(0.995, 5), 4.032142983557, 1e-11);
  EXPECT_NEAR(StudentTQuantile(0.025, 10), -2.228138851986, 1e-11);
  EXPECT_NEAR(StudentTQuantile(0.975, kInfiniteDof), 1.959963984540, 1e-12);
  EXPECT_NEAR(StudentTCdf(2.228138851986, 10), 0.975, 1e-12);
}

// Closed forms of I_x(a, b): x^a for b = 1, 1 - (1 - x)^b for a = 1, 1/2 at x = 1/2 when a = b,
// and the symmetry I_x(a, b) = 1 - I_{1-x}(b, a), on both sides of the continued fraction's switch.
// x is dyadic, so that 1 - x is exact. The front factor exp(lgamma(a + b) - lgamma(a) - lgamma(b)
// + ...) carries the rounding of its logarithm, about 2.2e-16 times the size of its terms: the
// tolerance scales with lgamma(a + b).
TEST(RegularizedBeta, ClosedForms) {
  auto tolerance = [](double a, double b) { return 4e-16 * (10.0 + std::abs(std::lgamma(a + b))); };
  for (const double x : {0x1p-20, 0.03125, 0.3125, 0.5, 0.6875, 0.96875, 1.0 - 0x1p-20}) {
    for (const double a : {0.5, 1.0, 2.5, 7.0, 40.0}) {
      EXPECT_NEAR(RegularizedBeta(x, a, 1.0), std::pow(x, a), tolerance(a, 1.0)) << x << " " << a;
      EXPECT_NEAR(RegularizedBeta(x, 1.0, a), 1.0 - std::pow(1.0 - x, a), tolerance(a, 1.0)) << x << " " << a;
      EXPECT_NEAR(RegularizedBeta(x, a, 3.5) + RegularizedBeta(1.0 - x, 3.5, a), 1.0, 2.0 * tolerance(a, 3.5))
          << x << " " << a;
    }
  }
  for (const double a : {0.5, 3.0, 250.0}) EXPECT_NEAR(RegularizedBeta(0.5, a, a), 0.5, tolerance(a, a)) << a;
  EXPECT_EQ(RegularizedBeta(0.0, 2.0, 3.0), 0.0);
  EXPECT_EQ(RegularizedBeta(1.0, 2.0, 3.0), 1.0);
}

// The chi-square's upper tail: closed forms (2 dof: exp(-x / 2); 1 dof: the normal's two tails)
// and the tables' 5 % and 1 % points, on both sides of the switch from series to continued fraction.
TEST(ChiSquareSf, ClosedFormsAndTables) {
  for (const double x : {0.1, 1.0, 3.0, 10.0, 40.0}) EXPECT_NEAR(gum::ChiSquareSf(x, 2.0), std::exp(-x / 2.0), 1e-14);
  EXPECT_NEAR(gum::ChiSquareSf(1.959963984540054 * 1.959963984540054, 1.0), 0.05, 1e-12);
  EXPECT_NEAR(gum::ChiSquareSf(3.841458820694124, 1.0), 0.05, 1e-12);
  EXPECT_NEAR(gum::ChiSquareSf(18.307038053275146, 10.0), 0.05, 1e-11);
  EXPECT_NEAR(gum::ChiSquareSf(23.209251158954356, 10.0), 0.01, 1e-11);
  EXPECT_NEAR(gum::ChiSquareSf(9.341817765591966, 10.0), 0.5, 1e-11);
  EXPECT_NEAR(gum::ChiSquareSf(101.87898399614, 77.0), 0.030419489285345953, 1e-11);  // 77: degrees 2..8
  EXPECT_EQ(gum::ChiSquareSf(0.0, 5.0), 1.0);
}

TEST(Quantiles, CoverageFactorsOfGumTableG2) {
  // JCGM 100:2008 Table G.2, p = 95.45 % (the k = 2 of the normal distribution), two decimals.
  const double p = 0.9545;
  const std::pair<double, double> table[] = {{1, 13.97}, {2, 4.53},  {3, 3.31},  {4, 2.87},
                                             {5, 2.65},  {10, 2.28}, {20, 2.13}, {50, 2.05}};
  for (const auto& [dof, k] : table) EXPECT_EQ(Rounded(CoverageFactor(p, dof), 2), k) << "dof " << dof;
  EXPECT_EQ(Rounded(CoverageFactor(p, kInfiniteDof), 2), 2.00);
  // p = 99 %: nu = 16 gives the 2.92 of the end-gauge example (H.1.6).
  EXPECT_EQ(Rounded(CoverageFactor(0.99, 16), 2), 2.92);
}

// JCGM 100:2008 H.1, calibration of an end gauge of nominal length 50 mm: l = l_s + d -
// l_s (delta_alpha theta + alpha_s delta_theta). The budget of Table H.1 from the inputs' stated
// distributions; the sensitivities at the estimates.
TEST(Budget, EndGaugeOfGumH1) {
  const double l_s = 50000623.6;                 // nm
  const double theta = -0.1, alpha_s = 11.5e-6;  // degC, 1/degC
  // d from three components (H.1.3.2): the mean of 5 + repeated observations, random and
  // systematic effects of the comparator.
  const UncertaintyStatement d = Combine({
      {"d, repeated observations", EvaluationType::kA, 5.8, 1.0, 24},
      {"d, random effects of the comparator", EvaluationType::kB, 10.0 / StudentTQuantile(0.975, 5), 1.0, 5},
      {"d, systematic effects of the comparator", EvaluationType::kB, 20.0 / 3.0, 1.0, 8},
  });
  EXPECT_EQ(Rounded(d.u, 1), 9.7);
  EXPECT_NEAR(d.dof, 25.6, 0.1);
  const UncertaintyStatement l = Combine(
      {
          {"l_s, certificate (U = 75 nm, k = 3)", EvaluationType::kB, 25.0, 1.0, 18},
          {"d", EvaluationType::kA, d.u, 1.0, d.dof},
          {"alpha_s", EvaluationType::kB, 2e-6 / std::sqrt(3.0), -l_s * 0.0, kInfiniteDof},  // c = -l_s delta_theta = 0
          {"theta", EvaluationType::kB, std::sqrt(0.2 * 0.2 + 0.5 * 0.5 / 2.0), -l_s * 0.0, kInfiniteDof},
          {"delta_alpha", EvaluationType::kB, 1e-6 / std::sqrt(3.0), -l_s * theta, 50},
          {"delta_theta", EvaluationType::kB, 0.05 / std::sqrt(3.0), -l_s * alpha_s, 2},
      },
      CoverageSpec{0.0, 0.99});
  EXPECT_EQ(Rounded(l.u, 0), 32.0);                    // u_c(l) = 32 nm
  EXPECT_EQ(std::floor(l.dof), 16.0);                  // nu_eff = 16
  EXPECT_EQ(Rounded(l.k, 2), 2.92);                    // t_99(16)
  EXPECT_EQ(Rounded(l.k * Rounded(l.u, 0), 0), 93.0);  // U_99 = 2.92 x (32 nm) = 93 nm, as H.1.6 multiplies
  EXPECT_DOUBLE_EQ(l.U, l.k * l.u);
  EXPECT_EQ(l.inputs[static_cast<std::size_t>(l.Largest())].name, "l_s, certificate (U = 75 nm, k = 3)");
  EXPECT_NEAR(l.coverage_probability, 0.99, 1e-12);
}

TEST(Budget, KTwoByDefaultAndWelchSatterthwaite) {
  // u = sqrt(0.57^2 + 0.25^2), nu_eff = u^4 / (0.57^4 / 9) by hand: 12.796.
  const UncertaintyStatement s = Combine({{"a", EvaluationType::kA, 0.57, 1.0, 9}, {"b", EvaluationType::kB, 0.25}});
  EXPECT_NEAR(s.u, std::sqrt(0.57 * 0.57 + 0.25 * 0.25), 1e-15);
  EXPECT_NEAR(s.dof, std::pow(s.u, 4) / (std::pow(0.57, 4) / 9.0), 1e-12);
  EXPECT_NEAR(s.dof, 12.796, 1e-3);
  EXPECT_EQ(s.k, 2.0);
  EXPECT_EQ(s.U, 2.0 * s.u);
  const UncertaintyStatement b = Combine({{"b", EvaluationType::kB, 0.25}});
  EXPECT_EQ(b.dof, kInfiniteDof);
  EXPECT_NEAR(b.coverage_probability, 0.9545, 1e-4);
}

// Worked by hand: a radius of 20 mm that varies by a few nanometres, where summing the values
// themselves would leave only about 9 of the 16 digits to the variation.
TEST(SampleStatistics, KeepTheDigitsOfSmallVariationsOfALargeValue) {
  const std::vector<double> radius_mm = {20.000001, 20.000003, 20.000002, 20.000006};
  // mean 20.000003; deviations -2, 0, -1, 3 nm; sum of squares 14e-12; n - 1 = 3
  EXPECT_NEAR(gum::SampleMean(radius_mm), 20.000003, 1e-14);
  EXPECT_NEAR(gum::SampleStd(radius_mm), std::sqrt(14e-12 / 3.0), 1e-15);
  const std::vector<double> equal(5, 20.000001);
  EXPECT_EQ(gum::SampleMean(equal), 20.000001);
  EXPECT_EQ(gum::SampleStd(equal), 0.0);
}

TEST(MonteCarlo, NumericalToleranceOfClause792) {
  EXPECT_DOUBLE_EQ(NumericalTolerance(0.0754, 2), 0.0005);  // 75 x 10^-3
  EXPECT_DOUBLE_EQ(NumericalTolerance(2.0, 2), 0.05);
  EXPECT_DOUBLE_EQ(NumericalTolerance(10.1, 3), 0.05);
  EXPECT_DOUBLE_EQ(NumericalTolerance(10.1, 2), 0.5);
}

double Sum(const std::vector<double>& x) { return x[0] + x[1] + x[2] + x[3]; }

// A Monte Carlo result is known to its numerical tolerance delta (JCGM 101 7.9.2), and so is the
// published one: each test runs the adaptive procedure with as many significant digits as make
// delta half a unit of the table's last digit, and expects |ours - table| <= 2 delta. The output of
// the additive models is symmetric, so that their shortest and probabilistically symmetric intervals
// coincide; the latter is compared, as the former's position is poorly determined where the density
// is flat.
::testing::AssertionResult Agrees(const char* expr, const char*, const char*, double ours, double table, double delta) {
  if (std::abs(ours - table) <= 2.0 * delta) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << expr << " = " << ours << ", the table gives " << table
                                       << ", beyond 2 delta = " << 2.0 * delta;
}

// JCGM 101:2008 9.2.2, Table 2: the additive model with four standard normal inputs: y = 0.00,
// u(y) = 2.00, 95 % interval [-3.92, 3.92], which the GUM uncertainty framework gives as well.
TEST(MonteCarlo, AdditiveModelWithNormalInputsOfClause922) {
  const std::vector<Distribution> in(4, Distribution::Gaussian(0.0, 1.0));
  PropagationOptions o;
  o.significant_digits = 3;  // delta = 0.005
  const PropagationResult r = PropagateDistributions(Sum, in, o);
  ASSERT_TRUE(r.converged);
  EXPECT_EQ(r.tolerance, 0.005);
  EXPECT_PRED_FORMAT3(Agrees, r.y, 0.00, r.tolerance);
  EXPECT_PRED_FORMAT3(Agrees, r.u, 2.00, r.tolerance);
  EXPECT_PRED_FORMAT3(Agrees, r.low, -3.92, r.tolerance);
  EXPECT_PRED_FORMAT3(Agrees, r.high, 3.92, r.tolerance);
  EXPECT_TRUE(GufValidated(0.0, 1.96 * 2.0, r));
}

// JCGM 101:2008 9.2.3, Table 3: the same model with rectangular inputs of the same standard
// deviation: u(y) = 2.00, but the 95 % interval [-3.88, 3.88] is narrower than the GUM framework's
// [-3.92, 3.92], which is therefore not validated at this tolerance.
TEST(MonteCarlo, AdditiveModelWithRectangularInputsOfClause923) {
  const double a = std::sqrt(3.0);
  const std::vector<Distribution> in(4, Distribution::Rectangular(-a, a));
  PropagationOptions o;
  o.significant_digits = 3;
  const PropagationResult r = PropagateDistributions(Sum, in, o);
  ASSERT_TRUE(r.converged);
  EXPECT_PRED_FORMAT3(Agrees, r.u, 2.00, r.tolerance);
  EXPECT_PRED_FORMAT3(Agrees, r.low, -3.88, r.tolerance);
  EXPECT_PRED_FORMAT3(Agrees, r.high, 3.88, r.tolerance);
  EXPECT_FALSE(GufValidated(0.0, 1.96 * 2.0, r));
}

// JCGM 101:2008 9.2.4, Table 4: three rectangular inputs of standard deviation 1 and one of 10:
// u(y) = 10.1, the 95 % interval [-17.0, 17.0] against the GUM framework's [-19.9, 19.9].
TEST(MonteCarlo, AdditiveModelWithADominantRectangularInputOfClause924) {
  const double a = std::sqrt(3.0);
  const std::vector<Distribution> in = {Distribution::Rectangular(-a, a), Distribution::Rectangular(-a, a),
                                        Distribution::Rectangular(-a, a), Distribution::Rectangular(-10 * a, 10 * a)};
  PropagationOptions o;
  o.significant_digits = 3;  // delta = 0.05
  const PropagationResult r = PropagateDistributions(Sum, in, o);
  ASSERT_TRUE(r.converged);
  EXPECT_EQ(r.tolerance, 0.05);
  EXPECT_PRED_FORMAT3(Agrees, r.u, 10.1, r.tolerance);
  EXPECT_PRED_FORMAT3(Agrees, r.low, -17.0, r.tolerance);
  EXPECT_PRED_FORMAT3(Agrees, r.high, 17.0, r.tolerance);
  const UncertaintyStatement guf = Combine({{"x1", EvaluationType::kB, 1.0},
                                            {"x2", EvaluationType::kB, 1.0},
                                            {"x3", EvaluationType::kB, 1.0},
                                            {"x4", EvaluationType::kB, 10.0}},
                                           CoverageSpec{0.0, 0.95});
  EXPECT_EQ(Rounded(guf.U, 1), 19.9);
  EXPECT_FALSE(GufValidated(0.0, guf.U, r));
}

// JCGM 101:2008 9.3, mass calibration: the deviation of a weight's conventional mass from 100 g,
//   dm = (m_Rc + dm_Rc)(1 + (rho_a - rho_a0)(1/rho_W - 1/rho_R)) - m_nom  [mg],
// rho_a0 = 1.2 kg/m^3, with m_Rc ~ N(100 000.000, 0.050) mg, dm_Rc ~ N(1.234, 0.020) mg,
// rho_a ~ R(1.10, 1.30) kg/m^3, rho_W ~ R(7 000, 9 000) kg/m^3, rho_R ~ R(7 950, 8 050) kg/m^3.
// The GUM framework at first order gives 1.2340 mg, u = 0.0539 mg, [1.1285, 1.3395] mg (the
// buoyancy terms have no sensitivity at the estimates); Monte Carlo 1.2341 mg, u = 0.0754 mg,
// shortest 95 % interval [1.0834, 1.3825] mg. Two significant digits of u: delta = 0.0005 mg.
TEST(MonteCarlo, MassCalibrationOfClause93) {
  const auto model = [](const std::vector<double>& x) {
    const double m_rc = x[0], dm_rc = x[1], rho_a = x[2], rho_w = x[3], rho_r = x[4];
    return (m_rc + dm_rc) * (1.0 + (rho_a - 1.2) * (1.0 / rho_w - 1.0 / rho_r)) - 100000.0;
  };
  const std::vector<Distribution> in = {Distribution::Gaussian(100000.000, 0.050), Distribution::Gaussian(1.234, 0.020),
                                        Distribution::Rectangular(1.10, 1.30), Distribution::Rectangular(7000, 9000),
                                        Distribution::Rectangular(7950, 8050)};
  const PropagationResult r = PropagateDistributions(model, in, {});
  ASSERT_TRUE(r.converged);
  EXPECT_EQ(r.tolerance, 0.0005);
  EXPECT_PRED_FORMAT3(Agrees, r.y, 1.2341, r.tolerance);
  EXPECT_PRED_FORMAT3(Agrees, r.u, 0.0754, r.tolerance);
  EXPECT_PRED_FORMAT3(Agrees, r.shortest_low, 1.0834, r.tolerance);
  EXPECT_PRED_FORMAT3(Agrees, r.shortest_high, 1.3825, r.tolerance);
  const UncertaintyStatement guf =
      Combine({{"m_Rc", EvaluationType::kB, 0.050}, {"dm_Rc", EvaluationType::kB, 0.020}}, CoverageSpec{0.0, 0.95});
  EXPECT_EQ(Rounded(guf.u, 4), 0.0539);
  EXPECT_EQ(Rounded(1.234 - guf.U, 4), 1.1285);
  EXPECT_EQ(Rounded(1.234 + guf.U, 4), 1.3395);
  EXPECT_FALSE(GufValidated(1.234, guf.U, r));
}

}  // namespace
}  // namespace sph::gum
