// Sphere fits to points in 3D, header-only, Eigen only.
//
// FitSphereAlgebraic: linear least squares on |p|^2 = 2 c.p + k (Kasa fit). Closed form and
// robust, but it minimises an algebraic, not a geometric, distance: use it as a starting point.
#ifndef SPH_MODEL_SPHERE_FIT_HPP_
#define SPH_MODEL_SPHERE_FIT_HPP_

#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <Eigen/QR>

namespace sph {

/// A fitted sphere. `ok` is false when the points do not determine a sphere (fewer than four,
/// or all on one plane or line); centre and radius are then meaningless.
struct Sphere {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double radius = 0.0;
  bool ok = false;
};

/// Algebraic (Kasa) sphere fit. Solves [2x 2y 2z 1] [c; k] = |p|^2 in the least-squares sense
/// with column-pivoting QR, after moving the origin to the centroid for conditioning;
/// radius = sqrt(k + |c|^2). Units are those of the points.
inline Sphere FitSphereAlgebraic(const std::vector<Eigen::Vector3d>& points) {
  Sphere s;
  const Eigen::Index n = static_cast<Eigen::Index>(points.size());
  if (n < 4) return s;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(n);
  Eigen::MatrixXd a(n, 4);
  Eigen::VectorXd rhs(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d q = points[static_cast<std::size_t>(i)] - mean;
    a.row(i) << 2.0 * q.x(), 2.0 * q.y(), 2.0 * q.z(), 1.0;
    rhs(i) = q.squaredNorm();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  if (qr.rank() < 4) return s;
  const Eigen::Vector4d x = qr.solve(rhs);
  const double r2 = x(3) + x.head<3>().squaredNorm();
  if (!(r2 > 0.0) || !std::isfinite(r2)) return s;
  s.center = mean + x.head<3>();
  s.radius = std::sqrt(r2);
  s.ok = true;
  return s;
}

}  // namespace sph

#endif  // SPH_MODEL_SPHERE_FIT_HPP_
