// The reference sphere's form as the lab knows it, in an everyday calibration: from the
// calibration file of a run that separated it (its "sphere_form" with the coefficients'
// covariance), or bounded by the sphere's certificate (sphere_form_rms_um, k = 1). Either becomes
// a Gaussian prior on the form's coefficients (FormPrior, sph/calib/calibrator.hpp); after the fit,
// CheckKnownForm() says how well the readings agree with it.
//
// Units: the prior in mm; the check's *_um fields in um.
#ifndef SPH_CALIB_KNOWN_FORM_HPP_
#define SPH_CALIB_KNOWN_FORM_HPP_

#include <optional>
#include <string>
#include <vector>

#include "sph/calib/calibrator.hpp"
#include "sph/calib/effect_fit.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/points_file.hpp"

namespace sph {

/// The prior of the form a calibration file holds: its coefficients and their covariance
/// (FormCovariance(); its cross-covariance with that run's seven errors is not carried). Throws
/// sph::Error naming `path` when the file holds no form, or no uncertainty of it. `notes`, when
/// given, receives what the prior lacks (the coefficients' correlations, in an older file).
FormPrior FormPriorOfFile(const CalibrationFile& file, const std::string& path,
                          std::vector<std::string>* notes = nullptr);

/// Throws sph::Error, both values in the message, when a calibration's R0 (`radius_mm`, its
/// certificate's standard uncertainty `radius_u_um`; `what` names the calibration) differs from
/// the R0 of the form's file `path` by more than the sum of their standard uncertainties (the file's:
/// its covariance input "R0 (certificate)"; 1 nm of rounding allowed): the form belongs to
/// another sphere; also when the file does not state R0 (whose sphere it is cannot be told).
void CheckSameSphere(const CalibrationFile& file, const std::string& path, double radius_mm, double radius_u_um,
                     const std::string& what);

/// The p-value below which the readings are said to disagree with the known form.
inline constexpr double kKnownFormP = 0.01;

/// The fraction of the prior's variance the readings must determine along a direction for the
/// direction to count in KnownFormCheck::conflict_chi_square.
inline constexpr double kConflictDetermined = 0.1;

/// How the readings agree with the known form of a calibration (`fit`, whose model has it).
struct KnownFormCheck {
  std::string source;           ///< the form's file, or "the certificate's bound"
  std::vector<int> setups;      ///< another sphere's: the setups of its set; empty: the reference sphere
  int terms = 0;                ///< coefficients informed: the chi-square's degrees of freedom
  double known_rms_um = 0.0;    ///< RMS over the sphere of the form as known (the prior's mean)
  double fitted_rms_um = 0.0;   ///< RMS of the form fitted (the setups of known orientation)
  /// The readings' residual RMS with the form held as known, the seven errors and the centres
  /// refitted (the effects found left out: beside a form that is not the sphere's, they can take
  /// its misfit), and the same without a form.
  double rms_with_um = 0.0;
  double rms_without_um = 0.0;
  /// What the form explains of the readings: sqrt(without^2 - with^2), 0 when it fits worse.
  double explained_rms_um = 0.0;
  /// |L^-1 (c - c0)|^2 of the fitted coefficients c against the prior (mean c0, L L^T its
  /// covariance), and P(chi-square of `terms` degrees of freedom above it). The fitted
  /// coefficients lean towards c0 by what the prior adds, so with a form as known this is below
  /// `terms` on average: a small p-value is a clear disagreement.
  double chi_square = 0.0;
  double p_value = 1.0;
  std::optional<double> bound_rms_um;  ///< the certificate's bound (k = 1), when given
  /// The prior against the readings, its shrinkage counted: in the prior's whitened coordinates
  /// z = L^-1 (c - c0), the readings determine a fraction lambda_i of the prior's variance along
  /// each eigenvector u_i of I - L^-1 C L^-T (C the fitted coefficients' covariance, at the
  /// prior's noise), and if the form is a draw of the prior, u_i^T z has variance lambda_i. The
  /// sum of (u_i^T z)^2 / lambda_i over the directions with lambda_i >= kConflictDetermined is then
  /// chi-square with as many degrees of freedom; its upper tail is conflict_p_value.
  double conflict_chi_square = 0.0;
  int conflict_dof = 0;
  double conflict_p_value = 1.0;
  /// With the certificate's bound as the prior: conflict_p_value < kKnownFormP, the sphere's form
  /// is larger than its certificate allows (the prior held it, the residual took the rest).
  bool exceeds_bound = false;
  bool agrees = true;   ///< p_value >= kKnownFormP, the form fits no worse than none, and not exceeds_bound
  std::string verdict;  ///< in words
  std::vector<std::string> warnings;  ///< disagreement, a form beyond the bound
};

/// Checks `fit` (of `points`, whose outliers it names, under `options` with its form_prior)
/// against options.form_prior: the prior's chi-square and its conflict with the readings, the seven
/// errors fitted with the form as known and without one, and the certificate's bound `bound_rms_um`
/// when given (the prior's conflict when the bound is the prior, the form fitted, and the known
/// form's own RMS when the prior is a file's). `source` names the form in the words.
KnownFormCheck CheckKnownForm(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                              const std::string& source, std::optional<double> bound_rms_um, bool from_file);

/// The same for the known form of another sphere, options.other_form_priors' of `setup` (from the
/// file `source`): its set's coefficients against it; rms_with_um with that set held at its known
/// value, rms_without_um held at zero, the other sets as fitted.
KnownFormCheck CheckOtherKnownForm(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                                   int setup, const std::string& source);

}  // namespace sph

#endif  // SPH_CALIB_KNOWN_FORM_HPP_
