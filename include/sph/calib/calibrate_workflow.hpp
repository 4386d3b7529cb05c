// The calibration workflow in one call (what sph_calibrate does, for a host program): the points'
// header merged with the options, the seven errors, the residual traced to further effects (or a
// fixed set of effects fitted), the sphere's form, the GUM budget, the validation on another file,
// the comparison with an earlier calibration and the calibration file's content, all in one result
// that renders the reports.
#ifndef SPH_CALIB_CALIBRATE_WORKFLOW_HPP_
#define SPH_CALIB_CALIBRATE_WORKFLOW_HPP_

#include <functional>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "sph/calib/budget.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/calib/known_form.hpp"
#include "sph/calib/report.hpp"
#include "sph/calib/statements.hpp"
#include "sph/calib/usability.hpp"
#include "sph/core/ranges.hpp"
#include "sph/io/calibration_comparison.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/dcc.hpp"
#include "sph/io/points_file.hpp"
#include "sph/select/trace.hpp"
#include "sph/select/trace_report.hpp"

namespace sph {

/// The ranges of the workflow's integer settings (the others: sph/core/ranges.hpp).
namespace ranges {
inline constexpr ValidRange kMaxIterations{1.0, 100000.0, ""};
inline constexpr ValidRange kHarmonicOrder{0.0, 12.0, ""};  ///< TraceOptions::harmonics, each axis
inline constexpr ValidRange kDriftOrder{1.0, 3.0, ""};      ///< TraceOptions::drift_order
}  // namespace ranges

/// What a calibration run takes besides the points. The defaults are the fit's and the trace's own
/// (CalibrationOptions, TraceOptions); sph_calibrate's options are these fields.
struct CalibrationWorkflowOptions {
  std::optional<double> sphere_radius_mm;  ///< R0 at 20 deg C; overrides the points' header [mm]
  std::optional<double> probe_offset_mm;   ///< nominal d; overrides the points' header [mm]
  /// The fit's settings: max_std_um, max_iterations, the parameters held (`fixed`) and informed
  /// (`priors`), which win over the points' header's "fix" and "prior" for a parameter both name, a
  /// robust loss (only without the trace's selection: trace false or `effects` given), ... The radii
  /// and d are the workflow's, from the two fields above or the header, R0 corrected to the
  /// measuring temperature.
  CalibrationOptions fit;
  bool trace = true;  ///< trace the residual to the effects the model lacks; false: the seven errors only
  /// The trace's settings: harmonics, drift_order, seed, hold_confounded, phi_wobble_pivot_mm,
  /// progress, ... (probe_range_mm is the workflow's: conditions.probe_range_mm, else the header's).
  TraceOptions trace_options;
  std::vector<Effect> effects;     ///< a fixed model: these effects fitted, no selection (needs trace)
  std::string validate_path;       ///< another points file of the machine, compensated before and after (needs trace)
  /// An earlier calibration file of the machine (sph_calibrate -o): this run's calibration compared
  /// with it like with like (CompareWithEarlier()); read before the fit. The comparison informs: it
  /// does not change the calibration nor whether it is usable.
  std::string compare_path;
  /// Calibration files each holding a sphere's form (made from a run that separated it): the form
  /// enters the fit as known within its covariance (FormPriorOfFile(), needs trace). Each file
  /// belongs to the sphere of the points whose radius is its R0 within their standard
  /// uncertainties (the reference sphere's R0 and sphere_radius_u_um; another sphere's
  /// sphere_radius_mm@<setup>, u 0); a file that matches none of them or more than one, two files
  /// of one sphere, another sphere's form without the reference sphere's known (by a file or the
  /// certificate) or whose setups are all of unknown orientation are refused (sph::Error with the
  /// radii). With one sphere in the points a file's R0 must be the points' (CheckSameSphere()). A
  /// sphere's setups of known orientation share its known form, each through its mount rotation; a
  /// setup of unknown orientation keeps a form of its own. With conditions.sphere_form_rms_um (or
  /// the header's) too, the certificate is checked against the reference sphere's known form;
  /// without a file of the reference sphere, that bound is its prior (CertificateFormPrior(),
  /// degrees 2 to FormDegreeLimit()).
  std::vector<std::string> sphere_form_paths;
  /// A statement the readings reject (sph/calib/statements.hpp) makes the calibration not usable;
  /// true: the lab insists on its statements, a rejected one does not, and the report and the
  /// calibration file say that it was accepted against the readings. Either way the trace adds
  /// nothing on top of a rejected statement.
  bool accept_rejected = false;
  /// What "usable" is judged against (sph/calib/usability.hpp): the lab's targets or max_std_um
  /// stated; else the default, whose reference the workflow predicts for the run's set-up.
  UsabilityRequirement requirement;
  /// When the readings reject a known form, search the mount orientation they support
  /// (SupportedOrientationOf()); false: only test the stated one.
  bool search_orientation = true;
  SphereConditions conditions;     ///< the uncertainty inputs and the probe range; override the header's
  std::optional<double> coverage;  ///< coverage probability of U; empty: k = 2
  std::string program;             ///< the reports' "program"; empty: "sph_calibrate <version>"
  /// Told each stage as it starts ("calibrating the seven errors") and each warning as it is found
  /// (the result keeps the warnings too); either may be empty.
  std::function<void(const std::string& stage)> on_stage;
  std::function<void(const std::string& warning)> on_warning;

