// sph_measure: options, CLI set-up and the run function (unit-tested directly).
//
// Measures a sphere: compensates raw readings with a calibration (or takes x y z coordinates),
// fits the least-squares sphere, evaluates least-squares and minimum-zone sphericity, judges the
// coverage, propagates the calibration's covariance, and draws a form-error map.
#ifndef SPH_APPS_MEASURE_CMD_HPP_
#define SPH_APPS_MEASURE_CMD_HPP_

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>

#include "cli_fwd.hpp"

#include "gnuplot.hpp"
#include "progress.hpp"

namespace sph::apps {

struct MeasureOptions {
  std::string points_path;  ///< sph-points 1 readings, or x y z coordinates with xyz
  bool xyz = false;         ///< points_path holds x y z [mm] (plain or NIST .ds)
  /// The points are of the calibration sphere itself: its form, which the calibration file holds,
  /// is taken off each point along the radius before the sphere is evaluated.
  bool subtract_sphere_form = false;
  std::string calibration_path;                  ///< calibration file (JSON); required for readings
  std::optional<int> setup;                      ///< which setup of a multi-setup points file
  std::string json_path;                         ///< JSON report ("-" for stdout), empty: none
  std::string output_path;                       ///< compensated points (x_mm y_mm z_mm), empty: none
  std::string plot_path;                         ///< form-error map (PNG, drawn by gnuplot), empty: none
  std::string plot_script_path;                  ///< the gnuplot script of the map, empty: none
  std::string gnuplot = "gnuplot";               ///< the gnuplot program
  double plot_timeout_s = kDefaultPlotTimeoutS;  ///< gnuplot is stopped after this long
  int uncertainty_samples = 200;                 ///< calibration draws; 0: no uncertainty
  std::uint64_t seed = 1;                        ///< of the calibration draws
  double max_dilution = 10.0;                    ///< coverage limit, see SphereEvaluationOptions
  bool quiet = false;                            ///< no text report on stdout (warnings still go to stderr)
  std::optional<double> noise_um;  ///< the probe's noise for the noise floor; default: the calibration's fit rms
  int noise_floor_draws = 50;      ///< simulated measurements of pure noise; 0: no noise floor
  std::optional<double> coverage;  ///< coverage probability of U (default: k = 2)
  long mc_max_trials = 100000;     ///< JCGM 101 check of the sphericities: at most this many trials; 0: none
  long mc_batch_trials = 1000;     ///< trials per batch of the adaptive procedure
  int mc_digits = 1;               ///< significant digits of u that set the check's numerical tolerance
  long mc_max_points = 2000;       ///< the check is run for at most this many points (its cost grows with them)
  ProgressMode progress = ProgressMode::kAuto;  ///< progress on stderr
};

void SetupMeasureApp(CLI::App& app, MeasureOptions& options);

/// Runs a measurement; the text report goes to `out`, errors and warnings to `err`.
/// Returns kExitOk or kExitBadInput.
int RunMeasure(const MeasureOptions& options, std::ostream& out, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_MEASURE_CMD_HPP_
