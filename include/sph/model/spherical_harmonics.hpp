// Real spherical harmonics, Schmidt semi-normalised (|S_lm| <= 1), as used for the form error of a
// sphere: S_lm(lon, x) = N_lm P_l^|m|(x) cos(m lon) for m >= 0 and N_lm P_l^|m|(x) sin(|m| lon)
// for m < 0, with x the cosine of the polar angle, P_l^m without the Condon-Shortley phase and
// N_lm = sqrt(2 (l - |m|)! / (l + |m|)!) for m != 0, 1 for m = 0. Header-only, no dependencies.
#ifndef SPH_MODEL_SPHERICAL_HARMONICS_HPP_
#define SPH_MODEL_SPHERICAL_HARMONICS_HPP_

#include <algorithm>
#include <cmath>
#include <cstdlib>

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

}  // namespace sph

#endif  // SPH_MODEL_SPHERICAL_HARMONICS_HPP_
