// Uncertainty as a calibration laboratory states it: the budget of JCGM 100:2008 (the GUM) and the
// propagation of distributions by the Monte Carlo method of JCGM 101:2008 (GUM Supplement 1).
//
// A budget lists each input quantity with its standard uncertainty u(x_i), how it was evaluated
// (Type A: from the statistics of the data; Type B: from other knowledge, a certificate, a data
// sheet, a limit), its sensitivity coefficient c_i = df/dx_i and its degrees of freedom nu_i
// (infinite for a Type B input known exactly enough). The inputs are taken as uncorrelated;
// correlated inputs, such as the parameters of one fit, enter as one input whose u is already
// their combination sqrt(c^T V c) (GUM 5.2). Then (GUM 5.1.2, G.4, G.6.4, 6.2)
//   u_c(y)^2 = sum_i (c_i u(x_i))^2
//   nu_eff   = u_c^4 / sum_i (c_i u(x_i))^4 / nu_i                 (Welch-Satterthwaite, G.4.1)
//   U        = k u_c,  k = 2 by default, or k = t_{(1+p)/2}(nu_eff) for a coverage probability p.
//
// The Monte Carlo method draws the inputs from their distributions, evaluates the model for
// each draw and summarises the output's distribution: its mean, standard deviation and a
// coverage interval (probabilistically symmetric and shortest, JCGM 101 7.7), with the adaptive
// procedure of JCGM 101 7.9 that adds batches until the results are stable to the numerical
// tolerance of the standard uncertainty's significant digits (7.9.2). Draws come from the
// project's random generator (sph/stats/random.hpp), the same numbers with every compiler.
#ifndef SPH_STATS_GUM_HPP_
#define SPH_STATS_GUM_HPP_

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "sph/stats/random.hpp"

namespace sph::gum {

inline constexpr double kInfiniteDof = std::numeric_limits<double>::infinity();

/// The p-quantile of the standard normal distribution (0 < p < 1), to about 1e-15.
double NormalQuantile(double p);
/// I_x(a, b), the regularised incomplete beta function (a, b > 0; 0 outside x > 0, 1 for x >= 1),
/// by its continued fraction: the distribution functions of Student's t and of the F distribution.
double RegularizedBeta(double x, double a, double b);
/// P(X > x) for X chi-square distributed with `dof` (> 0) degrees of freedom: Q(dof / 2, x / 2),
/// the regularised upper incomplete gamma function (series below x < dof / 2 + 1, else its
/// continued fraction), to about 1e-14; 1 for x <= 0.
double ChiSquareSf(double x, double dof);
/// The distribution function of Student's t distribution with `dof` (> 0, may be infinite)
/// degrees of freedom.
double StudentTCdf(double t, double dof);
/// The p-quantile of Student's t distribution (0 < p < 1); the normal quantile for infinite dof.
double StudentTQuantile(double p, double dof);
/// The coverage factor for a coverage probability p with `dof` degrees of freedom: the
/// (1 + p)/2-quantile of Student's t (GUM G.3.4). For dof below 1 the value at dof = 1.
double CoverageFactor(double p, double dof);

enum class EvaluationType { kA, kB };

/// One input quantity of a budget.
struct BudgetInput {
  std::string name;  ///< what it is: "R0 (certificate)", "fit (scatter of the points)"
  EvaluationType type = EvaluationType::kB;
  double standard_uncertainty = 0.0;  ///< u(x_i), in the input's own unit
  double sensitivity = 1.0;           ///< c_i = df/dx_i, output unit per input unit
  double dof = kInfiniteDof;          ///< nu_i
  std::string unit = {};              ///< of x_i, for the report
  std::string note = {};              ///< where u(x_i) comes from

