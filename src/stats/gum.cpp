#include "sph/stats/gum.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "sph/core/error.hpp"

namespace sph::gum {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The standard normal distribution function, accurate in both tails (erfc, not 1 - erf).
double NormalCdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

double NormalPdf(double x) { return std::exp(-0.5 * x * x) / std::sqrt(2.0 * kPi); }

// The continued fraction of the regularised incomplete beta function I_x(a, b), evaluated by the
// modified Lentz method; converges fast for x < (a + 1) / (a + b + 2).
double BetaContinuedFraction(double x, double a, double b) {
  constexpr double kTiny = 1e-300;
  double c = 1.0;
  double d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double f = d;
  for (int m = 1; m <= 1000; ++m) {
    // The even step d_{2m} = m (b - m) x / ((a + 2m - 1)(a + 2m)), then the odd step
    // d_{2m+1} = -(a + m)(a + b + m) x / ((a + 2m)(a + 2m + 1)).
    for (int odd = 0; odd < 2; ++odd) {
      const double coefficient = odd == 0 ? m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m))
                                          : -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
      d = 1.0 + coefficient * d;
      if (std::abs(d) < kTiny) d = kTiny;
      c = 1.0 + coefficient / c;
      if (std::abs(c) < kTiny) c = kTiny;
      d = 1.0 / d;
      const double delta = c * d;
      f *= delta;
      if (odd == 1 && std::abs(delta - 1.0) < 1e-16) return f;
    }
  }
  return f;
}

double StudentTPdf(double t, double dof) {
  const double log_c = std::lgamma(0.5 * (dof + 1.0)) - std::lgamma(0.5 * dof) - 0.5 * std::log(dof * kPi);
  return std::exp(log_c - 0.5 * (dof + 1.0) * std::log1p(t * t / dof));
}

// Degrees of freedom beyond which t and the normal distribution agree to rounding.
constexpr double kNormalDof = 1e12;

}  // namespace

double ChiSquareSf(double x, double dof) {
  if (!(x > 0.0)) return 1.0;
  const double a = 0.5 * dof, z = 0.5 * x;
  const double log_front = a * std::log(z) - z - std::lgamma(a);
  constexpr int kMaxTerms = 1000;
  constexpr double kEps = 1e-15;
  if (z < a + 1.0) {  // P(a, z) by its series; Q = 1 - P
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < kMaxTerms; ++n) {
      term *= z / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * kEps) break;
    }
    return std::max(0.0, 1.0 - sum * std::exp(log_front));
  }
  // Q(a, z) by its continued fraction (modified Lentz).
  constexpr double kTiny = 1e-300;
  double b = z + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int n = 1; n < kMaxTerms; ++n) {
    const double an = -n * (n - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < kEps) break;
  }
  return std::exp(log_front) * h;
}

double RegularizedBeta(double x, double a, double b) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  const double log_front = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  const double front = std::exp(log_front);
  if (x < (a + 1.0) / (a + b + 2.0)) return front * BetaContinuedFraction(x, a, b) / a;
  return 1.0 - front * BetaContinuedFraction(1.0 - x, b, a) / b;
}

double NormalQuantile(double p) {
  if (!(p > 0.0 && p < 1.0)) throw Error("NormalQuantile: p must lie in (0, 1)");
  if (p > 0.5) return -NormalQuantile(1.0 - p);
  if (p == 0.5) return 0.0;
  // A start within 5e-4 (Abramowitz and Stegun 26.2.23), then Newton's method on the lower tail,
  // where erfc keeps its relative accuracy.
  const double t = std::sqrt(-2.0 * std::log(p));
  double x = -(t - (2.515517 + 0.802853 * t + 0.010328 * t * t) /
                       (1.0 + 1.432788 * t + 0.189269 * t * t + 0.001308 * t * t * t));
  for (int i = 0; i < 50; ++i) {
    const double step = (NormalCdf(x) - p) / NormalPdf(x);
    x -= step;
    if (std::abs(step) <= 1e-16 * std::max(1.0, std::abs(x))) break;
  }
  return x;
}

