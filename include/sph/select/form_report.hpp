// The sphere's form as a result of a calibration: its coefficients with their uncertainties, its
// size over the whole sphere, and what of it the design could not separate from the machine.
//
// Coefficients are those of the Schmidt semi-normalised real spherical harmonics S_lm of the
// sphere's body frame (sph/model/spherical_harmonics.hpp: |S_lm| <= 1, mean square 1 / (2l + 1)
// over the sphere), as displacements of the surface along the outward normal [um]. The RMS over
// the sphere is sqrt(sum c^2 / (2l + 1)) with the noise's share taken out: the fitted coefficients'
// noise adds tr(W C) to its square on average (W = diag(1 / (2l + 1)), C their covariance), as
// a measurement's rms_form_um takes out the noise of its residual. Its standard uncertainty is that
// of the corrected square (var = 4 c'WCWc + 2 tr(WCWC)) carried to the RMS, and, with a trace
// (SphereFormOf(const TraceResult&)), what the degrees above the one chosen could add. The
// peak-to-valley is taken on a grid of the sphere.
#ifndef SPH_SELECT_FORM_REPORT_HPP_
#define SPH_SELECT_FORM_REPORT_HPP_

#include <array>
#include <string>
#include <vector>

#include "sph/calib/effect_fit.hpp"
#include "sph/select/trace.hpp"

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
  double rms_um = 0.0;            ///< over the sphere, the coefficients' noise taken out (0 when it is all noise)
  double rms_fitted_um = 0.0;     ///< sqrt(sum c^2 / (2l + 1)) of the coefficients as fitted
  double rms_noise_um = 0.0;      ///< what their noise adds to it in quadrature on average: sqrt(tr(W C))
  double rms_std_um = 0.0;        ///< of rms_um: the coefficients' noise and the degree chosen
  double rms_noise_std_um = 0.0;  ///< of rms_um, from the coefficients' noise alone
  /// The degrees the pattern could still hold above degree_max (those searched, up to
  /// FormSelection::degree_limit; 0 when none or not known), and what they might add: the
  /// noise-corrected RMS of those degrees fitted beside the others, plus twice its standard
  /// uncertainty (a bound at about 95 %). rms_std_um includes the change of the RMS that they would
  /// make, sqrt(rms^2 + bound^2) - rms, as the half-width of a rectangular distribution.
  int higher_degree_limit = 0;
  double higher_rms_max_um = 0.0;
  double pv_um = 0.0;  ///< on a grid of 1 deg over the whole sphere
  std::vector<FormTermValue> terms;
  /// Terms the data cannot tell from other parameters (variance inflation above max_vif), each in
  /// words with the parameter it is most correlated with.
  std::vector<std::string> confounded;
};

/// The form of each group of `fit` (none when its model has no form). max_vif: above it a term is
/// named as confounded.
std::vector<SphereFormResult> SphereFormOf(const EffectFit& fit, double max_vif = 1e4);

/// The form of each group of the trace's final model, its uncertainty including the degree chosen
/// (TraceResult::form's fit at the highest degree searched).
std::vector<SphereFormResult> SphereFormOf(const TraceResult& r, double max_vif = 1e4);

/// The RMS over the sphere of a form's terms of degree l_min and above, with the noise's share taken
/// out, from their coefficients `c_mm` and covariance `cov_mm2` (of all of `terms`, mm): rms_um as
/// SphereFormResult's, its standard uncertainty from the noise, the RMS as fitted and the noise's
/// share [um].
struct CorrectedRms {
  double rms_um = 0.0, std_um = 0.0, fitted_um = 0.0, noise_um = 0.0;
};
CorrectedRms CorrectedFormRms(const std::vector<FormTerm>& terms, const Eigen::VectorXd& c_mm,
                              const Eigen::MatrixXd& cov_mm2, int l_min = 0);

/// The form of group `group` of `fit` on a grid over the body frame: rows of (polar angle [deg],
/// longitude [deg], F [um]), `step_deg` apart (cell centres).
std::vector<std::array<double, 3>> FormMap(const EffectFit& fit, int group, double step_deg);

}  // namespace sph

#endif  // SPH_SELECT_FORM_REPORT_HPP_
