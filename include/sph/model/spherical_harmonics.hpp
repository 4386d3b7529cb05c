// Real spherical harmonics, Schmidt semi-normalised (|S_lm| <= 1), as used for the form error of a
// sphere: S_lm(lon, x) = N_lm P_l^|m|(x) cos(m lon) for m >= 0 and N_lm P_l^|m|(x) sin(|m| lon)
// for m < 0, with x the cosine of the polar angle, P_l^m without the Condon-Shortley phase and
// N_lm = sqrt(2 (l - |m|)! / (l + |m|)!) for m != 0, 1 for m = 0. Header-only, no dependencies.
#ifndef SPH_MODEL_SPHERICAL_HARMONICS_HPP_
#define SPH_MODEL_SPHERICAL_HARMONICS_HPP_

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

namespace sph {

/// The associated Legendre function P_l^m(x), 0 <= m <= l, without the Condon-Shortley phase.
inline double AssociatedLegendre(int l, int m, double x) {
  double pmm = 1.0;
  const double s = std::sqrt(std::max(0.0, 1.0 - x * x));
  for (int i = 1; i <= m; ++i) pmm *= (2.0 * i - 1.0) * s;
  if (l == m) return pmm;
  double pm1 = x * (2.0 * m + 1.0) * pmm;
  for (int ll = m + 2; ll <= l; ++ll) {
    const double pll = (x * (2.0 * ll - 1.0) * pm1 - (ll + m - 1.0) * pmm) / (ll - m);
    pmm = pm1;
    pm1 = pll;
  }
  return pm1;
}

/// S_lm at longitude lon [rad] and cos(polar angle) x (see the file comment).
inline double SchmidtHarmonic(int l, int m, double lon, double x) {
  const int am = std::abs(m);
  double norm = 1.0;
  if (am > 0) {
    double ratio = 1.0;
    for (int i = l - am + 1; i <= l + am; ++i) ratio /= i;
    norm = std::sqrt(2.0 * ratio);
  }
  return norm * AssociatedLegendre(l, am, x) * (m >= 0 ? std::cos(am * lon) : std::sin(am * lon));
}

/// Every S_lm of degrees min_degree..max_degree at once, in the order l = min..max, m = -l..l:
/// the values of SchmidtHarmonic() (to rounding), with the normalisations computed once and the
/// Legendre functions and harmonics of the longitude by their recurrences.
class SchmidtHarmonics {
 public:
  SchmidtHarmonics(int min_degree, int max_degree) : min_(min_degree), max_(max_degree) {
    norm_.assign(static_cast<std::size_t>((max_ + 1) * (max_ + 1)), 1.0);
    for (int l = 0; l <= max_; ++l) {
      for (int m = 1; m <= l; ++m) {
        double ratio = 1.0;
        for (int i = l - m + 1; i <= l + m; ++i) ratio /= i;
        norm_[Index(l, m)] = std::sqrt(2.0 * ratio);
      }
    }
    legendre_.resize(norm_.size());
    cos_.resize(static_cast<std::size_t>(max_ + 1));
    sin_.resize(static_cast<std::size_t>(max_ + 1));
  }

  /// Number of functions.
  int size() const { return (max_ + 1) * (max_ + 1) - min_ * min_; }

  /// The functions at longitude lon [rad] and cos(polar angle) x into out[0 .. size()).
  void Evaluate(double lon, double x, double* out) {
    const double c1 = std::cos(lon), s1 = std::sin(lon);
    cos_[0] = 1.0;
    sin_[0] = 0.0;
    for (int m = 1; m <= max_; ++m) {
      cos_[static_cast<std::size_t>(m)] =
          cos_[static_cast<std::size_t>(m - 1)] * c1 - sin_[static_cast<std::size_t>(m - 1)] * s1;
      sin_[static_cast<std::size_t>(m)] =
          sin_[static_cast<std::size_t>(m - 1)] * c1 + cos_[static_cast<std::size_t>(m - 1)] * s1;
    }
    // AssociatedLegendre()'s recurrence in l for each m, all l at once.
    const double s = std::sqrt(std::max(0.0, 1.0 - x * x));
    double pmm = 1.0;
    for (int m = 0; m <= max_; ++m) {
      if (m > 0) pmm *= (2.0 * m - 1.0) * s;
      legendre_[Index(m, m)] = pmm;
      if (m == max_) break;
      double p_prev = pmm, p = x * (2.0 * m + 1.0) * pmm;
      legendre_[Index(m + 1, m)] = p;
      for (int l = m + 2; l <= max_; ++l) {
        const double next = (x * (2.0 * l - 1.0) * p - (l + m - 1.0) * p_prev) / (l - m);
        p_prev = p;
        p = next;
        legendre_[Index(l, m)] = p;
      }
    }
    for (int l = min_; l <= max_; ++l) {
      for (int m = -l; m <= l; ++m) {
        const int am = std::abs(m);
        const double angular = m >= 0 ? cos_[static_cast<std::size_t>(am)] : sin_[static_cast<std::size_t>(am)];
        *out++ = norm_[Index(l, am)] * legendre_[Index(l, am)] * angular;
      }
    }
  }

 private:
  std::size_t Index(int l, int m) const { return static_cast<std::size_t>(l * (max_ + 1) + m); }
  int min_, max_;
  std::vector<double> norm_, legendre_, cos_, sin_;
};

}  // namespace sph

#endif  // SPH_MODEL_SPHERICAL_HARMONICS_HPP_