double StudentTCdf(double t, double dof) {
  if (!(dof > 0.0)) throw Error("StudentTCdf: the degrees of freedom must be positive");
  if (dof >= kNormalDof) return NormalCdf(t);
  const double tail = 0.5 * RegularizedBeta(dof / (dof + t * t), 0.5 * dof, 0.5);
  return t > 0.0 ? 1.0 - tail : tail;
}

double StudentTQuantile(double p, double dof) {
  if (!(p > 0.0 && p < 1.0)) throw Error("StudentTQuantile: p must lie in (0, 1)");
  if (!(dof > 0.0)) throw Error("StudentTQuantile: the degrees of freedom must be positive");
  if (dof >= kNormalDof) return NormalQuantile(p);
  if (p < 0.5) return -StudentTQuantile(1.0 - p, dof);
  if (p == 0.5) return 0.0;
  // Bracket, then Newton's method kept inside the bracket (bisection when it would leave it).
  double lo = 0.0, hi = std::max(1.0, NormalQuantile(p));
  while (StudentTCdf(hi, dof) < p) {
    lo = hi;
    hi *= 2.0;
  }
  double x = 0.5 * (lo + hi);
  for (int i = 0; i < 200; ++i) {
    const double f = StudentTCdf(x, dof) - p;
    if (f > 0.0)
      hi = x;
    else
      lo = x;
    double next = x - f / StudentTPdf(x, dof);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - x) <= 1e-15 * x) return next;
    x = next;
  }
  return x;
}

double CoverageFactor(double p, double dof) { return StudentTQuantile(0.5 * (1.0 + p), std::max(dof, 1.0)); }

double BudgetInput::Contribution() const { return std::abs(sensitivity) * standard_uncertainty; }

int UncertaintyStatement::Largest() const {
  int best = -1;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    if (best < 0 || inputs[i].Contribution() > inputs[static_cast<std::size_t>(best)].Contribution()) {
      best = static_cast<int>(i);
    }
  }
  return best;
}

UncertaintyStatement Combine(std::vector<BudgetInput> inputs, const CoverageSpec& coverage) {
  UncertaintyStatement s;
  s.inputs = std::move(inputs);
  double sum2 = 0.0, ws = 0.0;
  for (const BudgetInput& in : s.inputs) {
    const double c = in.Contribution();
    if (!std::isfinite(c)) throw Error("uncertainty budget: the contribution of " + in.name + " is not finite");
    sum2 += c * c;
    if (std::isfinite(in.dof)) ws += c * c * c * c / in.dof;
  }
  s.u = std::sqrt(sum2);
  s.dof = ws > 0.0 ? sum2 * sum2 / ws : kInfiniteDof;
  // GUM G.6.4: a non-integer nu_eff is truncated to the next lower integer for the t-factor.
  // (Rounding of the sums must not take an integer nu, as of a single input, to the next lower.)
  const double dof_for_k = std::isfinite(s.dof) ? std::max(1.0, std::floor(s.dof * (1.0 + 1e-12))) : kInfiniteDof;
  s.k = coverage.probability > 0.0 ? CoverageFactor(coverage.probability, dof_for_k) : coverage.k;
  s.U = s.k * s.u;
  s.coverage_probability = 2.0 * StudentTCdf(s.k, dof_for_k) - 1.0;
  return s;
}

// ---- Monte Carlo --------------------------------------------------------------------------------

double Distribution::Mean() const {
  switch (kind) {
    case Kind::kGaussian:
    case Kind::kStudentT:
      return a;
    case Kind::kRectangular:
    case Kind::kArcsine:
      return 0.5 * (a + b);
  }
  return a;
}

double Distribution::StandardDeviation() const {
  switch (kind) {
    case Kind::kGaussian:
      return b;
    case Kind::kStudentT:
      return dof > 2.0 ? b * std::sqrt(dof / (dof - 2.0)) : std::numeric_limits<double>::infinity();
    case Kind::kRectangular:
      return (b - a) / std::sqrt(12.0);
    case Kind::kArcsine:
      return (b - a) / std::sqrt(8.0);
  }
  return b;
}

