// Evaluation of a measured sphere: least-squares sphere, least-squares and minimum-zone
// sphericity, how well the coverage determines them, and how much of the result the calibration's
// own uncertainty can explain. The mathematics is header-only (sph/sphere/sphere_fit.hpp,
// sph/sphere/sphere_form.hpp); this adds the judgement (warnings) and the uncertainty propagation.
//
// Uncertainty from the calibration, by sampling (Monte Carlo), not by linearisation: the errors are
// drawn from N(g, Sigma) (Sigma the calibration's 7 x 7 covariance, rad and mm), the raw readings are
// compensated with each draw and evaluated again. The radius is a smooth function of the errors and
// a linearisation would do (the tests check that both agree), but the sphericities are a max minus a
// min: their derivative only follows the current extreme points and misses that other points become
// the extremes, and it cannot say how large a form error the calibration alone can produce when the
// true form is nil (a peak-to-valley is never negative). Sampling answers both. Reported:
//   radius_std_mm, center_std_mm, sphericity_{ls,mz}_std_mm   standard deviations over the draws;
//   calibration_form_p95_mm   95th percentile over the draws of the peak-to-valley of the change of
//                             the residuals (each draw about its own least-squares sphere): the form
//                             error that the calibration's uncertainty alone produces in 95 % of cases.
// The form error exceeds the calibration when the least-squares sphericity is above that percentile.
// Probe noise of the measurement itself is not part of the calibration's covariance and not in here.
#ifndef SPH_CORE_SPHERE_MEASUREMENT_HPP_
#define SPH_CORE_SPHERE_MEASUREMENT_HPP_

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/model/compensation.hpp"
#include "sph/sphere/sphere_fit.hpp"
#include "sph/sphere/sphere_form.hpp"

namespace sph {

struct SphereEvaluationOptions {
  /// Warn (poorly_determined) when the radius or the centre is determined more than this many
  /// times worse than by the same number of points over the whole sphere (see
  /// LeastSquaresSphere::RadiusDilution: 10 is an evenly covered cap of half-angle about 45 deg).
  double max_dilution = 10.0;
};

/// Everything measured about one sphere; lengths in mm.
struct SphereEvaluation {
  int n_points = 0;
  LeastSquaresSphere ls;             ///< ls.sphere.center, ls.sphere.radius [mm]
  std::vector<double> residuals_mm;  ///< radial residuals about the least-squares sphere, in point order
  double sphericity_ls_mm = 0.0;     ///< peak-to-valley of residuals_mm
  MinimumZoneSphere mz;              ///< minimum-zone centre, radii and width [mm]
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

/// Evaluates points measured on a sphere. `source` names them in messages. Throws sph::Error when
/// they determine no sphere (fewer than four, or all on one plane or line).
SphereEvaluation EvaluateSphere(const std::vector<Eigen::Vector3d>& points_mm, const std::string& source,
                                const SphereEvaluationOptions& options = SphereEvaluationOptions());

struct UncertaintyOptions {
  int samples = 200;       ///< calibration draws (the std of a std from 200 draws is about 5 %)
  std::uint64_t seed = 1;  ///< of the std::mt19937_64 that draws them
  int threads = 0;         ///< draws evaluated in parallel; 0: one per hardware thread (same result)
  /// Called with (draws done, draws) as they finish (from the evaluating threads, one at a time).
  std::function<void(int, int)> progress;
};

/// What the calibration's covariance means for one measured sphere (see the file comment); mm.
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

}  // namespace sph

#endif  // SPH_CORE_SPHERE_MEASUREMENT_HPP_