  /// Throws sph::Error naming the first setting that is out of its range (sph::ranges) or needs
  /// another: "calibration options: fit.max_std_um: must be > 0 and <= 1e+06 um, got 0".
  void Check() const;
};

/// A calibration run: its inputs as used and every result. The reports and the calibration file
/// are rendered from it.
struct CalibrationWorkflowResult {
  PointsData points;
  std::string points_path;      ///< as the reports name it
  CalibrationOptions settings;  ///< the fit's settings as used (radii, d, ...)
  CalibrationInputs inputs;     ///< the Type B inputs: the header's, then the options'
  std::optional<double> probe_range_mm;
  std::string program;
  CalibrationResult seven;                  ///< the seven-error fit
  std::optional<TraceResult> trace;         ///< when traced (or a fixed set of effects fitted)
  std::optional<Validation> validation;     ///< when a validation file was given
  std::optional<CalibrationBudget> budget;  ///< none when the fit was not analysed or a refit failed
  /// The comparison with an earlier calibration, when compare_path was given.
  std::optional<CalibrationComparison> comparison;
  /// With a known form (sphere_form_paths or the certificate's bound) and a trace: how the readings
  /// agree with the reference sphere's.
  std::optional<KnownFormCheck> known_form;
  /// The same for each other sphere whose known form was given, by its first setup.
  std::vector<KnownFormCheck> other_known_forms;
  /// Every statement of the lab tested against the readings (sph/calib/statements.hpp): the known
  /// forms, the certificate's bound when it is the prior, the priors and fixed values, the earlier
  /// model of the comparison.
  std::vector<StatementCheck> statements;
  /// Where each prior or fixed value came from, by parameter: "--prior", "--fix" or "the header of
  /// <points>".
  std::map<std::string, std::string> statement_origins;
  /// The effects the trace had added beside a statement the readings reject: not applied (the
  /// reported calibration is the model of the statements alone); empty otherwise.
  std::vector<Effect> withheld;
  std::vector<std::string> warnings;  ///< the readings' plausibility, the budget's absence, the statements
  /// What "usable" was judged against: the options' requirement, with the default's reference when
  /// neither targets nor max_std_um were stated.
  UsabilityRequirement requirement;
  /// When the seven-error fit fails as a misreading makes it fail: what the readings show was
  /// misread (LikelyMisreading()'s Reason()), the last of the usability's reasons; else "".
  std::string likely_cause;
  Usability usability;

