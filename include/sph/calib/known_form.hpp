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
#include "sph/calib/statements.hpp"
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

/// The p-value below which the readings are said to disagree with the known form: the level of
/// every statement's test (sph/calib/statements.hpp).
inline constexpr double kKnownFormP = kStatementP;

/// The fraction of the prior's variance the readings must determine along a direction for the
/// direction to count in KnownFormCheck::conflict_chi_square, for each of the two tests: the
/// directions they determine well (a form a few times its prior's scale shows there alone; the
/// other directions would dilute it), and all they determine to 1 % (a form spread over many, as a
/// known form turned the wrong way); a direction they determine less carries too little of them
/// to tell apart from the rounding of the covariance.
inline constexpr double kConflictDetermined[] = {0.1, 0.01};

/// How the readings agree with the known form of a calibration (`fit`, whose model has it).
struct KnownFormCheck {
  std::string source;           ///< the form's file, or "the certificate's bound"
  std::vector<int> setups;      ///< another sphere's: the setups of its set; empty: the reference sphere
  int terms = 0;                ///< coefficients informed: the chi-square's degrees of freedom
  double known_rms_um = 0.0;    ///< RMS over the sphere of the form as known (the prior's mean)
  double fitted_rms_um = 0.0;   ///< RMS of the form fitted (the setups of known orientation)
  /// The readings' residual RMS with the form held as known, the seven errors and the centres
  /// refitted (the effects found left out), and the same without a form: what the form explains
  /// of the readings, for information.
  double rms_with_um = 0.0;
  double rms_without_um = 0.0;
  /// What the form explains of the readings: sqrt(without^2 - with^2), 0 when it fits worse.
  double explained_rms_um = 0.0;
  /// |L^-1 (c - c0)|^2 of the fitted coefficients c against the prior (mean c0, L L^T its
  /// covariance), and P(chi-square of `terms` degrees of freedom above it). The fitted
  /// coefficients lean towards c0 by what the prior adds, so with a form as known this is below
  /// `terms` on average; for information (the test is the conflict's below).
  double chi_square = 0.0;
  double p_value = 1.0;
  std::optional<double> bound_rms_um;  ///< the certificate's bound (k = 1), when given
  /// The test of the statement (sph/calib/statements.hpp): the prior against the readings' own
  /// estimate, the effects found kept. In the prior's whitened coordinates z = L^-1 (c - c0), the
  /// readings determine a fraction lambda_i of the prior's variance along each eigenvector u_i of
  /// I - L^-1 C L^-T (C the fitted coefficients' covariance, at the prior's noise); if the form is
  /// as stated, u_i^T z has variance lambda_i, and the readings' own estimate along u_i,
  /// u_i^T z / lambda_i, differs from the statement by N(0, 1 / lambda_i): the prior's variance and
  /// the readings'. The sum of (u_i^T z)^2 / lambda_i over the directions with lambda_i >= one of
  /// kConflictDetermined is chi-square with as many degrees of freedom; of the two tests, the one
  /// of the smaller upper tail is reported, conflict_p_value that tail times two (Bonferroni: the
  /// two together reject a right statement at most at the level).
  double conflict_chi_square = 0.0;
  int conflict_dof = 0;
  double conflict_p_value = 1.0;
  /// The readings' own estimate of the form less the form as known, over those directions: its RMS
  /// over the sphere, and the RMS it has on average when the form is as known (from both
  /// covariances) [um].
  double difference_rms_um = 0.0;
  double difference_expected_um = 0.0;
  /// With the certificate's bound as the prior: the readings reject it (conflict_p_value <
  /// kKnownFormP), the sphere's form is larger than its certificate allows.
  bool exceeds_bound = false;
  bool agrees = true;   ///< not rejected: conflict_p_value >= kKnownFormP (or nothing determined)
  std::string verdict;  ///< in words
  std::vector<std::string> warnings;  ///< disagreement, a form beyond the bound
};

/// The statement `k` tests, as StatementCheck: `statement` names it as the lab gave it (the file
/// and the mount rotations, or the bound).
StatementCheck StatementOf(const KnownFormCheck& k, StatementKind kind, const std::string& statement);

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

/// The mount rotation of one setup under which the readings best fit a known form held at its
/// stated value.
struct MountRotationFit {
  int setup = 0;
  Eigen::Vector3d right_angle_deg{0, 0, 0};  ///< the turn by right angles nearest the fitted one (rotation vector)
  Eigen::Vector3d fitted_deg{0, 0, 0};       ///< the rotation fitted (rotation vector) [deg]
  /// Standard uncertainty of the fitted rotation, the largest over the axes [deg]; infinite when the
  /// readings do not determine the turn about some axis (the form looks the same turned about it).
  double u_deg = 0.0;
  double offset_deg = 0.0;     ///< angle from right_angle_deg to fitted_deg [deg]
  double rms_um = 0.0;         ///< the readings' residual RMS at the fitted rotation
  double stated_rms_um = 0.0;  ///< and at the stated one
};

/// The turn of the sphere by right angles (one of the 24) of setup `setup` of `points` (one of known
/// orientation of the form's set) under which the readings, without `fit`'s outliers, best fit the
/// known form (options.form_prior when `prior_setup` < 0, else options.other_form_priors.at(
/// prior_setup)) held at its value, the seven errors and the centres refitted, `fit`'s effects
/// left out (found beside a wrongly turned form, they may have taken its misfit): right_angle_deg
/// = fitted_deg, rms_um at it, stated_rms_um at the stated rotation, u_deg infinite.
MountRotationFit BestRightAngleTurn(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                                    int setup, int prior_setup);

/// The rotation of that setup refined continuously from the one `points` states, the form held and
/// `fit`'s effects kept (a fit at an orientation the readings support): Gauss-Newton on a rotation
/// vector turning it, the residuals' derivatives by central differences of fits (every other
/// parameter refitted), the covariance s^2 (J^T J)^-1; the nearest turn by right angles and the
/// angle to it.
MountRotationFit RefineMountRotation(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                                     int setup, int prior_setup);

}  // namespace sph

#endif  // SPH_CALIB_KNOWN_FORM_HPP_
