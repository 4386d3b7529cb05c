// Sphere fits to points in 3D: Eigen only, no exceptions (library sph::sphere, src/sphere/).
//
// FitSphereAlgebraic: linear least squares on |p|^2 = 2 c.p + k (Kasa fit). Closed form and
// robust, but it minimises an algebraic, not a geometric, distance: use it as a starting point.
// Memory O(1) in the number of points.
//
// FitSphereLeastSquares: the geometric (Gaussian, orthogonal-distance) least-squares sphere,
//   min over (c, R) of  S = sum_i e_i^2,   e_i = |p_i - c| - R,
// the fit of ISO 1101 / ISO 12181 least-squares sphericity and of the NIST ATS reference fits.
// Levenberg-Marquardt on (c, R), started from the algebraic fit, with the Jacobian rows
//   de_i/d(c, R) = [-(p_i - c)^T / |p_i - c|, -1].
// The 4 x 4 normal equations are accumulated in one pass (no n x 4 matrix). Their rounding only
// limits the step, not the fixed point: the iteration stops where the gradient J^T e, which is
// evaluated from the residuals directly, vanishes to rounding, so the result is as accurate as the
// residuals (about 1e-16 of the sphere size after moving the origin to the centroid).
//
// Units: those of the points, throughout.
//
// Compiled, not header-only as the SCMS model is: the fits instantiate Eigen's decompositions,
// and a header that defined them cost every unit that included it many seconds to compile. A
// firmware host that evaluates form links sph::sphere (two sources, Eigen only) beside the model.
#ifndef SPH_SPHERE_SPHERE_FIT_HPP_
#define SPH_SPHERE_SPHERE_FIT_HPP_

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "sph/model/row_qr.hpp"

namespace sph {

/// A fitted sphere. `ok` is false when the points do not determine a sphere (fewer than four,
/// or all on one plane or line); centre and radius are then meaningless.
struct Sphere {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double radius = 0.0;
  bool ok = false;
};

namespace internal {
/// The algebraic sphere from the triangular factor of the rows [2q_x 2q_y 2q_z 1 |q|^2],
/// q = p - mean (the solve of FitSphereAlgebraic).
Sphere AlgebraicSphereOf(const RowQr& factor, const Eigen::Vector3d& mean);
}  // namespace internal

/// Algebraic (Kasa) sphere fit. Solves [2x 2y 2z 1] [c; k] = |p|^2 in the least-squares sense
/// with column-pivoting QR, after moving the origin to the centroid for conditioning;
/// radius = sqrt(k + |c|^2). The rows are folded into the QR's triangular factor in blocks
/// (RowQr), so no n x 4 matrix is made. Units are those of the points.
/// `point(i)` gives point i of n (it is called twice per point).
template <typename PointAt>
Sphere FitSphereAlgebraic(Eigen::Index n, const PointAt& point) {
  Sphere s;
  if (n < 4) return s;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) mean += point(i);
  mean /= static_cast<double>(n);
  constexpr Eigen::Index kBlock = 64;
  RowQr factor(5);  // columns 2x, 2y, 2z, 1 and the right-hand side |p|^2
  Eigen::Matrix<double, kBlock, 5, Eigen::RowMajor> block;
  for (Eigen::Index first = 0; first < n; first += kBlock) {
    const Eigen::Index count = std::min(kBlock, n - first);
    for (Eigen::Index i = 0; i < count; ++i) {
      const Eigen::Vector3d q = point(first + i) - mean;
      block.row(i) << 2.0 * q.x(), 2.0 * q.y(), 2.0 * q.z(), 1.0, q.squaredNorm();
    }
    factor.AddRows(block.data(), 5, count);
  }
  return internal::AlgebraicSphereOf(factor, mean);
}

/// FitSphereAlgebraic() of a vector of points.
Sphere FitSphereAlgebraic(const std::vector<Eigen::Vector3d>& points);

/// Settings of FitSphereLeastSquares().
struct SphereFitOptions {
  int max_iterations = 100;
  /// Converged when an accepted step moves centre and radius by less than this times the radius.
  double step_tolerance = 1e-14;
  /// Where the iteration starts when `start.ok` (a sphere near the solution, such as the fit of
  /// nearly the same points: fewer iterations); otherwise at FitSphereAlgebraic().
  Sphere start;
};

/// The geometric least-squares sphere and what the fit knows about its own conditioning.
/// `sphere.ok` is false when the points do not determine a sphere (see FitSphereAlgebraic) or the
/// normal matrix is singular at the solution; nothing else is then meaningful.
struct LeastSquaresSphere {
  Sphere sphere;
  double rms = 0.0;  ///< RMS of the radial residuals e_i (units of the points)
  int n_points = 0;
  int iterations = 0;      ///< Levenberg-Marquardt iterations
  bool converged = false;  ///< the step (or, at rounding level, the cost) stopped changing
  /// (J^T J)^-1 at the solution, parameters (c_x, c_y, c_z, R). Times the residual variance it is
  /// the usual covariance of the fit; times n it is a pure geometry factor (see the dilutions).
  Eigen::Matrix4d normal_inverse = Eigen::Matrix4d::Zero();

  /// sqrt(n (J^T J)^-1_RR): how much worse the points determine the radius than the same number
  /// of points spread evenly over the whole sphere (for which it is 1). A hemisphere gives 2, a cap
  /// of half-angle 60 deg about 5, 45 deg about 10, 30 deg about 24: the coverage, not the noise.
  /// (Uniform points on a cap of half-angle t: sqrt(E[u_z^2] / var(u_z)) = sqrt(12 E[u_z^2]) / (1 - cos t).)
  double RadiusDilution() const { return std::sqrt(n_points * normal_inverse(3, 3)); }
  /// sqrt(n lambda_max((J^T J)^-1_cc) / 3): as RadiusDilution() for the centre's worst direction
  /// (1 for the whole sphere, 2 for a hemisphere).
  double CenterDilution() const;
};

/// Geometric least-squares sphere fit (see the file comment). Needs at least four points that
/// are not all on one plane; returns with `sphere.ok == false` otherwise. Units of the points.
LeastSquaresSphere FitSphereLeastSquares(const std::vector<Eigen::Vector3d>& points,
                                         const SphereFitOptions& options = SphereFitOptions());

}  // namespace sph

#endif  // SPH_SPHERE_SPHERE_FIT_HPP_
