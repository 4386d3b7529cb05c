// Sphere fits to points in 3D, header-only, Eigen only, no exceptions.
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
#ifndef SPH_MODEL_SPHERE_FIT_HPP_
#define SPH_MODEL_SPHERE_FIT_HPP_

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>

#include "sph/model/row_qr.hpp"

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
  // [A b] = Q R: the least-squares solution of A x = b is that of R_A x = R_b.
  const Eigen::ColPivHouseholderQR<Eigen::Matrix4d> qr(factor.r().topLeftCorner<4, 4>());
  if (qr.rank() < 4) return s;
  const Eigen::Vector4d x = qr.solve(factor.r().col(4).head<4>());
  const double r2 = x(3) + x.head<3>().squaredNorm();
  if (!(r2 > 0.0) || !std::isfinite(r2)) return s;
  s.center = mean + x.head<3>();
  s.radius = std::sqrt(r2);
  s.ok = true;
  return s;
}

/// FitSphereAlgebraic() of a vector of points.
inline Sphere FitSphereAlgebraic(const std::vector<Eigen::Vector3d>& points) {
  return FitSphereAlgebraic(static_cast<Eigen::Index>(points.size()),
                            [&](Eigen::Index i) { return points[static_cast<std::size_t>(i)]; });
}

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
  double CenterDilution() const {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(normal_inverse.topLeftCorner<3, 3>(),
                                                             Eigen::EigenvaluesOnly);
    return std::sqrt(n_points * std::max(eig.eigenvalues()(2), 0.0) / 3.0);
  }
};

namespace internal {

/// Residuals and normal equations of the geometric sphere fit at (c, R); returns the cost S.
/// Points are taken relative to `origin` (the centroid) for conditioning.
inline double SphereNormalEquations(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& origin,
                                    const Eigen::Vector4d& x, Eigen::Matrix4d* jtj, Eigen::Vector4d* jte) {
  // The ten sums of the lower triangle and the gradient, element by element (j_i j_k as the
  // rank-one update of the normal matrix would add them).
  double s[10] = {}, g[4] = {};
  double cost = 0.0;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d v = (p - origin) - x.head<3>();
    const double dist = v.norm();
    const double e = dist - x(3);
    // A point exactly at the centre has no radial direction: it only pulls on the radius.
    const Eigen::Vector3d a = dist > 0.0 ? Eigen::Vector3d(-v / dist) : Eigen::Vector3d::Zero();
    const double j[4] = {a.x(), a.y(), a.z(), -1.0};
    s[0] += j[0] * j[0];
    s[1] += j[0] * j[1];
    s[2] += j[0] * j[2];
    s[3] += j[0] * j[3];
    s[4] += j[1] * j[1];
    s[5] += j[1] * j[2];
    s[6] += j[1] * j[3];
    s[7] += j[2] * j[2];
    s[8] += j[2] * j[3];
    s[9] += j[3] * j[3];
    for (int k = 0; k < 4; ++k) g[k] += j[k] * e;
    cost += e * e;
  }
  *jtj << s[0], s[1], s[2], s[3], s[1], s[4], s[5], s[6], s[2], s[5], s[7], s[8], s[3], s[6], s[8], s[9];
  *jte << g[0], g[1], g[2], g[3];
  return cost;
}

}  // namespace internal

/// Geometric least-squares sphere fit (see the file comment). Needs at least four points that
/// are not all on one plane; returns with `sphere.ok == false` otherwise. Units of the points.
inline LeastSquaresSphere FitSphereLeastSquares(const std::vector<Eigen::Vector3d>& points,
                                                const SphereFitOptions& options = SphereFitOptions()) {
  LeastSquaresSphere fit;
  fit.n_points = static_cast<int>(points.size());
  if (points.size() < 4) return fit;
  const Sphere start = options.start.ok ? options.start : FitSphereAlgebraic(points);
  if (!start.ok) return fit;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  for (const auto& p : points) origin += p;
  origin /= static_cast<double>(points.size());

  Eigen::Vector4d x;
  x << start.center - origin, start.radius;
  Eigen::Matrix4d jtj;
  Eigen::Vector4d jte;
  double cost = internal::SphereNormalEquations(points, origin, x, &jtj, &jte);
  double lambda = 1e-6;  // LM damping, relative to diag(J^T J)
  for (int it = 0; it < options.max_iterations; ++it) {
    fit.iterations = it + 1;
    bool accepted = false;
    Eigen::Vector4d step = Eigen::Vector4d::Zero();
    Eigen::Matrix4d jtj_new;
    Eigen::Vector4d jte_new;
    while (lambda < 1e16) {
      Eigen::Matrix4d a = jtj;
      a.diagonal() += lambda * jtj.diagonal();
      step = a.ldlt().solve(-jte);
      // A step below the tolerance (more damping only shortens it) is the end: the minimum is
      // reached to within it, whether or not its cost shows the last rounding-level decrease.
      if (step.norm() <= options.step_tolerance * std::abs(x(3))) break;
      const Eigen::Vector4d x_new = x + step;
      const double cost_new = internal::SphereNormalEquations(points, origin, x_new, &jtj_new, &jte_new);
      if (std::isfinite(cost_new) && cost_new < cost) {
        x = x_new;
        cost = cost_new;
        jtj = jtj_new;
        jte = jte_new;
        lambda = std::max(lambda * 0.1, 1e-12);
        accepted = true;
        break;
      }
      lambda *= 10.0;
    }
    // No step lowers the cost even at heavy damping: the minimum is reached to rounding.
    if (!accepted || step.norm() <= options.step_tolerance * std::abs(x(3))) {
      fit.converged = true;
      break;
    }
  }

  const Eigen::FullPivLU<Eigen::Matrix4d> lu(jtj);
  if (!lu.isInvertible() || !(x(3) > 0.0) || !x.allFinite()) return fit;
  fit.normal_inverse = lu.inverse();
  fit.sphere.center = origin + x.head<3>();
  fit.sphere.radius = x(3);
  fit.sphere.ok = true;
  fit.rms = std::sqrt(cost / static_cast<double>(points.size()));
  return fit;
}

}  // namespace sph

#endif  // SPH_MODEL_SPHERE_FIT_HPP_
