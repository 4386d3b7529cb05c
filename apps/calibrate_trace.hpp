// sph_calibrate's closing of the loop: the report of a residual trace (text, JSON), the
// validation on another sphere, and the residual plots.
#ifndef SPH_APPS_CALIBRATE_TRACE_HPP_
#define SPH_APPS_CALIBRATE_TRACE_HPP_

#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sph/calib/budget.hpp"
#include "sph/calib/trace.hpp"
#include "sph/core/calibration_file.hpp"
#include "sph/core/output_files.hpp"

namespace sph::apps {

/// Least-squares sphericity and rms of the residuals about the least-squares sphere [um] of one
/// sphere position of the validation file.
struct ValidationSetup {
  int setup = 0;
  int n_points = 0;
  double before_um = 0.0;
  double after_um = 0.0;
  double before_rms_um = 0.0;
  double after_rms_um = 0.0;
};

/// An rms of residuals with its standard uncertainty, and how two of them compare. For n
/// residuals with nu = n - 4 degrees of freedom (per sphere) u(rms) = rms / sqrt(2 nu), the std of
/// the rms of normal residuals to first order. A difference is inside the noise when it is at most
/// twice sqrt(u_1^2 + u_2^2) (the two taken as independent, which overstates the uncertainty of
/// the difference of two rms of the same readings: "inside" is said rather too often than too
/// rarely).
struct RmsComparison {
  double before_um = 0.0, before_u_um = 0.0;
  double after_um = 0.0, after_u_um = 0.0;
  double difference_um = 0.0, difference_u_um = 0.0;
  bool inside_noise = true;
};

/// Least-squares sphericity [um] of another sphere measured on the same machine, compensated with
/// the seven-error model and with the model after tracing; the largest over its setups (sphere
/// positions), each of which has a sphere of its own.
struct Validation {
  std::string path;
  int n_points = 0;
  double before_um = 0.0;
  double after_um = 0.0;
  std::vector<ValidationSetup> setups;
  RmsComparison rms;  ///< pooled over the setups (each about its own sphere)
  std::string note;   ///< what of the model was not applied, and why
};

/// Compensates the points of `path` with `before` and `after` and fits a least-squares sphere
/// to each. probe_drift is not applied: a drift belongs to the run it was measured in.
Validation Validate(const std::string& path, double probe_offset_mm, const TraceResult& trace);

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

/// The trace section of the text report.
void WriteTraceText(std::ostream& out, const TraceResult& trace, const Validation* validation);

/// Adds the trace to the JSON report: effects_added, before, after, effects, candidates,
/// ambiguous, unexplained and validation.
void AddTraceJson(nlohmann::json& report, const TraceResult& trace, const Validation* validation);

/// The files PlotTrace() writes into its folder.
inline const std::vector<std::string> kTracePlotFiles = {"residual_map.png", "residual_time.png",   "residuals.dat",
                                                         "residuals.gp",     "sphere_form_map.png", "sphere_form.dat",
                                                         "sphere_form.gp"};

/// Stages residual_map.png (over theta and phi, before and after) and residual_time.png (against
/// t), drawn now, with their gnuplot script and data, in `dir` (created when missing).
/// `points`: every reading of the calibration (outliers too).
void PlotTrace(const std::string& dir, const PointsData& points, const CalibrationOptions& options,
               const TraceResult& trace, OutputFiles& files);

}  // namespace sph::apps

#endif  // SPH_APPS_CALIBRATE_TRACE_HPP_
