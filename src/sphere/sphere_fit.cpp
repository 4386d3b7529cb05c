// The sphere fits of sph/sphere/sphere_fit.hpp.
#include "sph/sphere/sphere_fit.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>

namespace sph {

Sphere internal::AlgebraicSphereOf(const RowQr& factor, const Eigen::Vector3d& mean) {
  Sphere s;
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

Sphere FitSphereAlgebraic(const std::vector<Eigen::Vector3d>& points) {
  return FitSphereAlgebraic(static_cast<Eigen::Index>(points.size()),
                            [&](Eigen::Index i) { return points[static_cast<std::size_t>(i)]; });
}

double LeastSquaresSphere::CenterDilution() const {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(normal_inverse.topLeftCorner<3, 3>(),
                                                           Eigen::EigenvaluesOnly);
  return std::sqrt(n_points * std::max(eig.eigenvalues()(2), 0.0) / 3.0);
}

namespace {

/// Residuals and normal equations of the geometric sphere fit at (c, R); returns the cost S.
/// Points are taken relative to `origin` (the centroid) for conditioning.
double SphereNormalEquations(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& origin,
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

}  // namespace

LeastSquaresSphere FitSphereLeastSquares(const std::vector<Eigen::Vector3d>& points, const SphereFitOptions& options) {
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
  double cost = SphereNormalEquations(points, origin, x, &jtj, &jte);
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
      const double cost_new = SphereNormalEquations(points, origin, x_new, &jtj_new, &jte_new);
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