  /// |c_i| u(x_i), in the output's unit: the input's share of the combined uncertainty.
  double Contribution() const;
};

/// How the expanded uncertainty is formed: a stated k (2 by default), or a coverage probability
/// p, from which k = t_{(1+p)/2}(nu_eff).
struct CoverageSpec {
  double k = 2.0;          ///< used when probability is 0
  double probability = 0;  ///< 0 < p < 1: the coverage probability instead of a fixed k
};

/// "coverage: ..." for a report: the coverage probability and where k comes from (each result's
/// effective degrees of freedom), or the fixed k. `result` names what each k belongs to.
std::string CoverageSentence(const CoverageSpec& coverage, const std::string& result);

/// Mean of at least one value, summed about the first one: a radius of 20 mm that varies by
/// nanometres keeps its digits, and equal values give exactly that value.
double SampleMean(const std::vector<double>& values);

/// Sample standard deviation (n - 1) of at least two values, computed about the first one, as
/// SampleMean().
double SampleStd(const std::vector<double>& values);

/// The uncertainty statement of one result.
struct UncertaintyStatement {
  std::vector<BudgetInput> inputs;
  double u = 0.0;             ///< combined standard uncertainty u_c
  double dof = kInfiniteDof;  ///< effective degrees of freedom (Welch-Satterthwaite)
  double k = 2.0;             ///< coverage factor
  double U = 0.0;             ///< expanded uncertainty k u_c
  /// The coverage probability the interval y +- U has under a t distribution with nu_eff degrees
  /// of freedom (0.9545 for k = 2 and many degrees of freedom).
  double coverage_probability = 0.0;
  /// The input of the largest contribution (empty budget: -1).
  int Largest() const;
};

/// Combines the inputs (GUM 5.1.2, G.4.1) and expands by `coverage`.
UncertaintyStatement Combine(std::vector<BudgetInput> inputs, const CoverageSpec& coverage = {});

// ---- JCGM 101: propagation of distributions ---------------------------------------------------

/// The distribution assigned to an input quantity (JCGM 101 6.4).
struct Distribution {
  enum class Kind { kGaussian, kRectangular, kArcsine, kStudentT } kind = Kind::kGaussian;
  double a = 0.0;  ///< Gaussian, t: the mean; rectangular, arcsine: the lower limit
  double b = 0.0;  ///< Gaussian, t: the standard deviation (t: the scale); rectangular, arcsine: the upper limit
  double dof = kInfiniteDof;  ///< t only

  static Distribution Gaussian(double mean, double sd) { return {Kind::kGaussian, mean, sd}; }
  static Distribution Rectangular(double lo, double hi) { return {Kind::kRectangular, lo, hi}; }
  /// U-shaped, on [lo, hi] (a quantity varying sinusoidally between its limits).
  static Distribution Arcsine(double lo, double hi) { return {Kind::kArcsine, lo, hi}; }
  /// The scaled and shifted t distribution of a Type A input from nu + 1 readings (JCGM 101 6.4.9).
  static Distribution StudentT(double mean, double scale, double dof) { return {Kind::kStudentT, mean, scale, dof}; }

  double Mean() const;
  double StandardDeviation() const;  ///< infinite for t with dof <= 2
  double Draw(Random& random) const;
};

/// How PropagateDistributions() runs (JCGM 101 7.9).
struct PropagationOptions {
  double probability = 0.95;   ///< of the coverage interval
  int significant_digits = 2;  ///< of u(y), which set the numerical tolerance (JCGM 101 7.9.2)
  std::uint64_t seed = 1;
  long batch_trials = 0;        ///< M of each batch; 0: max(100 / (1 - p), 10^4) (7.9.4 b)
  long max_trials = 100000000;  ///< give up (converged = false) beyond this many trials
  bool adaptive = true;         ///< false: exactly one batch of batch_trials
};

/// The output's distribution as PropagateDistributions() found it (JCGM 101 7.6, 7.7).
struct PropagationResult {
  double y = 0.0;    ///< mean of the model values
  double u = 0.0;    ///< their standard deviation
  double low = 0.0;  ///< probabilistically symmetric coverage interval
  double high = 0.0;
  double shortest_low = 0.0;  ///< shortest coverage interval
  double shortest_high = 0.0;
  long trials = 0;
  double tolerance = 0.0;  ///< numerical tolerance delta of u (JCGM 101 7.9.2)
  bool converged = false;  ///< the adaptive procedure reached the tolerance
};

/// The numerical tolerance of `u` given to `digits` significant digits: half a unit of the last
/// digit (JCGM 101 7.9.2: u = 0.0754 with two digits is 75 x 10^-3, so delta = 0.5 x 10^-3).
double NumericalTolerance(double u, int digits);

/// Propagates the distributions of `inputs` through `model` (JCGM 101 7, adaptive as 7.9.4).
/// `model` gets one draw of every input, in order.
PropagationResult PropagateDistributions(const std::function<double(const std::vector<double>&)>& model,
                                         const std::vector<Distribution>& inputs,
                                         const PropagationOptions& options = {});

/// The coverage interval of `values` for probability p (JCGM 101 7.7): the values are sorted in
/// place; symmetric: the (1 - p)/2 and (1 + p)/2 points; shortest: the shortest of all intervals
/// holding a fraction p.
void CoverageIntervals(std::vector<double>& values, double p, double* low, double* high, double* shortest_low,
                       double* shortest_high);

/// Whether the GUM interval y_guf +- U agrees with the Monte Carlo one to the tolerance
/// (JCGM 101 8.2): both ends within delta.
bool GufValidated(double y_guf, double U, const PropagationResult& mc);

}  // namespace sph::gum

#endif  // SPH_STATS_GUM_HPP_
