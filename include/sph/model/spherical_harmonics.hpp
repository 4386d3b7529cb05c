// Real spherical harmonics, Schmidt semi-normalised (|S_lm| <= 1), as used for the form error of a
// sphere. At the unit direction u = (x, y, z) = (sin p cos lon, sin p sin lon, cos p):
//
//   S_lm(u) = N_lm P_l^|m|(z) cos(m lon)     (m >= 0),     N_lm P_l^|m|(z) sin(|m| lon)     (m < 0),
//   N_l0 = 1,   N_lm = sqrt(2 (l - |m|)! / (l + |m|)!),
//
// P_l^m without the Condon-Shortley phase. Over the whole sphere the mean of S_lm^2 is 1 / (2l + 1).
//
// Evaluated from the Cartesian direction, without atan2 (smooth at the poles, and for any scalar
// type, e.g. ceres::Jet): P_l^m(z) (cos, sin)(m lon) = Q_l^m(z) (Re, Im) (x + i y)^m with
// Q_l^m = d^m P_l / dz^m = P_l^m / (1 - z^2)^(m/2), a polynomial in z:
//   Q_m^m = (2m - 1)!!,   Q_{m+1}^m = (2m + 1) z Q_m^m,
//   Q_l^m = ((2l - 1) z Q_{l-1}^m - (l + m - 1) Q_{l-2}^m) / (l - m).
// The same expression is a polynomial on all of R^3, and its gradient there is exact and cheap:
// d/dz Q_l^m = Q_l^{m+1}, d/dx (x + i y)^m = m (x + i y)^(m-1), d/dy (x + i y)^m = i m (x + i y)^(m-1).
// Projected on the tangent plane it is the gradient of S_lm on the sphere (what a fit needs of a
// function of the direction of p - O).
//
// Header-only, no dependencies.
#ifndef SPH_MODEL_SPHERICAL_HARMONICS_HPP_
#define SPH_MODEL_SPHERICAL_HARMONICS_HPP_

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <vector>

namespace sph {

/// The highest degree the evaluations below accept.
inline constexpr int kMaxHarmonicDegree = 40;

/// The index of S_lm among the values of every degree 0..l_max: l (l + 1) + m (S_00 at 0, S_2,-2 at 4).
inline constexpr std::size_t HarmonicIndex(int l, int m) { return static_cast<std::size_t>(l * (l + 1) + m); }

/// The number of values of degrees 0..l_max: (l_max + 1)^2.
inline constexpr std::size_t HarmonicCount(int l_max) { return static_cast<std::size_t>((l_max + 1) * (l_max + 1)); }

namespace internal {

// N_lm for 0 <= m <= l into norm[HarmonicIndex(l, m)], by N_{l,m}^2 / N_{l-1,m}^2 = (l - m) / (l + m).
inline void SchmidtNorms(int l_max, double* norm) {
  for (int m = 0; m <= l_max; ++m) {
    double n = 1.0;
    if (m > 0) {
      double f = 2.0;  // N_mm^2 = 2 / (2m)!
      for (int i = 1; i <= 2 * m; ++i) f /= i;
      n = std::sqrt(f);
    }
    for (int l = m; l <= l_max; ++l) {
      if (l > m) n *= std::sqrt(static_cast<double>(l - m) / static_cast<double>(l + m));
      norm[HarmonicIndex(l, m)] = n;
    }
  }
}

// Q_l^m(z) for 0 <= m <= l <= l_max into q[HarmonicIndex(l, m)] (see the file comment).
template <typename T>
void LegendreQ(const T& z, int l_max, T* q) {
  double qmm = 1.0;
  for (int m = 0; m <= l_max; ++m) {
    if (m > 0) qmm *= 2.0 * m - 1.0;
    q[HarmonicIndex(m, m)] = T(qmm);
    if (m == l_max) break;
    T prev = T(qmm), cur = z * T((2.0 * m + 1.0) * qmm);
    q[HarmonicIndex(m + 1, m)] = cur;
    for (int l = m + 2; l <= l_max; ++l) {
      T next = (z * T(2.0 * l - 1.0) * cur - T(l + m - 1.0) * prev) / T(l - m);
      prev = cur;
      cur = next;
      q[HarmonicIndex(l, m)] = cur;
    }
  }
}

}  // namespace internal

/// The values S_lm(u) of every degree 0..l_max <= kMaxHarmonicDegree and order at a unit direction
/// u = (x, y, z) into values[HarmonicIndex(l, m)] (HarmonicCount(l_max) of them). T may be a
/// ceres::Jet.
template <typename T>
void SchmidtHarmonicsOf(const T& x, const T& y, const T& z, int l_max, T* values) {
  std::array<double, HarmonicCount(kMaxHarmonicDegree)> norm;
  internal::SchmidtNorms(l_max, norm.data());
  std::array<T, kMaxHarmonicDegree + 1> re, im;  // (x + i y)^m
  re[0] = T(1.0);
  im[0] = T(0.0);
  for (int m = 1; m <= l_max; ++m) {
    re[static_cast<std::size_t>(m)] = re[static_cast<std::size_t>(m - 1)] * x - im[static_cast<std::size_t>(m - 1)] * y;
    im[static_cast<std::size_t>(m)] = re[static_cast<std::size_t>(m - 1)] * y + im[static_cast<std::size_t>(m - 1)] * x;
  }
  internal::LegendreQ(z, l_max, values);  // Q_l^m in the slots of m >= 0, then scaled in place
  for (int l = 0; l <= l_max; ++l) {
    for (int m = l; m >= 1; --m) {
      const T nq = T(norm[HarmonicIndex(l, m)]) * values[HarmonicIndex(l, m)];
      values[HarmonicIndex(l, m)] = nq * re[static_cast<std::size_t>(m)];
      values[HarmonicIndex(l, -m)] = nq * im[static_cast<std::size_t>(m)];
    }
  }
}

/// SchmidtHarmonicsOf() into a vector (resized to HarmonicCount(l_max)).
template <typename T>
void SchmidtHarmonicsOf(const T& x, const T& y, const T& z, int l_max, std::vector<T>* values) {
  values->resize(HarmonicCount(l_max));
  SchmidtHarmonicsOf(x, y, z, l_max, values->data());
}

/// S_lm at longitude lon [rad] and cos(polar angle) x, one value (see the file comment).
inline double SchmidtHarmonic(int l, int m, double lon, double x) {
  const double s = std::sqrt(std::fmax(0.0, 1.0 - x * x));
  std::vector<double> values;
  SchmidtHarmonicsOf(s * std::cos(lon), s * std::sin(lon), x, l, &values);
  return values[HarmonicIndex(l, m)];
}

/// The S_lm of degrees min_degree..max_degree (<= kMaxHarmonicDegree) at many directions, in the
/// order l = min..max, m = -l..l, with their gradients on R^3 when asked (see the file comment).
/// The normalisations are computed once; not thread-safe (scratch).
class SchmidtHarmonics {
 public:
  SchmidtHarmonics(int min_degree, int max_degree)
      : min_(min_degree), max_(max_degree), norm_(HarmonicCount(max_degree)), q_(HarmonicCount(max_degree)) {
    internal::SchmidtNorms(max_, norm_.data());
    re_.resize(static_cast<std::size_t>(max_ + 1));
    im_.resize(static_cast<std::size_t>(max_ + 1));
  }

