// The form error of a sphere as a function on its body frame: real spherical harmonics of the
// direction, for a fit that separates the sphere's form from the machine's errors.
//
//   F(u) = sum_{(l, m) in terms} c_lm S_lm(u)                                         [mm]
//
// u: unit direction from the sphere's centre in the sphere's BODY frame; S_lm: the Schmidt
// semi-normalised real spherical harmonics of sph/model/spherical_harmonics.hpp (m >= 0 the cos,
// m < 0 the sin of |m| times the longitude), which the simulator's --form-um uses too. Over the
// whole sphere the mean of S_lm^2 is 1 / (2l + 1), so the RMS of F is sqrt(sum c_lm^2 / (2l + 1)).
// Degrees 0 and 1 are no form: a radius and a displacement of the centre.
//
// The body frame turns with the sphere on its mount: a point of the surface relative to the
// centre is p_theta = R_mount p_body in the frame that turns with the Theta axis, so the direction
// of a probed point p (sphere frame, sph/model/scms_model.hpp) is u = R_mount^T (p - O) / |p - O|.
//
// Evaluated from the Cartesian direction, without atan2: S_lm = N_lm Q_l^m(z) Re/Im (x + i y)^m,
// Q_l^m = P_l^m / (1 - z^2)^(m/2) a polynomial in z, so that it is smooth at the poles and works for
// ceres::Jet. Header-only, Eigen only.
#ifndef SPH_MODEL_FORM_MODEL_HPP_
#define SPH_MODEL_FORM_MODEL_HPP_

#include <cmath>
#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace sph {

/// One spherical harmonic of a form: degree l >= 2, order -l <= m <= l.
struct FormTerm {
  int l = 2;
  int m = 0;
  bool operator==(const FormTerm& o) const { return l == o.l && m == o.m; }
};

/// Every term of degrees `l_min`..`l_max`, in degree and then order m = -l..l.
inline std::vector<FormTerm> FormTermsOfDegrees(int l_min, int l_max) {
  std::vector<FormTerm> terms;
  for (int l = l_min; l <= l_max; ++l) {
    for (int m = -l; m <= l; ++m) terms.push_back({l, m});
  }
  return terms;
}

/// The values S_lm(u) of every degree 0..l_max and order, at a unit direction u = (x, y, z):
/// values[l * (l + 1) + m] = S_lm (so S_00 is at 0, S_2,-2 at 4). Scalar T may be a ceres::Jet.
template <typename T>
void SchmidtHarmonicsOf(const T& x, const T& y, const T& z, int l_max, std::vector<T>* values) {
  values->assign(static_cast<std::size_t>((l_max + 1) * (l_max + 1)), T(0.0));
  // Re and Im of (x + i y)^m.
  std::vector<T> re(static_cast<std::size_t>(l_max + 1)), im(static_cast<std::size_t>(l_max + 1));
  re[0] = T(1.0);
  im[0] = T(0.0);
  for (int m = 1; m <= l_max; ++m) {
    re[static_cast<std::size_t>(m)] = re[static_cast<std::size_t>(m - 1)] * x - im[static_cast<std::size_t>(m - 1)] * y;
    im[static_cast<std::size_t>(m)] = re[static_cast<std::size_t>(m - 1)] * y + im[static_cast<std::size_t>(m - 1)] * x;
  }
  for (int m = 0; m <= l_max; ++m) {
    // Q_m^m = (2m - 1)!!, Q_{m+1}^m = (2m + 1) z Q_m^m, then the three-term recursion in l.
    double qmm = 1.0;
    for (int i = 1; i <= m; ++i) qmm *= 2.0 * i - 1.0;
    T q_prev(qmm), q(0.0);
    for (int l = m; l <= l_max; ++l) {
      T q_l;
      if (l == m) {
        q_l = q_prev;
      } else if (l == m + 1) {
        q_l = z * T(2.0 * m + 1.0) * q_prev;
        q = q_prev;
        q_prev = q_l;
      } else {
        q_l = (z * T(2.0 * l - 1.0) * q_prev - T(l + m - 1.0) * q) / T(l - m);
        q = q_prev;
        q_prev = q_l;
      }
      // N_lm = sqrt(2 (l - m)! / (l + m)!) for m > 0.
      double norm = 1.0;
      if (m > 0) {
        double ratio = 1.0;
        for (int i = l - m + 1; i <= l + m; ++i) ratio /= i;
        norm = std::sqrt(2.0 * ratio);
      }
      const std::size_t base = static_cast<std::size_t>(l * (l + 1));
      (*values)[base + static_cast<std::size_t>(m)] = T(norm) * q_l * re[static_cast<std::size_t>(m)];
      if (m > 0) (*values)[base - static_cast<std::size_t>(m)] = T(norm) * q_l * im[static_cast<std::size_t>(m)];
    }
  }
}

/// The index of S_lm in SchmidtHarmonicsOf()'s values.
inline std::size_t HarmonicIndex(int l, int m) { return static_cast<std::size_t>(l * (l + 1) + m); }

/// F(u) = sum_k coefficients[k] S_{terms[k]}(u) [mm] at a unit body-frame direction u.
template <typename T>
T FormValue(const std::vector<FormTerm>& terms, const T* coefficients, const Eigen::Matrix<T, 3, 1>& u) {
  int l_max = 0;
  for (const FormTerm& t : terms) l_max = t.l > l_max ? t.l : l_max;
  std::vector<T> s;
  SchmidtHarmonicsOf(u[0], u[1], u[2], l_max, &s);
  T sum(0.0);
  for (std::size_t k = 0; k < terms.size(); ++k) sum += coefficients[k] * s[HarmonicIndex(terms[k].l, terms[k].m)];
  return sum;
}

/// The RMS of the form over the whole sphere [mm]: sqrt(sum c^2 / (2l + 1)) (see the file comment).
inline double FormRms(const std::vector<FormTerm>& terms, const std::vector<double>& coefficients) {
  double sum = 0.0;
  for (std::size_t k = 0; k < terms.size(); ++k) sum += coefficients[k] * coefficients[k] / (2.0 * terms[k].l + 1.0);
  return std::sqrt(sum);
}

/// The rotation R_mount of a rotation vector in degrees (axis times angle; zero: the identity).
inline Eigen::Matrix3d MountRotation(const Eigen::Vector3d& rotation_vector_deg) {
  const double angle_deg = rotation_vector_deg.norm();
  if (angle_deg == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle_deg * 3.14159265358979323846 / 180.0, rotation_vector_deg / angle_deg)
      .toRotationMatrix();
}

}  // namespace sph

#endif  // SPH_MODEL_FORM_MODEL_HPP_
