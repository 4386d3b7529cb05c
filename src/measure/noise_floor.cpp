#include "sph/measure/noise_floor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sph/core/cancellation.hpp"
#include "sph/core/error.hpp"
#include "sph/sphere/sphere_fit.hpp"
#include "sph/sphere/sphere_form.hpp"
#include "sph/stats/gum.hpp"

namespace sph {

FormNoiseFloor EstimateFormNoiseFloor(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center_mm,
                                      double radius_mm, double rms_mm, double sigma_mm,
                                      const NoiseFloorOptions& options) {
  if (!(sigma_mm > 0.0) || !std::isfinite(sigma_mm)) throw Error("noise floor: the noise must be positive");
  if (points.size() < 5) throw Error("noise floor: at least 5 points are needed");
  if (options.draws < 2) throw Error("noise floor: at least 2 draws are needed");
  const std::size_t n = points.size();
  std::vector<Eigen::Vector3d> directions(n);
  for (std::size_t i = 0; i < n; ++i) directions[i] = (points[i] - center_mm).normalized();
  const bool with_mz = static_cast<long>(n) <= options.max_mz_points;

  FormNoiseFloor f;
  f.sigma_mm = sigma_mm;
  f.draws = options.draws;
  const double nn = static_cast<double>(n);
  f.rms_form_mm = std::sqrt(std::max(0.0, rms_mm * rms_mm - sigma_mm * sigma_mm * (nn - 4.0) / nn));
  Random random(options.seed);
  std::vector<double> pv, mz;
  std::vector<Eigen::Vector3d> noisy(n);
  for (int d = 0; d < options.draws; ++d) {
    ThrowIfCancelled();
    for (std::size_t i = 0; i < n; ++i) noisy[i] = center_mm + (radius_mm + sigma_mm * random.Normal()) * directions[i];
    const LeastSquaresSphere ls = FitSphereLeastSquares(noisy);
    if (!ls.sphere.ok) throw Error("noise floor: a draw determined no sphere");
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Eigen::Vector3d& p : noisy) {
      const double e = (p - ls.sphere.center).norm() - ls.sphere.radius;
      lo = std::min(lo, e);
      hi = std::max(hi, e);
    }
    pv.push_back(hi - lo);
    if (with_mz) {
      const MinimumZoneSphere z = FitSphereMinimumZone(noisy, ls.sphere.center);
      if (z.ok) mz.push_back(z.width);
    }
  }
  f.ls_pv_mean_mm = gum::SampleMean(pv);
  f.ls_pv_std_mm = gum::SampleStd(pv);
  if (mz.size() >= 2) {
    f.mz_mean_mm = gum::SampleMean(mz);
    f.mz_std_mm = gum::SampleStd(mz);
  } else {
    f.mz_mean_mm = f.mz_std_mm = std::numeric_limits<double>::quiet_NaN();
  }
  return f;
}

}  // namespace sph