  /// Number of functions.
  int size() const { return (max_ + 1) * (max_ + 1) - min_ * min_; }

  /// The functions at the unit direction (x, y, z) into out[0 .. size()); with gradient, their
  /// gradients (d/dx, d/dy, d/dz of each, one after the other) into gradient[0 .. 3 size()).
  void Evaluate(double x, double y, double z, double* out, double* gradient = nullptr) {
    re_[0] = 1.0;
    im_[0] = 0.0;
    for (int m = 1; m <= max_; ++m) {
      const auto k = static_cast<std::size_t>(m);
      re_[k] = re_[k - 1] * x - im_[k - 1] * y;
      im_[k] = re_[k - 1] * y + im_[k - 1] * x;
    }
    internal::LegendreQ(z, max_, q_.data());
    for (int l = min_; l <= max_; ++l) {
      for (int m = -l; m <= l; ++m) {
        const int am = std::abs(m);
        const double nq = norm_[HarmonicIndex(l, am)] * q_[HarmonicIndex(l, am)];
        const auto k = static_cast<std::size_t>(am);
        *out++ = nq * (m >= 0 ? re_[k] : im_[k]);
        if (gradient == nullptr) continue;
        // d/dx Re w^m = m Re w^(m-1), d/dy Re w^m = -m Im w^(m-1); d/dx Im = m Im, d/dy Im = m Re.
        double gx = 0.0, gy = 0.0;
        if (am > 0) {
          const double n_m = norm_[HarmonicIndex(l, am)] * q_[HarmonicIndex(l, am)] * am;
          gx = n_m * (m >= 0 ? re_[k - 1] : im_[k - 1]);
          gy = n_m * (m >= 0 ? -im_[k - 1] : re_[k - 1]);
        }
        const double dq = am + 1 <= l ? q_[HarmonicIndex(l, am + 1)] : 0.0;
        *gradient++ = gx;
        *gradient++ = gy;
        *gradient++ = norm_[HarmonicIndex(l, am)] * dq * (m >= 0 ? re_[k] : im_[k]);
      }
    }
  }

 private:
  int min_, max_;
  std::vector<double> norm_, q_, re_, im_;
};

}  // namespace sph

#endif  // SPH_MODEL_SPHERICAL_HARMONICS_HPP_
