// The report of a residual trace: its text and the validation of its model on another sphere.
// The trace's result (sph/select/trace.hpp) is the report's data; this renders it. Its JSON is
// part of JsonReport() (sph/calib/report.hpp), one document built as data, never text parsed
// back.
#ifndef SPH_SELECT_TRACE_REPORT_HPP_
#define SPH_SELECT_TRACE_REPORT_HPP_

#include <ostream>
#include <string>
#include <vector>

#include "sph/select/trace.hpp"

namespace sph {

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

/// Compensates the points of `path` with the trace's seven-error model and with its final model,
/// each as its calibration file carries it (CompensationOf(), as sph_measure applies it, through
/// CompensateAll()), and fits a least-squares sphere to each setup. probe_drift is not applied: a
/// drift belongs to the run it was measured in.
Validation Validate(const std::string& path, double probe_offset_mm, const TraceResult& trace);

/// The trace section of the text report.
void WriteTraceText(std::ostream& out, const TraceResult& trace, const Validation* validation);

}  // namespace sph

#endif  // SPH_SELECT_TRACE_REPORT_HPP_