double Distribution::Draw(Random& random) const {
  switch (kind) {
    case Kind::kGaussian:
      return a + b * random.Normal();
    case Kind::kRectangular:
      return a + (b - a) * random.Uniform();
    case Kind::kArcsine:
      return 0.5 * (a + b) + 0.5 * (b - a) * std::sin(2.0 * kPi * random.Uniform());  // JCGM 101 6.4.6
    case Kind::kStudentT: {
      // z / sqrt(chi2 / nu), chi2 as a sum of squared normals for integer nu, else by the
      // t quantile of a uniform (JCGM 101 6.4.9.5).
      if (dof == std::floor(dof) && dof <= 200.0) {
        const double z = random.Normal();
        double chi2 = 0.0;
        for (int i = 0; i < static_cast<int>(dof); ++i) {
          const double n = random.Normal();
          chi2 += n * n;
        }
        return a + b * z / std::sqrt(chi2 / dof);
      }
      return a + b * StudentTQuantile(random.Uniform(), dof);
    }
  }
  return a;
}

double NumericalTolerance(double u, int digits) {
  if (!(u > 0.0)) return 0.0;
  // u = c x 10^l with c an integer of `digits` digits; delta = 10^l / 2.
  const int l = static_cast<int>(std::floor(std::log10(u))) - (digits - 1);
  return 0.5 * std::pow(10.0, l);
}

void CoverageIntervals(std::vector<double>& values, double p, double* low, double* high, double* shortest_low,
                       double* shortest_high) {
  std::sort(values.begin(), values.end());
  const auto m = static_cast<long>(values.size());
  // q = pM values inside (JCGM 101 7.7.1; pM rounded to the nearest integer when not one).
  const long q = std::clamp(static_cast<long>(std::llround(p * static_cast<double>(m))), 1L, m);
  const long r = (m - q) / 2;  // the probabilistically symmetric interval starts at y_(r+1)
  *low = values[static_cast<std::size_t>(r)];
  *high = values[static_cast<std::size_t>(std::min(m - 1, r + q - 1))];
  long best = 0;
  for (long s = 1; s + q - 1 < m; ++s) {
    if (values[static_cast<std::size_t>(s + q - 1)] - values[static_cast<std::size_t>(s)] <
        values[static_cast<std::size_t>(best + q - 1)] - values[static_cast<std::size_t>(best)]) {
      best = s;
    }
  }
  *shortest_low = values[static_cast<std::size_t>(best)];
  *shortest_high = values[static_cast<std::size_t>(best + q - 1)];
}

namespace {

struct BatchSummary {
  double y, u, low, high;
};

double StdOfMean(const std::vector<double>& x) {
  const double h = static_cast<double>(x.size());
  const double mean = std::accumulate(x.begin(), x.end(), 0.0) / h;
  double s2 = 0.0;
  for (double v : x) s2 += (v - mean) * (v - mean);
  return std::sqrt(s2 / (h * (h - 1.0)));
}

}  // namespace

std::string CoverageSentence(const CoverageSpec& coverage, const std::string& result) {
  char text[200];
  if (coverage.probability > 0.0) {
    std::snprintf(text, sizeof text, "coverage: %g %%, k from each %s's effective degrees of freedom (t distribution)",
                  100.0 * coverage.probability, result.c_str());
  } else {
    std::snprintf(text, sizeof text,
                  "coverage: k = %g (about 95.45 %% for a normal distribution; --coverage 0.95 gives a coverage "
                  "interval)",
                  coverage.k);
  }
  return text;
}

namespace {
// The mean of the values' differences from the first one.
double MeanAboutFirst(const std::vector<double>& v) {
  double mean = 0.0;
  for (const double x : v) mean += x - v.front();
  return mean / static_cast<double>(v.size());
}
}  // namespace

