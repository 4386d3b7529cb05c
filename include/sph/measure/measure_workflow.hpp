// The measurement workflow in one call (what sph_measure does, for a host program): readings
// compensated with a calibration file (or x y z points taken as they are), the least-squares and
// minimum-zone spheres, the uncertainty by sampling the calibration's covariance, the noise floor
// of the form values, the GUM budget of each result with its JCGM 101 check, in one result that
// renders the text and JSON reports.
#ifndef SPH_MEASURE_MEASURE_WORKFLOW_HPP_
#define SPH_MEASURE_MEASURE_WORKFLOW_HPP_

#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/io/dcc.hpp"
#include "sph/io/setup_checks.hpp"
#include "sph/measure/noise_floor.hpp"
#include "sph/measure/sphere_measurement.hpp"
#include "sph/model/compensation.hpp"
#include "sph/stats/gum.hpp"

namespace sph {

/// What a measurement takes besides the points; sph_measure's options are these fields.
struct MeasurementWorkflowOptions {
  bool xyz = false;  ///< the points file holds x y z [mm] (plain or NIST .ds), no calibration
  /// The points are of the calibration sphere itself: its form, which the calibration file holds,
  /// is taken off each point along the radius before the sphere is evaluated.
  bool subtract_sphere_form = false;
  std::string calibration_path;    ///< calibration file (JSON); required for readings
  std::optional<int> setup;        ///< which setup of a multi-setup points file
  int uncertainty_samples = 200;   ///< calibration draws; 0: no uncertainty (1 is refused)
  std::uint64_t seed = 1;          ///< of the calibration draws, the noise floor and the check
  double max_dilution = 10.0;      ///< coverage limit, see SphereEvaluationOptions
  std::optional<double> noise_um;  ///< the probe's noise for the noise floor; default: the calibration's fit rms
  int noise_floor_draws = 50;      ///< simulated measurements of pure noise; 0: no noise floor
  std::optional<double> coverage;  ///< coverage probability of U; empty: k = 2
  long mc_max_trials = 100000;     ///< JCGM 101 check of the sphericities: at most this many trials; 0: none
  long mc_batch_trials = 1000;     ///< trials per batch of the adaptive procedure
  int mc_digits = 1;               ///< significant digits of u that set the check's numerical tolerance
  long mc_max_points = 2000;       ///< the check is run for at most this many points (its cost grows with them)
  std::string program;             ///< the reports' program; empty: "sph_measure <version>"
  /// Told how far the run is: a stage (total 0) or `done` of `total` of it; may be empty.
  std::function<void(const std::string& stage, long done, long total)> on_progress;
  /// Told each warning on the readings as it is found (the result keeps them too); may be empty.
  std::function<void(const std::string& warning)> on_warning;

  /// Throws sph::Error naming the first setting out of its range.
  void Check() const;
};

/// What was read: the points to evaluate and, for readings, what compensated them.
struct MeasuredPoints {
  std::vector<Eigen::Vector3d> points_mm;
  std::vector<RawReading> readings;           ///< empty for x y z input
  std::optional<AppliedCalibration> applied;  ///< what compensated them, with its covariance
  std::string covariance_note;                ///< what of the calibration goes without its uncertainty
  std::optional<int> setup;
  std::optional<StatedSphereRadius> header_radius;  ///< the radius the points file states for the setup's sphere
  std::string description;                          ///< one line for the report
  std::string form_note;                            ///< what the calibration file says of the calibration sphere's form
  std::vector<std::string> warnings;                ///< readings that parse but look wrong (PlausibilityWarnings)
  std::optional<double> calibration_fit_rms_um;     ///< the calibration file's source.fit_rms_um
  /// The points file's header fields beyond those read (PointsHeader::metadata); none for x y z input.
  std::vector<std::pair<std::string, std::string>> metadata;
  /// The calibration file's "source" (the points file it was made from, its header's fields).
  std::vector<std::pair<std::string, std::string>> calibration_source;
};

/// The noise floor of the form values, or why there is none.
struct MeasurementNoiseFloor {
  std::optional<FormNoiseFloor> floor;
  std::string sigma_source;  ///< where sigma came from
  std::string note;          ///< why there is none
};

/// The GUM budget of one result, with its JCGM 101 check.
struct MeasuredResultBudget {
  MeasuredResult which;
  const char* name;  ///< as in the report: radius_mm, sphericity_ls_um, ...
  const char* key;   ///< of the JSON
  double value_mm = 0.0;
  gum::UncertaintyStatement statement;
  std::optional<gum::PropagationResult> mc;  ///< the JCGM 101 check, for the sphericities
  std::string mc_note;                       ///< why there is none
};

/// The budgets of the radius and the two sphericities.
struct MeasurementBudgets {
  std::vector<MeasuredResultBudget> results;
  gum::CoverageSpec coverage;
  std::string type_a_form_note;  ///< where the sphericities' Type A comes from, or why there is none
};

/// A measurement: its inputs as used and every result; the reports are rendered from it.
struct MeasurementWorkflowResult {
  std::string points_path;
  MeasurementWorkflowOptions options;
  MeasuredPoints input;
  SphereEvaluation evaluation;
  std::optional<CalibrationUncertainty> uncertainty;  ///< by sampling the calibration's covariance
  std::string uncertainty_note;                       ///< why there is none
  MeasurementNoiseFloor noise_floor;
  MeasurementBudgets budgets;

  std::string Program() const;
  void WriteTextReport(std::ostream& out) const;
  std::string JsonReport() const;
  /// The report as one self-contained HTML document (sph/io/html_report.hpp): its numbers are
  /// JsonReport()'s, with the date it was made and the form map as embedded SVG.
  std::string HtmlReport() const;
  /// The Digital Calibration Certificate (sph/io/dcc.hpp; docs/dcc.md): the sphere as the item, the
  /// SCMS with its calibration as the equipment, the radius and the sphericities with their U as
  /// results, JsonReport()'s numbers in SI units rounded as GUM 7.2.6 states them. Throws
  /// sph::Error naming each administrative key that `lab` (the laboratory's settings) and the points header lack.
  std::string Dcc(const dcc::Settings& lab) const;
  /// The form-error map as a gnuplot script (data inline): the radial residuals about the
  /// least-squares sphere over the sphere, azimuth about a pole against the angle from it, colour
  /// the residual [um]. The pole is the z axis (for an SCMS the Theta axis, so that the map is the
  /// machine's theta/phi) unless the points form a cap, then centred at the top of the map. It
  /// draws to the variable `png` when that is set (gnuplot -e), else to `png_path`.
  std::string FormMapScript(const std::string& png_path) const;
  /// The compensated points (x_mm y_mm z_mm) with a header naming their source.
  void WritePoints(std::ostream& out) const;
};

/// Runs the measurement of `points_path`. Throws sph::Error on bad input: a file that cannot be
/// read, readings without a calibration, a setup that is not there, a calibration of another d.
MeasurementWorkflowResult RunMeasurementWorkflow(const std::string& points_path,
                                                 const MeasurementWorkflowOptions& options);

/// The same of readings in memory (a host's, sph::PointsFromColumns()), which `source` names in
/// the messages and reports as a path would; options.xyz is refused (it reads a file).
MeasurementWorkflowResult RunMeasurementWorkflow(PointsData points, const std::string& source,
                                                 const MeasurementWorkflowOptions& options);

}  // namespace sph

#endif  // SPH_MEASURE_MEASURE_WORKFLOW_HPP_
