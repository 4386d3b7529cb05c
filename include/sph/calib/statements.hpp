// What the lab states besides the readings, each tested against the readings by one rule before
// the calibration uses it: a prior on a parameter, a parameter held at a value, the sphere's form
// known from a separation with its orientation on the mount, a second sphere's known form, the
// certificate's bound on the form's RMS, and the model an earlier calibration file gives the
// comparison (docs/method/uncertainty.md, "What the lab states").
//
// The rule: the readings' own estimate of what the statement fixes (the statement left out, the
// effects found kept in the model) against the statement, with both covariances:
//   chi^2 = d^T (C_readings + C_statement)^-1 d,   d = estimate - stated,
// on as many degrees of freedom as the readings determine of it; the readings reject the statement
// when P(chi^2 above it) < kStatementP.
//
// Units: the fits in rad and mm; the words in the reports' units.
#ifndef SPH_CALIB_STATEMENTS_HPP_
#define SPH_CALIB_STATEMENTS_HPP_

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/calib/calibrator.hpp"
#include "sph/calib/effect_fit.hpp"
#include "sph/io/points_file.hpp"

namespace sph {

/// The level of the test: a statement whose p-value is below it is rejected by the readings.
inline constexpr double kStatementP = 0.001;

/// What a statement is about.
enum class StatementKind {
  kPrior,         ///< a Gaussian prior on a parameter (--prior, the header's "prior")
  kFixed,         ///< a parameter held at a value (--fix, the header's "fix")
  kKnownForm,     ///< the reference sphere's form from a separation, at its stated mount rotations
  kOtherForm,     ///< another sphere's form from a separation
  kFormBound,     ///< the certificate's bound of the form's RMS (sphere_form_rms_um) as the prior
  kEarlierModel,  ///< the model of an earlier calibration file, for the comparison (--compare)
};

/// "prior", "fixed", "known_form", "other_sphere_form", "form_bound", "earlier_model".
const char* StatementKindId(StatementKind kind);

/// A mount orientation the readings support for a known form the stated one is rejected for.
struct SupportedOrientation {
  int setup = 0;                             ///< the setup whose orientation was searched
  Eigen::Vector3d stated_deg{0, 0, 0};       ///< the stated rotation vector [deg]
  Eigen::Vector3d right_angle_deg{0, 0, 0};  ///< the turn by right angles nearest the fitted one [deg]
  Eigen::Vector3d fitted_deg{0, 0, 0};       ///< the rotation fitted with the form held [deg]
  double u_deg = 0.0;                        ///< standard uncertainty of the fitted rotation's angle [deg]
  double offset_deg = 0.0;                   ///< angle between the fitted rotation and right_angle_deg [deg]
  double p_value = 0.0;                      ///< the statement's test with the form at the fitted rotation
  bool agrees = false;                       ///< p_value >= kStatementP
  std::string text;                          ///< in words
};

/// One statement tested against the readings.
struct StatementCheck {
  StatementKind kind = StatementKind::kPrior;
  /// The statement as the lab gave it: "--prior alpha_deg=0.03,1e-06", "prior alpha_deg=0.03,1e-06
  /// (header of points.txt)", "--sphere-form sep.json, mount_rotation_deg@0: 0 0 0".
  std::string statement;
  std::string parameter;  ///< for a prior or a fixed value: the parameter's name
  std::string stated;     ///< the stated value with its standard uncertainty, in words
  std::string readings;   ///< the readings' own estimate with its standard uncertainty, in words
  double chi_square = 0.0;
  int dof = 0;  ///< what the readings determine of it; 0: not tested (they determine nothing of it)
  double p_value = 1.0;
  bool rejected = false;  ///< p_value < kStatementP
  /// Rejected, but the user accepted it as stated (CalibrationWorkflowOptions::accept_rejected):
  /// it then does not make the calibration unusable, and the calibration file says so.
  bool accepted = false;
  std::string verdict;  ///< in words, with both values
  /// For a rejected known form: the orientation the readings support, when searched.
  std::optional<SupportedOrientation> orientation;
};

/// Tests each prior and each fixed parameter of `options` against the readings `points` (without
/// the outliers of `fit`) under `fit`'s model (the effects found kept): the model fitted again
/// without that one statement, the others kept, gives the readings' estimate x and its standard
/// uncertainty u_x (at the readings' noise); chi^2 = (x - v)^2 / (u_x^2 + u^2) on one degree of
/// freedom, u the prior's standard uncertainty (0 for a held value). A parameter the readings
/// leave undetermined without the statement is not tested (dof 0). `origin` names where each
/// statement came from, by parameter ("--prior", "the header of points.txt").
std::vector<StatementCheck> CheckParameterStatements(const PointsData& points, const CalibrationOptions& options,
                                                     const EffectFit& fit,
                                                     const std::map<std::string, std::string>& origin);

/// "= 0.012", or "< 1e-300" for a p-value that underflows.
std::string PValueText(double p);

/// Whether any statement is rejected and not accepted.
bool AnyRejected(const std::vector<StatementCheck>& statements);

}  // namespace sph

#endif  // SPH_CALIB_STATEMENTS_HPP_