double SampleMean(const std::vector<double>& v) { return v.front() + MeanAboutFirst(v); }

double SampleStd(const std::vector<double>& v) {
  const double mean = MeanAboutFirst(v);
  double ss = 0.0;
  for (const double x : v) ss += (x - v.front() - mean) * (x - v.front() - mean);
  return std::sqrt(ss / static_cast<double>(v.size() - 1));
}

PropagationResult PropagateDistributions(const std::function<double(const std::vector<double>&)>& model,
                                         const std::vector<Distribution>& inputs, const PropagationOptions& options) {
  if (!(options.probability > 0.0 && options.probability < 1.0)) {
    throw Error("Monte Carlo: the coverage probability must lie in (0, 1)");
  }
  const long m = options.batch_trials > 0
                     ? options.batch_trials
                     : std::max(static_cast<long>(std::ceil(100.0 / (1.0 - options.probability))), 10000L);
  Random random(options.seed);
  std::vector<double> x(inputs.size()), all, batch;
  std::vector<BatchSummary> batches;
  PropagationResult r;
  for (;;) {
    batch.resize(static_cast<std::size_t>(m));
    for (long i = 0; i < m; ++i) {
      for (std::size_t j = 0; j < inputs.size(); ++j) x[j] = inputs[j].Draw(random);
      batch[static_cast<std::size_t>(i)] = model(x);
    }
    all.insert(all.end(), batch.begin(), batch.end());
    BatchSummary s{};
    s.y = std::accumulate(batch.begin(), batch.end(), 0.0) / static_cast<double>(m);
    double ss = 0.0;
    for (double v : batch) ss += (v - s.y) * (v - s.y);
    s.u = std::sqrt(ss / static_cast<double>(m - 1));
    double sl, sh;
    CoverageIntervals(batch, options.probability, &s.low, &s.high, &sl, &sh);
    batches.push_back(s);
    if (!options.adaptive) break;
    if (batches.size() < 2) continue;
    // JCGM 101 7.9.4 f) to i): the standard deviations of the batch results against the tolerance.
    std::vector<double> ys, us, lows, highs;
    for (const BatchSummary& b : batches) {
      ys.push_back(b.y);
      us.push_back(b.u);
      lows.push_back(b.low);
      highs.push_back(b.high);
    }
    // The standard deviation of all the values so far, from the batches' own (Chan et al.).
    double n = 0.0, mean = 0.0, m2 = 0.0;
    for (const BatchSummary& b : batches) {
      const double nb = static_cast<double>(m), d = b.y - mean;
      m2 += b.u * b.u * (nb - 1.0) + d * d * n * nb / (n + nb);
      mean += d * nb / (n + nb);
      n += nb;
    }
    const double delta = NumericalTolerance(std::sqrt(m2 / (n - 1.0)), options.significant_digits);
    if (2.0 * StdOfMean(ys) <= delta && 2.0 * StdOfMean(us) <= delta && 2.0 * StdOfMean(lows) <= delta &&
        2.0 * StdOfMean(highs) <= delta) {
      r.converged = true;
      break;
    }
    if (static_cast<long>(all.size()) + m > options.max_trials) break;
  }
  r.trials = static_cast<long>(all.size());
  r.y = std::accumulate(all.begin(), all.end(), 0.0) / static_cast<double>(all.size());
  double ss = 0.0;
  for (double v : all) ss += (v - r.y) * (v - r.y);
  r.u = std::sqrt(ss / static_cast<double>(all.size() - 1));
  r.tolerance = NumericalTolerance(r.u, options.significant_digits);
  CoverageIntervals(all, options.probability, &r.low, &r.high, &r.shortest_low, &r.shortest_high);
  if (!options.adaptive) r.converged = true;
  return r;
}

bool GufValidated(double y_guf, double U, const PropagationResult& mc) {
  return std::abs(y_guf - U - mc.low) <= mc.tolerance && std::abs(y_guf + U - mc.high) <= mc.tolerance;
}

}  // namespace sph::gum