  /// Whether the reported calibration is the trace's (it added effects or a form).
  bool Extended() const;
  /// The calibration reported: the trace's final fit when Extended(), else the seven errors.
  const CalibrationResult& Reported() const;
  /// The reports' context (points into this result: do not keep it past a move).
  ReportContext Context() const;
  void WriteTextReport(std::ostream& out) const;
  std::string JsonReport() const;
  /// The report as one self-contained HTML document (sph/io/html_report.hpp): its numbers are
  /// JsonReport()'s, with the date it was made, the points file's header fields (escaped) and the
  /// residual map as inline SVG.
  std::string HtmlReport() const;
  /// The Digital Calibration Certificate (sph/io/dcc.hpp; docs/dcc.md): the SCMS and its devices
  /// as the items, the reference sphere with its certificate as the equipment, the model, R0 and the
  /// temperature as the conditions, the seven errors, the effects, the form and the comparison as
  /// results, JsonReport()'s numbers in SI units rounded as GUM 7.2.6 states them. Throws
  /// sph::Error naming each administrative key that `lab` (the laboratory's settings) and the points header lack.
  std::string Dcc(const dcc::Settings& lab) const;
  /// The calibration file for compensation: the seven errors, the trace's effects but
  /// probe_drift (`*drift_left_out` says whether one was left out), the covariance. Throws
  /// sph::Error when the calibration is not usable.
  CalibrationFile MakeCalibrationFile(bool* drift_left_out = nullptr) const;
};

/// `run`'s calibration compared with an earlier calibration file of the machine (`previous`, named
/// `previous_source`), like with like (what the workflow does with compare_path, `options` its
/// own): CompareCalibrations() of run's calibration file; when the two files' models differ (other
/// parameters: effects, their components, the form's terms, the drift's powers), today's readings
/// are fitted again with the earlier model (FitGivenModel(): its effects with their components, a
/// drift of its probe_drift_powers, its form's terms, its probe terms' normalisation), with their
/// budget, and the verdict is taken on that comparison, today's own
/// model's beside it (LikeForLike()). When the earlier model cannot be fitted to today's readings
/// (the fit fails, or its calibration is not usable: a parameter undetermined, no budget), today's
/// own model is compared and the comparison says why (NotLikeForLike()). Throws sph::Error as
/// CheckComparable().
CalibrationComparison CompareWithEarlier(const CalibrationWorkflowResult& run, const CalibrationFile& previous,
                                         const std::string& previous_source,
                                         const CalibrationWorkflowOptions& options);

/// The mount orientation the readings of `run` support for a known form they reject: the reference
/// sphere's (`prior_setup` < 0) or another sphere's (its key in run.settings.other_form_priors).
/// Each setup of known orientation of that sphere in turn: FitMountRotation() (the 24 turns by
/// right angles, then refined with the form held); the best setup's fitted rotation is then
/// stated in place of the file's and the workflow run again (`options`, without the comparison,
/// the validation and this search), whose test of the same statement gives the p-value.
SupportedOrientation SupportedOrientationOf(const CalibrationWorkflowResult& run,
                                            const CalibrationWorkflowOptions& options, int prior_setup);

/// Runs the workflow on the points file `points_path` (read with ReadPointsFile()). Throws
/// sph::Error on bad input: a setting out of range, R0 or d given nowhere, a reading beyond the
/// probe's range, a fit that fails, an unreadable validation file, a compare file that is no
/// calibration file or one of another nominal d (CheckComparable()).
CalibrationWorkflowResult RunCalibrationWorkflow(const std::string& points_path,
                                                 const CalibrationWorkflowOptions& options);

/// The same on points already read; `points_path` names them in messages and reports.
CalibrationWorkflowResult RunCalibrationWorkflow(PointsData points, const std::string& points_path,
                                                 const CalibrationWorkflowOptions& options);

}  // namespace sph

#endif  // SPH_CALIB_CALIBRATE_WORKFLOW_HPP_
