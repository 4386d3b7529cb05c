// Evaluation of a measured sphere: least-squares sphere, least-squares and minimum-zone
// sphericity, how well the coverage determines them, and how much of the result the calibration's
// own uncertainty can explain. The mathematics is in sph::sphere (sph/sphere/sphere_fit.hpp,
// sph/sphere/sphere_form.hpp); this adds the judgement (warnings) and the uncertainty: the
// calibration's covariance propagated by sampling (every parameter the measurement applies drawn
// from their joint covariance, the readings compensated again with each draw), the GUM budget of
// radius and sphericities with its linear sensitivities, and its check by the adaptive Monte Carlo
// method of JCGM 101. What each statement means: docs/method/uncertainty.md and
// docs/method/sphere-evaluation.md. Units: mm, unless a name says otherwise.
#ifndef SPH_MEASURE_SPHERE_MEASUREMENT_HPP_
#define SPH_MEASURE_SPHERE_MEASUREMENT_HPP_

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/io/calibration_file.hpp"
#include "sph/stats/gum.hpp"
#include "sph/io/points_file.hpp"
#include "sph/model/compensation.hpp"
#include "sph/model/form_model.hpp"
#include "sph/sphere/sphere_fit.hpp"
#include "sph/sphere/sphere_form.hpp"

namespace sph {

struct SphereEvaluationOptions {
  /// Warn (poorly_determined) when the radius or the centre is determined more than this many
  /// times worse than by the same number of points over the whole sphere (see
  /// LeastSquaresSphere::RadiusDilution: 10 is an evenly covered cap of half-angle about 45 deg).
  double max_dilution = 10.0;
  /// The minimum zone is searched from several starts (FitSphereMinimumZoneMultiStart) when the
  /// points lie within this half-angle of their mean direction (a cap or a hemisphere), or when
  /// one search does not certify it to mz_slack_mm over its whole near region.
  double multi_start_cap_deg = 135.0;
  /// The slack to which the minimum zone's certificate is stated (1 nm).
  double mz_slack_mm = 1e-6;
};

/// Everything measured about one sphere; lengths in mm.
struct SphereEvaluation {
  int n_points = 0;
  LeastSquaresSphere ls;             ///< ls.sphere.center, ls.sphere.radius [mm]
  std::vector<double> residuals_mm;  ///< radial residuals about the least-squares sphere, in point order
  double sphericity_ls_mm = 0.0;     ///< peak-to-valley of residuals_mm
  MinimumZoneSphere mz;              ///< minimum-zone centre, radii, width and certificate [mm]
  SphereCoverage coverage;           ///< about the least-squares centre
  double radius_dilution = 0.0;      ///< LeastSquaresSphere::RadiusDilution()
  double center_dilution = 0.0;      ///< LeastSquaresSphere::CenterDilution()
  /// Standard uncertainty of radius and centre from the scatter of the points about the sphere,
  /// s sqrt(diag((J^T J)^-1)), s^2 = sum e_i^2 / (n - 4) (0 when n == 4). It counts the form error
  /// as noise: a measure of how well this point set fixes the sphere, not a calibration statement.
  double radius_fit_std_mm = 0.0;
  Eigen::Vector3d center_fit_std_mm = Eigen::Vector3d::Zero();
  bool poorly_determined = false;     ///< the coverage leaves centre and radius poorly determined
  std::vector<std::string> warnings;  ///< plain-language, for the user
};

/// The largest coordinate of a measured point that EvaluateSphere() takes [mm]: 1 km, beyond any
/// measuring machine (a larger one is in another unit, or not a measurement).
inline constexpr double kMaxPointCoordinateMm = 1e6;

/// Evaluates points measured on a sphere. `source` names them in messages. Throws sph::Error,
/// naming the point, when a point is not finite or lies beyond kMaxPointCoordinateMm, and when
/// the points determine no sphere (fewer than four, all one point, or all on one plane or line).
SphereEvaluation EvaluateSphere(const std::vector<Eigen::Vector3d>& points_mm, const std::string& source,
                                const SphereEvaluationOptions& options = SphereEvaluationOptions());

/// The calibration sphere's own form, taken off compensated points of that sphere (sph_measure
/// --subtract-sphere-form): each point p moves along its direction u = (p - center) / |p - center|
/// by -F(R^T u) (sph/model/form_model.hpp).
struct FormCorrection {
  std::vector<FormTerm> terms;
  std::vector<double> values_mm;                           ///< one coefficient per term [mm]
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< body frame into the Theta frame (the mount)
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();     ///< where the directions are taken from
  bool Empty() const { return terms.empty(); }
};

/// The rotation R (FormCorrection::rotation) of the calibration sphere as it sat on its mount in
/// `setup` of a points file (`points_name` names it in messages): its mount_rotation_deg@<setup>,
/// the identity without one. Throws sph::Error when the setup measured another sphere
/// (sphere_radius_mm@<setup>: the calibration file's form is not that sphere's), when its
/// orientation is unknown, or when the rotation is not finite.
Eigen::Matrix3d CalibrationSphereRotation(const PointsHeader& header, int setup, const std::string& points_name);

/// Takes the form off `points_mm` with the coefficients `values_mm` (one per term).
void SubtractForm(const FormCorrection& form, const double* values_mm, std::vector<Eigen::Vector3d>& points_mm);

/// What a measurement applies of its calibration, with the joint covariance of all of it.
struct AppliedCalibration {
  Calibration calibration;  ///< the seven errors and the effects (its own 7 x 7 covariance is not used here)
  FormCorrection form;      ///< taken off the points when not empty
  /// Covariance (rad, mm) of the parameters applied, in this order: the seven errors, the effects'
  /// parameters (term, then component order) when effects_in_covariance, the form's coefficients
  /// when form_in_covariance. Empty: no covariance.
  Eigen::MatrixXd covariance;
  bool effects_in_covariance = false;
  bool form_in_covariance = false;
  std::vector<std::string> names;  ///< of the covariance's parameters
  /// The Type B inputs the covariance holds (sized as it), when the calibration file says.
  std::vector<CalibrationFile::CovarianceInput> inputs;
  double type_a_dof = gum::kInfiniteDof;  ///< of the covariance's Type A part

