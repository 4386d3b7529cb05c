// Human-readable and JSON reports of a calibration, and the calibration file it leads to.
#ifndef SPH_CALIB_REPORT_HPP_
#define SPH_CALIB_REPORT_HPP_

#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "sph/calib/budget.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/core/calibration_file.hpp"

namespace sph {

/// What the report says about where the data came from.
struct ReportContext {
  std::string program;  ///< e.g. "sph_calibrate 0.1.0"
  std::string points_path;
  double sphere_radius_mm = 0.0;
  double probe_offset_mm = 0.0;
  double max_std_um = 0.0;
  std::vector<std::pair<std::string, std::string>> metadata;  ///< the points file's extra header fields
  /// The uncertainty budget of the result's parameters (GUM), when made; not owned.
  const CalibrationBudget* budget = nullptr;
};

/// A table of value +- std in the paper's units (deg, mm) and in urad and um, the fit summary,
/// correlations, conditioning and warnings.
void WriteTextReport(std::ostream& out, const CalibrationResult& result, const ReportContext& ctx);

/// The same as JSON (format described in README.md, "sph_calibrate --json").
std::string JsonReport(const CalibrationResult& result, const ReportContext& ctx);

/// The calibration file for compensation: the seven errors, their covariance, d and R0.
CalibrationFile MakeCalibrationFile(const CalibrationResult& result, const ReportContext& ctx);

}  // namespace sph

#endif  // SPH_CALIB_REPORT_HPP_
