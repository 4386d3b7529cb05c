// Human-readable and JSON reports of a calibration, and the calibration file it leads to.
#ifndef SPH_CALIB_REPORT_HPP_
#define SPH_CALIB_REPORT_HPP_

#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "sph/calib/budget.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/calib/effect_fit.hpp"
#include "sph/io/calibration_comparison.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/model/compensation.hpp"

namespace sph {

struct TraceResult;  // sph/select/trace.hpp
struct KnownFormCheck;  // sph/calib/known_form.hpp
struct StatementCheck;  // sph/calib/statements.hpp
struct UsabilityRequirement;  // sph/calib/usability.hpp
struct Validation;   // sph/select/trace_report.hpp

/// What the report says about where the data came from.
struct ReportContext {
  std::string program;  ///< e.g. "sph_calibrate 0.1.0"
  std::string points_path;
  double sphere_radius_mm = 0.0;
  std::map<int, double> sphere_radii_mm;  ///< the setups that measured another sphere: its radius
  double probe_offset_mm = 0.0;
  double max_std_um = 0.0;
  std::optional<double> probe_range_mm;                       ///< the probe's measuring range, when stated [mm]
  std::vector<std::pair<std::string, std::string>> metadata;  ///< the points file's extra header fields
  /// The uncertainty budget of the result's parameters (GUM), when made; not owned.
  const CalibrationBudget* budget = nullptr;
  /// The residual traced to further effects, when traced, and its validation on another sphere
  /// (sph/select/trace_report.hpp): both reports then carry them. Not owned.
  const TraceResult* trace = nullptr;
  const Validation* validation = nullptr;
  /// The comparison with an earlier calibration, when made: both reports end with it. Not owned.
  const CalibrationComparison* comparison = nullptr;
  /// How the readings agree with the sphere's known form, when one was given. Not owned.
  const KnownFormCheck* known_form = nullptr;
  /// The same for each other sphere whose known form was given (may be null). Not owned.
  const std::vector<KnownFormCheck>* other_known_forms = nullptr;
  /// The statements of the lab tested against the readings (sph/calib/statements.hpp; may be
  /// null): a rejected one that was not accepted makes the calibration not usable. Not owned.
  const std::vector<StatementCheck>* statements = nullptr;
  /// The effects the trace had added beside a rejected statement, not applied (may be null).
  const std::vector<Effect>* withheld = nullptr;
  /// The run's warnings besides the fit's (the readings' plausibility, the budget's absence, the
  /// known forms, the statements; may be null): the reports' warnings hold both. Not owned.
  const std::vector<std::string>* run_warnings = nullptr;
  /// What "usable" is judged against besides max_std_um (may be null: max_std_um alone). Not owned.
  const UsabilityRequirement* requirement = nullptr;
  /// What the readings show was misread when the set-up does not fit (LikelyMisreading()'s
  /// Reason(), sph/calib/misreading.hpp); "" when nothing.
  std::string likely_cause;
};

/// A table of value +- std in the paper's units (deg, mm) and in urad and um, the fit summary,
/// correlations, conditioning, warnings and whether the calibration is usable, and why not
/// (JudgeUsability(), sph/calib/usability.hpp); then the trace, when ctx.trace is set.
void WriteTextReport(std::ostream& out, const CalibrationResult& result, const ReportContext& ctx);

/// The same as JSON (every key: docs/formats/reports.md): "usable" and "why_not_usable" are
/// JudgeUsability()'s, "undetermined" names every parameter of the fit that its data do not
/// determine (the effects' and the form's too).
std::string JsonReport(const CalibrationResult& result, const ReportContext& ctx);

/// The calibration file for compensation: the seven errors, their covariance, d and R0.
CalibrationFile MakeCalibrationFile(const CalibrationResult& result, const ReportContext& ctx);

/// Puts the effects of `fit` into a calibration file, except probe_drift (it belongs to the run).
/// Returns whether a probe_drift was left out.
bool AddEffectsToCalibrationFile(const EffectFit& fit, CalibrationFile& file);

/// The columns of the fit's analysis (its parameter order) of what AddEffectsToCalibrationFile()
/// puts into the file, in the file's covariance order: the seven errors, every effect parameter
/// but probe_drift's, then the form's coefficients of the setups of known orientation.
std::vector<int> AppliedColumns(const EffectFit& fit);

/// Puts the covariance of the parameters `columns` of the fit's analysis (in the file's order,
/// AppliedColumns(); the seven errors' alone without effects) into the file: `covariance` (their
/// 7 x 7 block) and `parameter_covariance`, the budget's combined one when given (else the fit's),
/// with each Type B input's share and the Type A degrees of freedom. Nothing when a parameter is
/// undetermined.
void AddCovarianceToCalibrationFile(const std::vector<int>& columns, const CalibrationResult& result,
                                    const CalibrationBudget* budget, CalibrationFile& file);

/// The calibration that compensates with `fit`'s model as its calibration file carries it: the
/// seven errors and every effect but probe_drift (what AddEffectsToCalibrationFile() writes, read
/// back as sph_measure reads it).
Calibration CompensationOf(const EffectFit& fit, double probe_offset_mm);

}  // namespace sph

#endif  // SPH_CALIB_REPORT_HPP_
