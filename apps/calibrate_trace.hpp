// sph_calibrate's closing of the loop: the report of a residual trace (text, JSON), the
// validation on another sphere, and the residual plots.
#ifndef SPH_APPS_CALIBRATE_TRACE_HPP_
#define SPH_APPS_CALIBRATE_TRACE_HPP_

#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sph/calib/trace.hpp"
#include "sph/core/calibration_file.hpp"
#include "sph/core/output_files.hpp"

namespace sph::apps {

/// Least-squares sphericity [um] of one sphere position of the validation file.
struct ValidationSetup {
  int setup = 0;
  int n_points = 0;
  double before_um = 0.0;
  double after_um = 0.0;
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
  std::string note;  ///< what of the model was not applied, and why
};

/// Compensates the points of `path` with `before` and `after` and fits a least-squares sphere
/// to each. probe_drift is not applied: a drift belongs to the run it was measured in.
Validation Validate(const std::string& path, double probe_offset_mm, const TraceResult& trace);

/// Puts the effects of `fit` into a calibration file, except probe_drift (it belongs to the run).
/// Returns whether a probe_drift was left out.
bool AddEffectsToCalibrationFile(const EffectFit& fit, CalibrationFile& file);

/// The trace section of the text report.
void WriteTraceText(std::ostream& out, const TraceResult& trace, const Validation* validation);

/// Adds the trace to the JSON report: effects_added, before, after, effects, candidates,
/// ambiguous, unexplained and validation.
void AddTraceJson(nlohmann::json& report, const TraceResult& trace, const Validation* validation);

/// The files PlotTrace() writes into its folder.
inline const std::vector<std::string> kTracePlotFiles = {"residual_map.png", "residual_time.png", "residuals.dat",
                                                         "residuals.gp",     "sphere_form_map.png", "sphere_form.dat",
                                                         "sphere_form.gp"};

/// Stages residual_map.png (over theta and phi, before and after) and residual_time.png (against
/// t), drawn now, with their gnuplot script and data, in `dir` (created when missing).
/// `points`: every reading of the calibration (outliers too).
void PlotTrace(const std::string& dir, const PointsData& points, const CalibrationOptions& options,
               const TraceResult& trace, OutputFiles& files);

}  // namespace sph::apps

#endif  // SPH_APPS_CALIBRATE_TRACE_HPP_
