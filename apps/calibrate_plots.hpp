// sph_calibrate's residual plots of a trace (before and after, over the sphere and against time),
// the map of the sphere's form and the error curves, drawn by gnuplot.
#ifndef SPH_APPS_CALIBRATE_PLOTS_HPP_
#define SPH_APPS_CALIBRATE_PLOTS_HPP_

#include <string>
#include <vector>

#include "sph/io/output_files.hpp"
#include "sph/io/points_file.hpp"
#include "sph/select/trace.hpp"

namespace sph::apps {

/// The files PlotTrace() writes into its folder.
inline const std::vector<std::string> kTracePlotFiles = {
    "residual_map.png", "residual_time.png", "residuals.dat",    "residuals.gp",    "sphere_form_map.png",
    "sphere_form.dat",  "sphere_form.gp",    "error_curves.png", "error_curves.dat", "error_curves.gp"};

/// Stages residual_map.png (over theta and phi, before and after), residual_time.png (against
/// t), sphere_form_map.png (when the form was fitted) and error_curves.png (the effects of an axis
/// angle, each with its 95 % band), drawn now, with their gnuplot scripts and data, in the folder
/// `dir` (PlotFolder::Make()).
/// `points`: every reading of the calibration (outliers too); gnuplot gets `timeout_s` for each
/// of its two runs.
void PlotTrace(const std::string& dir, const PointsData& points, const CalibrationOptions& options,
               const TraceResult& trace, double timeout_s, OutputFiles& files);

}  // namespace sph::apps

#endif  // SPH_APPS_CALIBRATE_PLOTS_HPP_
