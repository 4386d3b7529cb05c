// Calibration of the seven geometric errors from points measured on a reference sphere.
//
// Minimises
//   S = sum_i (|p_sphere(g; theta_i, phi_i, r_i) - O_setup(i)| - R_setup(i))^2
// over g (seven errors) and one centre O per setup, by Ceres' Levenberg-Marquardt (ceres::Solve)
// on the hand-derived gradient (docs/architecture.md, "The solver"); the errors start at
// zero (the paper's initial guess) and each centre at an algebraic sphere fit of that setup's
// nominal-model points. Outliers and the analysis: docs/method/model.md.
//
// Plain C++ API: no Ceres type appears here. Units: rad and mm.
#ifndef SPH_CALIB_CALIBRATOR_HPP_
#define SPH_CALIB_CALIBRATOR_HPP_

#include <limits>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/calib/observability.hpp"
#include "sph/io/parameter_settings.hpp"
#include "sph/io/points_file.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/scms_model.hpp"

namespace sph {

/// Bounds of a parameter besides its physical ones (internal units: rad, mm; -inf or +inf where
/// it has none).
struct ParameterBound {
  std::string name;  ///< as FixedParameter::name
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
};

/// A robust loss of the readings' residuals, in place of least squares.
enum class RobustLoss {
  kNone,    ///< least squares
  kHuber,   ///< quadratic within the scale, linear beyond: a reading beyond it weighs scale / |e|
  kCauchy,  ///< log(1 + (e / scale)^2): a reading weighs 1 / (1 + (e / scale)^2)
};

/// A Gaussian prior on the reference sphere's form (sph/model/form_model.hpp): its coefficients on
/// the body frame known from an earlier separation (mean and covariance), or bounded by a
/// certificate (zero mean, CertificateFormPrior()). A fit whose model has a form adds the
/// whitened residual sigma L^-1 (c - mean), L L^T = covariance, on the coefficients of the setups
/// of known orientation (group 0; each setup sees them through its mount rotation), sigma the
/// readings' noise as for the priors on named parameters. Terms of the prior the model lacks are
/// left out of it (the marginal of the others).
struct FormPrior {
  std::vector<FormTerm> terms;
  Eigen::VectorXd mean_mm;         ///< one per term [mm]
  Eigen::MatrixXd covariance_mm2;  ///< symmetric positive definite, terms x terms [mm^2]
  bool Empty() const { return terms.empty(); }
};

/// The certificate's bound as a prior: zero mean, the same variance v for every coefficient of
/// degrees 2..l_max. The mean square of S_lm over the sphere is 1 / (2l + 1) and degree l has
/// 2l + 1 coefficients, so the expected mean square of the form is sum_l v = (l_max - 1) v: with
/// v = rms^2 / (l_max - 1) its expected RMS over the sphere is the bound, shared equally by the
/// degrees. `rms_mm` > 0, l_max >= 2.
FormPrior CertificateFormPrior(double rms_mm, int l_max);

struct CalibrationOptions {
  double sphere_radius_mm = 0.0;  ///< R0 (required, > 0)
  /// The setups that measured another sphere (a points file's "sphere_radius_mm@<setup>"), by
  /// setup id: that sphere's radius [mm]. Every setup the points' header names must be here: a fit
  /// does not take a radius from the header behind the caller's back (sph_calibrate corrects
  /// each radius to the measuring temperature as it does R0). Two spheres of different radii tell
  /// a probe's gain (its trace on a sphere goes as 1/R) from its incidence error (1/R^2).
  std::map<int, double> sphere_radii_mm;
  double probe_offset_mm = 0.0;   ///< nominal d (required, > 0)
  /// A parameter whose standard uncertainty, as a displacement of the probed point (lengths as
  /// they are, angles times R0), exceeds this is reported as undetermined [um].
  double max_std_um = 10.0;
  int max_iterations = 100;
  /// Compute the covariance, the observability analysis and the residual statistics. The Monte
  /// Carlo study switches it off when it only needs the estimates.
  bool analyse = true;
  ScmsGeometry initial_geometry{};  ///< start of the errors (rad, mm); the paper starts at zero
  /// A reading whose residual is farther than this many robust standard deviations (1.4826 times
  /// the median absolute deviation) from the median residual, both of its setup, is an outlier
  /// and is left out (a setup off as a whole is a model error, not outliers; RobustOutliers()):
  /// first judged at the start values, then under the fit of the readings kept, until the set of
  /// outliers no longer changes. The limit is at least 1 nm. 0 keeps every reading. Needs `analyse`.
  double outlier_sigma = 5.0;

