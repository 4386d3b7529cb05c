// The sphere's form as a result of a calibration: its coefficients with their uncertainties, its
// size over the whole sphere, and what of it the design could not separate from the machine.
//
// Coefficients are those of the Schmidt semi-normalised real spherical harmonics S_lm of the
// sphere's body frame (sph/model/spherical_harmonics.hpp: |S_lm| <= 1, mean square 1 / (2l + 1)
// over the sphere), as displacements of the surface along the outward normal [um]. The RMS over
// the sphere is sqrt(sum c^2 / (2l + 1)); its standard uncertainty comes from the covariance of the
// coefficients to first order (its gradient c / ((2l + 1) rms)), which overstates the precision
// when the RMS is not well above its noise. The peak-to-valley is taken on a grid of the sphere.
#ifndef SPH_CALIB_FORM_REPORT_HPP_
#define SPH_CALIB_FORM_REPORT_HPP_

#include <array>
#include <string>
#include <vector>

#include "sph/calib/effect_fit.hpp"

namespace sph {

/// One coefficient of the form.
struct FormTermValue {
  int l = 2;
  int m = 0;
  double value_um = 0.0;
  double std_um = 0.0;  ///< NaN when the fit was not analysed or the term is in the null space
};

/// The form of one coefficient set (group) of a fit.
struct SphereFormResult {
  /// "" for the set of the setups of known orientation, "@<setup>" for the form of its own of one
  /// setup of unknown orientation or on another sphere
  std::string setups;
  std::vector<int> setup_ids;  ///< the setups of a set of its own (empty for the reference set)
  int degree_max = 0;
  double rms_um = 0.0;
  double rms_std_um = 0.0;
  double pv_um = 0.0;  ///< on a grid of 1 deg over the whole sphere
  std::vector<FormTermValue> terms;
  /// Terms the data cannot tell from other parameters (variance inflation above max_vif), each in
  /// words with the parameter it is most correlated with.
  std::vector<std::string> confounded;
};

/// The form of each group of `fit` (none when its model has no form). max_vif: above it a term is
/// named as confounded.
std::vector<SphereFormResult> SphereFormOf(const EffectFit& fit, double max_vif = 1e4);

/// The form of group `group` of `fit` on a grid over the body frame: rows of (polar angle [deg],
/// longitude [deg], F [um]), `step_deg` apart (cell centres).
std::vector<std::array<double, 3>> FormMap(const EffectFit& fit, int group, double step_deg);

}  // namespace sph

#endif  // SPH_CALIB_FORM_REPORT_HPP_