  /// The covariance less its Type B inputs: the calibration's Type A part A = C - sum_j s_j s_j^T u_j^2.
  Eigen::MatrixXd TypeACovariance() const;
  /// The parameters applied and their covariance, from a calibration file; `with_form`: the
  /// file's form is taken off the points (then `form` is to be completed by the caller with the
  /// mount rotation and centre).
  static AppliedCalibration Of(const CalibrationFile& file, bool with_form);
};

/// The points of `readings` under the calibration `applied` with its parameters moved by `delta`
/// (covariance order; nullptr: none) and the probe readings scaled by 1 + `probe_scale`.
std::vector<Eigen::Vector3d> ApplyCalibration(const AppliedCalibration& applied,
                                              const std::vector<RawReading>& readings,
                                              const Eigen::VectorXd* delta = nullptr, double probe_scale = 0.0);

/// The results of a sphere that a budget is made for.
enum class MeasuredResult { kRadius, kSphericityLs, kSphericityMz };

/// The Type B input of a calibration file that scales the probe readings (sph/calib/budget.hpp):
/// it acts on the measurement's readings as well.
inline constexpr const char* kProbeScaleInput = "probe scale";

/// A result of `points` [mm]: the least-squares radius, peak-to-valley of its residuals, or the
/// minimum-zone width; `start`: a sphere near theirs.
double MeasuredValue(MeasuredResult which, const std::vector<Eigen::Vector3d>& points, const Sphere& start);

/// Linear sensitivities of one result: to each parameter of the covariance (mm per rad or mm, by
/// central differences with steps of a tenth of the parameter's standard uncertainty; 0 for a
/// parameter of zero variance) and to the probe's relative scale through this measurement's
/// readings alone [mm].
struct ResultSensitivity {
  Eigen::VectorXd per_parameter;
  double per_probe_scale = 0.0;
};
/// The sensitivities of radius, least-squares and minimum-zone sphericity, in MeasuredResult order.
std::array<ResultSensitivity, 3> SensitivitiesOf(const std::vector<RawReading>& readings,
                                                 const AppliedCalibration& applied, const SphereEvaluation& nominal);

/// The budget of one result: `type_a_u` [mm] and `type_a_dof` of the measurement's own scatter
/// (named `type_a_name`), then the calibration's Type A part and each Type B input it holds, or
/// the calibration's covariance as one input when the file does not say what it holds.
gum::UncertaintyStatement MeasurementBudget(const std::string& type_a_name, double type_a_u, double type_a_dof,
                                            const ResultSensitivity& c, const AppliedCalibration& applied,
                                            const gum::CoverageSpec& coverage);

/// JCGM 101 adaptive Monte Carlo check of a result's statement: the calibration's Type A part
/// drawn from its covariance, each Type B input from a Gaussian of its u (through the calibration
/// and, for the probe scale, the readings), the measurement's own Type A as an additive t
/// variable of std `type_a_u` and `type_a_dof` (Gaussian when infinite), the result evaluated for
/// each draw. `options.probability`: the coverage probability of the statement checked.
gum::PropagationResult CheckByMonteCarlo(MeasuredResult which, const std::vector<RawReading>& readings,
                                         const AppliedCalibration& applied, const SphereEvaluation& nominal,
                                         double type_a_u, double type_a_dof, const gum::PropagationOptions& options);

struct UncertaintyOptions {
  int samples = 200;       ///< calibration draws (the std of a std from 200 draws is about 5 %)
  std::uint64_t seed = 1;  ///< of the sph::Random that draws them
  int threads = 0;         ///< draws evaluated in parallel; 0: one per hardware thread (same result)
  /// Called with (draws done, draws) as they finish (from the evaluating threads, one at a time).
  std::function<void(int, int)> progress;
};

/// What the calibration's covariance means for one measured sphere (docs/method/uncertainty.md); mm.
struct CalibrationUncertainty {
  int samples = 0;
  std::uint64_t seed = 0;
  double radius_std_mm = 0.0;
  Eigen::Vector3d center_std_mm = Eigen::Vector3d::Zero();
  double sphericity_ls_std_mm = 0.0;
  double sphericity_mz_std_mm = 0.0;
  double calibration_form_p95_mm = 0.0;
  bool form_exceeds_calibration = false;  ///< the measured sphericity_ls exceeds calibration_form_p95_mm
};

/// Propagates cal.covariance to the evaluation `nominal` of `readings` compensated with `cal`.
/// Throws std::invalid_argument when the calibration has no covariance or samples < 2.
CalibrationUncertainty PropagateCalibrationUncertainty(const std::vector<RawReading>& readings, const Calibration& cal,
                                                       const SphereEvaluation& nominal,
                                                       const UncertaintyOptions& options = UncertaintyOptions());

/// The same for every parameter `applied` holds the covariance of (effects and form too); with
/// its Type B inputs, each is drawn on its own, and the probe scale scales the readings as well.
CalibrationUncertainty PropagateCalibrationUncertainty(const std::vector<RawReading>& readings,
                                                       const AppliedCalibration& applied,
                                                       const SphereEvaluation& nominal,
                                                       const UncertaintyOptions& options = UncertaintyOptions());

}  // namespace sph

#endif  // SPH_MEASURE_SPHERE_MEASUREMENT_HPP_