  /// Parameters held at a value instead of fitted (sph/io/parameter_settings.hpp): reported as
  /// held, not with an uncertainty. A parameter of an effect holds where the fit's model has it.
  std::vector<FixedParameter> fixed;
  /// Gaussian priors from independent measurements: each adds the residual (p - value) sigma / u to
  /// the readings' (sigma: the readings' noise, prior_sigma_mm), and the uncertainty budget lists
  /// it as an input of its own. Not on a parameter also held.
  std::vector<ParameterPrior> priors;
  /// The readings' noise the priors are weighted with [mm]; 0: from the fit itself (the residual
  /// sigma of the readings and the priors together, found by refitting until it holds).
  /// CalibrationResult::prior_sigma_mm is the one used: refits of the same readings pass it on.
  double prior_sigma_mm = 0.0;
  /// The reference sphere's form as known (FormPrior), weighted with prior_sigma_mm as the priors
  /// are; only fits whose model has a form use it (sph/select/trace.hpp puts the form in the model
  /// from the start when it is given). Empty: none.
  FormPrior form_prior;
  /// The form as known of another sphere of the points (sphere_radii_mm), by one setup that
  /// measured it in a known orientation: a prior as form_prior's on the coefficients of that
  /// sphere's set (the set FormModelOf() gives the setup), shared by its setups of known
  /// orientation. Needs form_prior (a fit with a known form starts from the reference sphere's);
  /// the model's terms are those of all the priors, a term a prior lacks free in its set.
  std::map<int, FormPrior> other_form_priors;
  /// Bounds besides the physical ones, which every fit has: |alpha|, |beta|, |epsilon| below 90
  /// deg, d' above -d (the probe's zero beyond the axes' common point). A parameter that ends at a
  /// bound is reported as held there.
  std::vector<ParameterBound> bounds;
  /// A robust loss instead of least squares, with every reading kept at a weight, in place of the
  /// outlier rule (outlier_sigma is then not used). Its scale is robust_scale_sigma times the
  /// readings' noise, estimated as 1.4826 times the median absolute deviation of the residuals
  /// (each setup about its own median) and refitted until it holds.
  RobustLoss robust_loss = RobustLoss::kNone;
  /// The loss' scale in units of the noise; 0: the usual (Huber 1.345, Cauchy 2.385: 95 % of the
  /// efficiency of least squares on Gaussian noise).
  double robust_scale_sigma = 0.0;
  /// The noise the loss' scale is in units of [mm]; 0: estimated as above. Refits of the same
  /// readings pass the fit's on (CalibrationResult::robust_sigma_mm).
  double robust_sigma_mm = 0.0;

  /// Whether outliers are left out (outlier_sigma > 0 and no robust loss).
  bool LeavesOutOutliers() const { return outlier_sigma > 0.0 && robust_loss == RobustLoss::kNone; }

