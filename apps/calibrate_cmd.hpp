// sph_calibrate: options, CLI set-up and the run function (unit-tested directly).
#ifndef SPH_APPS_CALIBRATE_CMD_HPP_
#define SPH_APPS_CALIBRATE_CMD_HPP_

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "cli_fwd.hpp"

#include "gnuplot.hpp"
#include "progress.hpp"
#include "sph/core/points_file.hpp"

namespace sph::apps {

struct CalibrateOptions {
  std::string points_path;
  std::optional<double> sphere_radius_mm;  ///< overrides the file's header
  std::optional<double> probe_offset_mm;   ///< overrides the file's header
  std::string json_path;                   ///< JSON report ("-" for stdout), empty: none
  std::string output_path;                 ///< calibration file, empty: none
  double max_std_um = 10.0;
  int max_iterations = 100;
  bool quiet = false;                            ///< no text report on stdout
  bool no_trace = false;                         ///< fit the seven errors only, no residual tracing
  bool hold_confounded = false;                  ///< add neither of two effects the data cannot tell apart
  std::vector<std::string> effects;              ///< a fixed model: these effects, no selection
  std::string validate_path;                     ///< another sphere measured on the same machine
  std::string plot_dir;                          ///< residual plots (PNG, gnuplot) into this folder
  double plot_timeout_s = kDefaultPlotTimeoutS;  ///< gnuplot is stopped after this long
  int harmonics = 0;                             ///< highest harmonic order searched; 0: what the pattern resolves
  int drift_order = 2;                           ///< highest power of time of probe_drift
  double phi_wobble_pivot_mm = 0.0;              ///< where the Phi axis pivots, along it (the drawing's) [mm]
  std::uint64_t seed = 1;                        ///< of the cross-validation folds
  SphereConditions conditions;                   ///< uncertainty inputs; override the file's header
  std::optional<double> coverage;                ///< coverage probability of U (default: k = 2)
  ProgressMode progress = ProgressMode::kAuto;   ///< progress on stderr
};

void SetupCalibrateApp(CLI::App& app, CalibrateOptions& options);

/// Runs a calibration; the text report goes to `out`, errors and notes to `err`.
/// Returns kExitOk, kExitNotUsable or kExitBadInput.
int RunCalibrate(const CalibrateOptions& options, std::ostream& out, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_CALIBRATE_CMD_HPP_
