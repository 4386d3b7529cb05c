// Positioning-error tables of ISO 230-2 as encoder terms of the effect library, and the sign
// convention of the library's angles.
//
// ISO 230-2 states a rotary axis' positional deviation at each target position P_i as
//   x_i = P_actual - P_i            (actual minus target),
// the target being the position the axis reads. The encoder terms of sph/model/effect_terms.hpp are
//   theta_true = theta_read + sum_k c_k cos(k theta) + s_k sin(k theta),
// so their sum IS the ISO 230-2 deviation, with its sign: a vendor's table of x_i goes in as it is.
// The error of indication of the VIM (indicated minus true value), which some encoder certificates
// give, is its negative: negate such a table before importing it.
//
// A table's mean (k = 0) is a zero offset of the axis: of Theta a turn of the sphere about its
// axis, which the sphere's centre takes up; of Phi the angle error beta (about the opposite
// sense: the Phi frame's z is machine -y). It is returned apart, not put into the term.
//
// Header-only, Eigen only.
#ifndef SPH_MODEL_ISO230_HPP_
#define SPH_MODEL_ISO230_HPP_

#include <cmath>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "sph/model/effect_terms.hpp"
#include "sph/model/units.hpp"

namespace sph {

/// One row of an ISO 230-2 positioning-error table of a rotary axis.
struct PositionalDeviation {
  double target_deg = 0.0;        ///< target position P_i, what the axis reads [deg]
  double deviation_arcsec = 0.0;  ///< x_i = actual minus target [arcsec] (ISO 230-2's sign)
};

/// An encoder term imported from a table.
struct ImportedEncoderTerm {
  EffectTerm term;                   ///< theta_encoder or phi_encoder, harmonics 1..harmonics
  std::vector<double> values;        ///< its parameter block [rad]
  double mean_arcsec = 0.0;          ///< the table's mean: a zero offset (see the file comment)
  double rms_residual_arcsec = 0.0;  ///< what the harmonics leave of the table
};

/// The least-squares harmonics k = 1..harmonics (and the mean) of an ISO 230-2 table of the Theta
/// or Phi axis (`axis`: Effect::kThetaEncoder or Effect::kPhiEncoder). False when the table has
/// fewer than 2 harmonics + 2 rows or its targets do not determine the harmonics (all alike, say).
inline bool ImportPositionalDeviations(Effect axis, const std::vector<PositionalDeviation>& table, int harmonics,
                                       ImportedEncoderTerm* out) {
  if (axis != Effect::kThetaEncoder && axis != Effect::kPhiEncoder) return false;
  if (harmonics < 1 || harmonics > kMaxEffectHarmonic) return false;
  const int n = 2 * harmonics + 1;
  if (static_cast<int>(table.size()) < n + 1) return false;
  Eigen::MatrixXd a(static_cast<Eigen::Index>(table.size()), n);
  Eigen::VectorXd b(static_cast<Eigen::Index>(table.size()));
  for (std::size_t i = 0; i < table.size(); ++i) {
    const double x = table[i].target_deg * kRadPerDeg;
    const auto row = static_cast<Eigen::Index>(i);
    a(row, 0) = 1.0;
    for (int k = 1; k <= harmonics; ++k) {
      a(row, 2 * k - 1) = std::cos(k * x);
      a(row, 2 * k) = std::sin(k * x);
    }
    b(row) = table[i].deviation_arcsec;
  }
  const Eigen::MatrixXd normal = a.transpose() * a;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-12)) return false;
  const Eigen::VectorXd c = ldlt.solve(a.transpose() * b);
  out->term = DefaultTerm(axis, harmonics);
  out->values.clear();
  for (int k = 1; k <= harmonics; ++k) {  // DefaultTerm's order: c1, s1, c2, s2, ...
    out->values.push_back(c(2 * k - 1) * kRadPerArcsec);
    out->values.push_back(c(2 * k) * kRadPerArcsec);
  }
  out->mean_arcsec = c(0);
  out->rms_residual_arcsec = std::sqrt((a * c - b).squaredNorm() / static_cast<double>(table.size()));
  return true;
}

}  // namespace sph

#endif  // SPH_MODEL_ISO230_HPP_