  /// The radius of the sphere measured in `setup`: its entry in sphere_radii_mm, else R0 [mm].
  double SphereRadiusMm(int setup) const {
    const auto it = sphere_radii_mm.find(setup);
    return it == sphere_radii_mm.end() ? sphere_radius_mm : it->second;
  }
};

/// A reading that a robust loss weighted down.
struct WeightedReading {
  std::size_t sample = 0;    ///< index in the points file's samples (0-based, file order)
  double weight = 1.0;       ///< rho'(e^2): what it counts for against a reading within the scale
  double residual_um = 0.0;  ///< its residual under the fit
};

/// A reading left out of the fit as an outlier.
struct Outlier {
  std::size_t sample = 0;    ///< index in the points file's samples (0-based, file order)
  double residual_um = 0.0;  ///< its residual under the final fit
};

/// The outcome of one calibration.
struct CalibrationResult {
  ScmsGeometry geometry{};                  ///< estimated errors (rad, mm)
  std::vector<int> setup_ids;               ///< ascending; centres_mm[k] belongs to setup_ids[k]
  std::vector<Eigen::Vector3d> centers_mm;  ///< estimated sphere centre of each setup
  /// |p - O| - R of each sample, R the radius of its setup's sphere, in file order (outliers too)
  std::vector<double> residuals_mm;
  double rms_um = 0.0;                      ///< residual RMS of the readings fitted
  double pv_um = 0.0;                       ///< residual peak to valley of the readings fitted
  int n_points = 0;                         ///< readings fitted (outliers not counted)
  std::vector<Outlier> outliers;            ///< readings left out, in file order
  /// Under a robust loss: the readings it weighted down (weight below 1), in file order, the noise
  /// it estimated and its scale [mm].
  std::vector<WeightedReading> weighted;
  RobustLoss robust_loss = RobustLoss::kNone;
  double robust_sigma_mm = 0.0;
  double robust_scale_mm = 0.0;
  /// The readings' noise the priors were weighted with [mm] (0 without priors).
  double prior_sigma_mm = 0.0;
  int iterations = 0;
  bool converged = false;
  std::string solver_message;  ///< the solver's termination message
  /// Uncertainties, correlations and identifiability; parameters in the order: the seven errors,
  /// then center_x, center_y, center_z of each setup. Empty when options.analyse is false.
  ObservabilityReport analysis;
  /// Plain-language warnings: undetermined parameters and why, no convergence, a poor design.
  std::vector<std::string> warnings;

  /// Converged and every parameter determined.
  bool Usable() const;
};

/// Jacobian of the residuals |p_i - O_setup(i)| - R_setup(i) with respect to the parameters, at the given
/// errors (rad, mm) and centres (one per setup, in ascending setup id order). Rows in file order;
/// columns: the seven errors, then x, y, z of each setup's centre.
Eigen::MatrixXd ResidualJacobian(const PointsData& points, const CalibrationOptions& options,
                                 const ScmsGeometry& geometry, const std::vector<Eigen::Vector3d>& centers_mm);

/// Calibrates from the samples of `points`, leaving out outliers (options.outlier_sigma). Throws
/// sph::Error on unusable input (radius or offset not positive, fewer samples than parameters, a
/// setup whose points determine no centre).
CalibrationResult Calibrate(const PointsData& points, const CalibrationOptions& options);

/// The outliers among residuals (any order, mm; setup: the setup id of each) by the rule of
/// CalibrationOptions::outlier_sigma: farther than k robust standard deviations (1.4826 times the
/// median absolute deviation, at least 1 nm) from the median, each setup judged by its own.
std::vector<bool> RobustOutliers(const std::vector<double>& residuals_mm, const std::vector<int>& setup, double k);

/// "sample 18 (theta 240 deg, phi 7.5 deg, residual +999 um); ...": the outliers of `points` in
/// words, cut after about 400 characters.
std::string DescribeOutliers(const PointsData& points, const std::vector<Outlier>& outliers);

/// "sample 18 (line 24, theta 240 deg, phi 7.5 deg, residual +999 um, weight 0.001); ...": readings
/// a robust loss weighted down, in words, cut after about 400 characters.
std::string DescribeWeightedReadings(const PointsData& points, const std::vector<WeightedReading>& readings);

/// `points` without the samples that `result` left out as outliers.
PointsData WithoutOutliers(const PointsData& points, const CalibrationResult& result);

}  // namespace sph

#endif  // SPH_CALIB_CALIBRATOR_HPP_
