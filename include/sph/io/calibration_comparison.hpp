// Today's calibration compared with an earlier one of the same machine: for each of the seven
// errors and each effect parameter both calibration files hold, the previous value, today's, the
// difference now - previous, the expanded uncertainty U of the difference (k = 2) and
// En = difference / U; the sphere's form by its RMS over the sphere when both hold one; a
// parameter only one of them holds listed as such, with its value and U.
//
// u(difference)^2 = g_now^T C_now g_now + g_prev^T C_prev g_prev - 2 sum_j (g_now . a_j)(g_prev . b_j),
// g the gradient of the compared quantity in each file's parameters, C each file's combined
// covariance and a_j = s_j u_j, b_j its contribution from a Type B input j that both take from the
// same source (counted fully correlated, so it cancels where it acts alike in both): the
// "R0 (certificate)" when both files give the same R0 within its uncertainty, and the "probe scale".
// Every other input (the sphere's temperature, the priors) and the Type A parts are counted
// independent; so is a shared input a file does not itemise (then U is larger, never smaller).
// U is that of two fits of one model: when the calibrations hold other effects (a parameter found
// in one only), the parameters both hold may differ by the change of model as well, and the
// verdict says so. So when today's model differs from the earlier one, today's readings are
// refitted with the earlier model and compared like with like (LikeForLike(), made by the
// calibrate workflow), today's own model's rows listed beside. Units as the reports': the seven errors in urad and um, the effects in arcsec and um, the form's
// RMS in um; internally rad and mm. The method: docs/method/uncertainty.md.
#ifndef SPH_IO_CALIBRATION_COMPARISON_HPP_
#define SPH_IO_CALIBRATION_COMPARISON_HPP_

#include <limits>
#include <string>
#include <vector>

#include "sph/io/calibration_file.hpp"

namespace sph {

/// The coverage factor of a comparison's U.
inline constexpr double kComparisonCoverageFactor = 2.0;

/// ComparedParameter::model and CalibrationComparison::model: today's own model.
inline constexpr const char* kTodaysModel = "today";
/// The same: today's readings refitted with the earlier calibration's model.
inline constexpr const char* kPreviousModel = "previous";

/// One parameter of a comparison.
struct ComparedParameter {
  enum class Found { kBoth, kPreviousOnly, kNowOnly };
  std::string parameter;  ///< "alpha", "theta_encoder.c2", "sphere_form.rms"
  std::string unit;       ///< "urad", "um", "arcsec"
  Found found = Found::kBoth;
  double previous = std::numeric_limits<double>::quiet_NaN();    ///< NaN when only today's holds it
  double now = std::numeric_limits<double>::quiet_NaN();         ///< NaN when only the previous holds it
  double difference = std::numeric_limits<double>::quiet_NaN();  ///< now - previous; NaN unless kBoth
  /// k = 2 expanded uncertainty of the difference (kBoth) or of the one value; NaN when a file has
  /// no covariance of it
  double U = std::numeric_limits<double>::quiet_NaN();
  double En = std::numeric_limits<double>::quiet_NaN();  ///< difference / U; NaN without a U > 0
  std::string note;                                      ///< why a value is not compared or has no U, else empty
  /// The model today's value comes from: kTodaysModel (today's own) or kPreviousModel (today's
  /// readings refitted with the earlier calibration's model).
  std::string model = kTodaysModel;
  /// Whether it was compared with an uncertainty: found in both, U > 0, no note.
  bool Compared() const { return found == Found::kBoth && U > 0.0 && note.empty(); }
};

/// A comparison of two calibrations of one machine.
struct CalibrationComparison {
  std::string previous_source;  ///< the earlier calibration file, as messages name it
  double k = kComparisonCoverageFactor;
  /// The seven errors, the effects' parameters, the form's RMS: the rows the verdict is taken on,
  /// all of `model`.
  std::vector<ComparedParameter> parameters;
  /// The model of `parameters`: kTodaysModel, or kPreviousModel when today's readings were refitted
  /// with the earlier calibration's model (LikeForLike()).
  std::string model = kTodaysModel;
  /// With model kPreviousModel: today's own model's rows, compared the same way, for information.
  std::vector<ComparedParameter> todays_model;
  /// Empty when the two models are the same; else which parameters each holds alone, and what
  /// today's own model changes (LikeForLike()) or why the earlier model was not fitted to today's
  /// readings (NotLikeForLike()).
  std::string models;
  std::vector<std::string> correlated_inputs;  ///< the Type B inputs counted fully correlated
  std::vector<std::string> notes;              ///< how the rest was counted, and what could not be compared
  /// "unchanged within uncertainty (9 parameters compared, each |En| <= 1)", or which moved and by
  /// how many U, or "nothing compared with an uncertainty"; then what one calibration holds alone.
  std::string verdict;
  /// Whether a parameter was compared and every one compared has |En| <= 1 (one found in one run
  /// only is no change of it).
  bool Unchanged() const;
};

/// Throws sph::Error naming `previous_source` and the field when `previous` is no earlier
/// calibration of the set-up of `now`: another nominal probe offset d (`probe_offset_mm`), whose
/// seven errors mean other things.
void CheckComparable(const CalibrationFile& previous, const CalibrationFile& now, const std::string& previous_source);

/// Compares `now` with `previous` (see the file comment); checks them with CheckComparable() first.
/// Probe terms (probe_gain, probe_nonlinearity) normalised by other probe readings (effect_reference)
/// and a phi_wobble about another pivot are listed with a note, not compared.
CalibrationComparison CompareCalibrations(const CalibrationFile& previous, const CalibrationFile& now,
                                          const std::string& previous_source);

/// The comparison taken like with like: `like` compares the earlier calibration with today's
/// readings refitted with its model (CompareCalibrations() of the refit's calibration file), `own`
/// with today's own model. Returns `like`, its rows and `model` kPreviousModel, the verdict its
/// own, `own`'s rows in todays_model and `models` saying that the models differ, which parameters
/// each holds alone and what today's own model changes: the parameters it moves most, by own's
/// value minus like's in units of like's U.
CalibrationComparison LikeForLike(CalibrationComparison like, const CalibrationComparison& own);

/// `own` (today's own model compared) when the earlier model could not be fitted to today's
/// readings (`why`): `models` and the verdict say so, and that the parameters both hold may differ
/// by the change of model as well, which U does not include.
CalibrationComparison NotLikeForLike(CalibrationComparison own, const std::string& why);

}  // namespace sph

#endif  // SPH_IO_CALIBRATION_COMPARISON_HPP_
