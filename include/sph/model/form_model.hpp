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
// Evaluated from the Cartesian direction, without atan2 (SchmidtHarmonicsOf()), so that it is
// smooth at the poles and works for ceres::Jet. Header-only, Eigen only.
#ifndef SPH_MODEL_FORM_MODEL_HPP_
#define SPH_MODEL_FORM_MODEL_HPP_

#include <cmath>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "sph/model/spherical_harmonics.hpp"

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
inline Eigen::Matrix3d MountRotationMatrix(const Eigen::Vector3d& rotation_vector_deg) {
  const double angle_deg = rotation_vector_deg.norm();
  if (angle_deg == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle_deg * 3.14159265358979323846 / 180.0, rotation_vector_deg / angle_deg)
      .toRotationMatrix();
}

/// How the readings of one setup see the form: which coefficient set (group) and the mount
/// rotation R (body frame into the Theta frame).
struct FormSetup {
  int group = 0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
};

/// The sphere's form in a fit: the terms, the same for every group, and by setup id which
/// coefficient set a setup uses and how the sphere sits on its mount there. Setups of known
/// orientation share one set; a sphere remounted at an unknown orientation has its own, and
/// another sphere one of its own, shared by the setups that measured it in known orientations.
/// The coefficients are parameters [mm], group after group, term order within each. No terms: no
/// form.
struct FormModel {
  std::vector<FormTerm> terms;
  std::map<int, FormSetup> setups;  ///< a setup absent here: group 0, reference orientation
  /// Per group, what its parameter names carry: "" for the reference sphere's set, "@<setup>" for
  /// the set of one setup of unknown orientation, "@<setup>,<setup>..." for the set of another
  /// sphere, by the setups that measured it.
  std::vector<std::string> group_names{""};

  bool Empty() const { return terms.empty(); }
  int NumGroups() const { return static_cast<int>(group_names.size()); }
  int NumParams() const { return static_cast<int>(terms.size()) * NumGroups(); }
  int MaxDegree() const {
    int l_max = 0;
    for (const FormTerm& t : terms) l_max = t.l > l_max ? t.l : l_max;
    return l_max;
  }
  const FormSetup& SetupOf(int setup_id) const {
    static const FormSetup reference{};
    const auto it = setups.find(setup_id);
    return it == setups.end() ? reference : it->second;
  }
  /// "sphere_form.S(3,-2)", or "sphere_form@2.S(3,-2)" for the set of setup 2 (unknown orientation
  /// or another sphere).
  std::string ParamName(int group, std::size_t term) const {
    return "sphere_form" + group_names[static_cast<std::size_t>(group)] + ".S(" + std::to_string(terms[term].l) + "," +
           std::to_string(terms[term].m) + ")";
  }
};

}  // namespace sph

#endif  // SPH_MODEL_FORM_MODEL_HPP_
