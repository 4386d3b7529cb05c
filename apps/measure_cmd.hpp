// sph_measure: options, CLI set-up and the run function (unit-tested directly).
//
// Measures a sphere: compensates raw readings with a calibration (or takes x y z coordinates),
// fits the least-squares sphere, evaluates least-squares and minimum-zone sphericity, judges the
// coverage, propagates the calibration's covariance, and draws a form-error map.
#ifndef SPH_APPS_MEASURE_CMD_HPP_
#define SPH_APPS_MEASURE_CMD_HPP_

#include <ostream>
#include <string>

#include "cli_fwd.hpp"

#include "gnuplot.hpp"
#include "progress.hpp"
#include "sph/measure/measure_workflow.hpp"

namespace sph::apps {

/// sph_measure's options: the workflow's (sph/measure/measure_workflow.hpp, whose defaults they
/// take) and the app's own: where the points come from and the outputs go.
struct MeasureOptions {
  std::string points_path;  ///< sph-points 1 readings, or x y z coordinates with workflow.xyz
  MeasurementWorkflowOptions workflow;
  std::string json_path;                         ///< JSON report ("-" for stdout), empty: none
  std::string report_path;                       ///< HTML report ("-" for stdout), empty: none
  std::string dcc_path;                          ///< Digital Calibration Certificate ("-" for stdout), empty: none
  std::string dcc_settings_path;                 ///< its administrative data, empty: the points header's alone
  std::string output_path;                       ///< compensated points (x_mm y_mm z_mm), empty: none
  std::string plot_path;                         ///< form-error map (PNG, drawn by gnuplot), empty: none
  std::string plot_script_path;                  ///< the gnuplot script of the map, empty: none
  std::string gnuplot = "gnuplot";               ///< the gnuplot program
  double plot_timeout_s = kDefaultPlotTimeoutS;  ///< gnuplot is stopped after this long
  bool quiet = false;                            ///< no text report on stdout (warnings still go to stderr)
  ProgressMode progress = ProgressMode::kAuto;   ///< progress on stderr
};

void SetupMeasureApp(CLI::App& app, MeasureOptions& options);

/// Runs a measurement; the text report goes to `out`, errors and warnings to `err`.
/// Returns kExitOk or kExitBadInput.
int RunMeasure(const MeasureOptions& options, std::ostream& out, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_MEASURE_CMD_HPP_
