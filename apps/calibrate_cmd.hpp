// sph_calibrate: options, CLI set-up and the run function (unit-tested directly).
#ifndef SPH_APPS_CALIBRATE_CMD_HPP_
#define SPH_APPS_CALIBRATE_CMD_HPP_

#include <ostream>
#include <string>
#include <vector>

#include "cli_fwd.hpp"

#include "gnuplot.hpp"
#include "progress.hpp"
#include "sph/calib/calibrate_workflow.hpp"

namespace sph::apps {

/// sph_calibrate's options: the workflow's (sph/calib/calibrate_workflow.hpp, whose defaults they
/// take) and the app's own: where the points come from and the outputs go.
struct CalibrateOptions {
  std::string points_path;
  CalibrationWorkflowOptions workflow;
  std::vector<std::string> effects;              ///< --effects' ids, into workflow.effects
  std::vector<std::string> fix;                  ///< parameters held: NAME or NAME_UNIT=VALUE, into workflow.fit.fixed
  std::vector<std::string> prior;                ///< Gaussian priors: NAME_UNIT=VALUE,U, into workflow.fit.priors
  std::vector<std::string> target_u;             ///< NAME_UNIT=U, into workflow.requirement.target_u
  std::string robust_loss;                       ///< "huber" or "cauchy", into workflow.fit.robust_loss
  std::string json_path;                         ///< JSON report ("-" for stdout), empty: none
  std::string report_path;                       ///< HTML report ("-" for stdout), empty: none
  std::string dcc_path;                          ///< Digital Calibration Certificate ("-" for stdout), empty: none
  std::string dcc_settings_path;                 ///< its administrative data, empty: the points header's alone
  std::string output_path;                       ///< calibration file, empty: none
  std::string firmware_blob_path;                ///< the calibration as the firmware blob, empty: none
  std::string firmware_c_path;                   ///< the same as a C source, empty: none
  bool quiet = false;                            ///< no text report on stdout
  std::string plot_dir;                          ///< residual plots (PNG, gnuplot) into this folder
  double plot_timeout_s = kDefaultPlotTimeoutS;  ///< gnuplot is stopped after this long
  ProgressMode progress = ProgressMode::kAuto;   ///< progress on stderr
};

void SetupCalibrateApp(CLI::App& app, CalibrateOptions& options);

/// Runs a calibration; the text report goes to `out`, errors and notes to `err`.
/// Returns kExitOk, kExitNotUsable or kExitBadInput.
int RunCalibrate(const CalibrateOptions& options, std::ostream& out, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_CALIBRATE_CMD_HPP_
