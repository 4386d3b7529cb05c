// Form of a measured sphere: radial residuals, least-squares and minimum-zone sphericity, angular
// coverage. Header-only, Eigen only, no exceptions. Units: those of the points, throughout.
//
// Least-squares sphericity (ISO 12181-1 LSCS): the peak-to-valley of the radial residuals about the
// least-squares centre (sph/model/sphere_fit.hpp),
//   S_LS = max_i |p_i - c_LS| - min_i |p_i - c_LS|.
//
// Minimum-zone sphericity (ISO 12181-1 MZCS, Chebyshev): the smallest radial separation of two
// concentric spheres that enclose all points between them,
//   S_MZ = min over c of f(c),   f(c) = max_i d_i(c) - min_i d_i(c),   d_i(c) = |p_i - c|,
// and c_MZ, the minimising centre. Always S_MZ <= S_LS = f(c_LS).
//
// Algorithm: sequential linear programming with a trust region, started at the least-squares centre.
// About a centre c, d_i(c + delta) = d_i - u_i . delta + O(|delta|^2 / d_i), u_i = (p_i - c) / d_i
// (the limacon approximation). With it the problem is the linear programme in x = (delta, a, b)
//   min a - b   s.t.   d_i - u_i . delta <= a,   d_i - u_i . delta >= b   (all i),   |delta_k| <= Delta,
// which is convex, so its minimum is global. The step delta is taken when the exact f decreases;
// Delta follows the ratio of actual to predicted decrease. The iteration stops when the LP predicts
// no decrease: delta = 0 solves the LP at c, which is exactly the first-order optimality condition of
// the exact problem (the convex hulls of the outer and of the inner contact directions u_i meet).
// Near a solution with five contact points (the generic case) the LP step is a Newton step on the
// contact equations, so convergence is quadratic and the result is exact to rounding.
//
// Why not minimise f directly: f is not smooth (a max minus a min) and not convex (min_i d_i is not
// concave), so a general-purpose minimiser stalls at its kinks; the LP treats the kinks exactly. The
// non-convexity only enters through the O(|delta|^2 / R) term: within |c - c_LS| << sqrt(R S) it is
// far below the zone width, the model is the convex LP, and the minimum found is the global one. That
// covers every case where the form error S is small against the radius R, i.e. every real sphere;
// for few points on a small cap the least-squares centre itself is poorly determined (see
// LeastSquaresSphere::RadiusDilution) and so is the minimum zone.
//
// The LP has only five variables: it is solved by a primal active-set (simplex) method on the
// inequality form, with the most negative multiplier leaving and Bland's smallest-index rule after a
// run of degenerate steps (constructed data has every point in contact at the solution). Only
// constraints that can be active under the trust region take part: a point whose d_i is more than
// 2 sqrt(3) Delta below max d (above min d) can never reach the outer (inner) sphere of the LP.
#ifndef SPH_MODEL_SPHERE_FORM_HPP_
#define SPH_MODEL_SPHERE_FORM_HPP_

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/QR>

#include "sph/model/sphere_fit.hpp"
#include "sph/model/units.hpp"

namespace sph {

/// Radial residuals e_i = |p_i - center| - radius, in the order of the points.
inline std::vector<double> RadialResiduals(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center,
                                           double radius) {
  std::vector<double> e(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) e[i] = (points[i] - center).norm() - radius;
  return e;
}

/// max_i |p_i - center| - min_i |p_i - center|: the width of the thinnest spherical shell centred at
/// `center` that holds all points (the least-squares sphericity when `center` is c_LS). 0 for no points.
inline double RadialPeakToValley(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center) {
  if (points.empty()) return 0.0;
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (const auto& p : points) {
    const double d = (p - center).norm();
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  return hi - lo;
}

/// Peak-to-valley (max - min) of values; 0 for none.
inline double PeakToValley(const std::vector<double>& values) {
  if (values.empty()) return 0.0;
  const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
  return *hi - *lo;
}

/// Settings of FitSphereMinimumZone().
struct MinimumZoneOptions {
  int max_iterations = 200;        ///< linear programmes solved (trust-region steps)
  int max_lp_iterations = 100000;  ///< active-set iterations in one linear programme
  /// Stop when the LP predicts a decrease of the width below tolerance * width (plus rounding).
  double tolerance = 1e-12;
  /// With more than 4 x this many points, the zone is first found for the `candidates` farthest and
  /// the `candidates` nearest points from the start centre, then checked against all points and
  /// found again with those outside it added, until it holds them all (see FitSphereMinimumZone).
  /// 0: all points at once.
  int candidates = 2048;
};

/// The minimum-zone sphere pair. Class invariant when ok: inner_radius <= outer_radius and
/// width == outer_radius - inner_radius, all distances from `center`.
struct MinimumZoneSphere {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double inner_radius = 0.0;  ///< min_i |p_i - center|
  double outer_radius = 0.0;  ///< max_i |p_i - center|
  double width = 0.0;         ///< minimum-zone sphericity
  int iterations = 0;         ///< trust-region steps (linear programmes)
  int lp_iterations = 0;      ///< active-set iterations over all linear programmes
  bool converged = false;     ///< the LP predicted no further decrease (a stationary centre)
  bool ok = false;            ///< false for fewer than four points or non-finite input
};

namespace internal {

enum class LpStatus { kOptimal, kUnbounded, kIterationLimit };

/// Minimises c^T x subject to A x <= h for x in R^N (N small), by a primal active-set method.
/// On entry x is feasible and `working` lists linearly independent rows of A active at x; on exit x
/// is optimal (kOptimal) and `working` its active set. `iterations` accumulates the iterations.
template <int N>
LpStatus SolveInequalityLp(const Eigen::Matrix<double, Eigen::Dynamic, N>& a, const Eigen::VectorXd& h,
                           const Eigen::Matrix<double, N, 1>& c, int max_iterations, Eigen::Matrix<double, N, 1>* x,
                           std::vector<int>* working, int* iterations) {
  using Vec = Eigen::Matrix<double, N, 1>;
  using WorkT = Eigen::Matrix<double, N, Eigen::Dynamic, 0, N, N>;  // A_W^T, at most N columns, no heap
  constexpr double kMultiplierTolerance = 1e-10;                    // rows and c are O(1): multipliers are O(1)
  constexpr double kDirectionTolerance = 1e-12;
  constexpr int kDegenerateRunForBland = 20;
  const Eigen::Index m = a.rows();
  Eigen::VectorXd slack = h - a * (*x);
  Eigen::VectorXd ap(m);
  std::vector<char> in_working(static_cast<std::size_t>(m), 0);
  for (const int w : *working) in_working[static_cast<std::size_t>(w)] = 1;
  int degenerate_run = 0;
  const double c_norm = c.norm();

  for (int it = 0; it < max_iterations; ++it) {
    ++*iterations;
    const int k = static_cast<int>(working->size());
    WorkT awt(N, k);
    for (int r = 0; r < k; ++r) awt.col(r) = a.row((*working)[static_cast<std::size_t>(r)]).transpose();
    // lambda = argmin |c + A_W^T lambda|; the residual c + A_W^T lambda is c projected onto the
    // null space of A_W, so p = -(c + A_W^T lambda) is the steepest descent within the face.
    const Eigen::ColPivHouseholderQR<WorkT> qr(awt);
    const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1> lambda =
        k > 0 ? Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1>(qr.solve(-c))
              : Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1>();
    Vec p = k > 0 ? Vec(-(c + awt * lambda)) : Vec(-c);
    if (k == N || p.norm() <= kDirectionTolerance * c_norm) {
      // c is in the row space: c + A_W^T lambda = 0, optimal when every lambda >= 0.
      const bool bland = degenerate_run >= kDegenerateRunForBland;
      int leave = -1;
      for (int j = 0; j < k; ++j) {
        if (!(lambda(j) < -kMultiplierTolerance)) continue;
        const int row = (*working)[static_cast<std::size_t>(j)];
        if (leave < 0 || (bland ? row < (*working)[static_cast<std::size_t>(leave)] : lambda(j) < lambda(leave)))
          leave = j;
      }
      if (leave < 0) return LpStatus::kOptimal;
      // Leave row `leave`, keep the others active: the min-norm p with A_W p = -e_leave, for which
      // c^T p = -lambda^T A_W p = lambda_leave < 0.
      Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1> e = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1>::Zero(k);
      e(leave) = -1.0;
      const Eigen::CompleteOrthogonalDecomposition<Eigen::Matrix<double, Eigen::Dynamic, N, 0, N, N>> cod(
          awt.transpose());
      p = cod.solve(e);
      in_working[static_cast<std::size_t>((*working)[static_cast<std::size_t>(leave)])] = 0;
      working->erase(working->begin() + leave);
    }

    // Ratio test: the first constraint that the move along p makes active (smallest index on ties).
    ap.noalias() = a * p;
    const double threshold = kDirectionTolerance * p.norm();
    double step = std::numeric_limits<double>::infinity();
    Eigen::Index block = -1;
    for (Eigen::Index i = 0; i < m; ++i) {
      if (in_working[static_cast<std::size_t>(i)] || !(ap(i) > threshold)) continue;
      const double t = std::max(slack(i), 0.0) / ap(i);
      if (t < step) {
        step = t;
        block = i;
      }
    }
    if (block < 0) return LpStatus::kUnbounded;
    *x += step * p;
    slack.noalias() -= step * ap;
    slack(block) = 0.0;
    working->push_back(static_cast<int>(block));
    in_working[static_cast<std::size_t>(block)] = 1;
    degenerate_run = step * p.norm() > 0.0 ? 0 : degenerate_run + 1;
  }
  return LpStatus::kIterationLimit;
}

}  // namespace internal

namespace internal {

/// The minimum zone of all `points` at once (FitSphereMinimumZone() without candidates).
inline MinimumZoneSphere MinimumZoneOfAll(const std::vector<Eigen::Vector3d>& points,
                                          const Eigen::Vector3d& start_center, const MinimumZoneOptions& options) {
  using Vec5 = Eigen::Matrix<double, 5, 1>;
  using Rows5 = Eigen::Matrix<double, Eigen::Dynamic, 5>;
  constexpr double kEps = std::numeric_limits<double>::epsilon();
  MinimumZoneSphere mz;
  const std::size_t n = points.size();
  if (n < 4 || !start_center.allFinite()) return mz;

  // Work relative to the start centre: distances are then about R, and the offsets small.
  std::vector<Eigen::Vector3d> q(n);
  for (std::size_t i = 0; i < n; ++i) q[i] = points[i] - start_center;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  std::vector<double> d(n);
  std::size_t i_max = 0, i_min = 0;
  auto evaluate = [&](const Eigen::Vector3d& centre, std::vector<double>* dist, std::size_t* imax, std::size_t* imin) {
    *imax = *imin = 0;
    for (std::size_t i = 0; i < n; ++i) {
      (*dist)[i] = (q[i] - centre).norm();
      if ((*dist)[i] > (*dist)[*imax]) *imax = i;
      if ((*dist)[i] < (*dist)[*imin]) *imin = i;
    }
    return (*dist)[*imax] - (*dist)[*imin];
  };
  double f = evaluate(c, &d, &i_max, &i_min);
  if (!std::isfinite(f)) return mz;
  const double scale = d[i_max];
  const double rounding = 16.0 * kEps * scale;

  double radius = f;  // trust region: the zone width is the scale of the centre's move
  std::vector<double> d_new(n);
  Rows5 a;
  Eigen::VectorXd h;
  std::vector<int> working;
  Vec5 objective;
  objective << 0.0, 0.0, 0.0, 1.0, -1.0;
  mz.converged = f <= rounding;  // on a sphere already (e.g. four points)
  for (int it = 0; it < options.max_iterations && !mz.converged; ++it) {
    mz.iterations = it + 1;
    // Build the LP at c: outer rows [-u_i, -1, 0] x <= -d_i, inner rows [u_i, 0, 1] x <= d_i, box.
    const double reach = 2.0 * std::sqrt(3.0) * radius;
    const double outer_from = d[i_max] - reach;
    const double inner_to = d[i_min] + reach;
    std::size_t rows = 6;
    for (std::size_t i = 0; i < n; ++i) rows += (d[i] >= outer_from ? 1 : 0) + (d[i] <= inner_to ? 1 : 0);
    a.resize(static_cast<Eigen::Index>(rows), 5);
    h.resize(static_cast<Eigen::Index>(rows));
    Eigen::Index row = 0;
    int start_outer = -1, start_inner = -1;
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d u = d[i] > 0.0 ? Eigen::Vector3d((q[i] - c) / d[i]) : Eigen::Vector3d::Zero();
      if (d[i] >= outer_from) {
        if (i == i_max) start_outer = static_cast<int>(row);
        a.row(row) << -u.transpose(), -1.0, 0.0;
        h(row++) = -d[i];
      }
      if (d[i] <= inner_to) {
        if (i == i_min) start_inner = static_cast<int>(row);
        a.row(row) << u.transpose(), 0.0, 1.0;
        h(row++) = d[i];
      }
    }
    for (int k = 0; k < 3; ++k) {
      a.row(row).setZero();
      a(row, k) = 1.0;
      h(row++) = radius;
      a.row(row).setZero();
      a(row, k) = -1.0;
      h(row++) = radius;
    }
    Vec5 x;
    x << 0.0, 0.0, 0.0, d[i_max], d[i_min];
    working.assign({start_outer, start_inner});
    const internal::LpStatus status =
        internal::SolveInequalityLp<5>(a, h, objective, options.max_lp_iterations, &x, &working, &mz.lp_iterations);
    if (status != internal::LpStatus::kOptimal) break;

    const double predicted = f - (x(3) - x(4));
    if (predicted <= options.tolerance * f + rounding) {
      mz.converged = true;
      break;
    }
    const Eigen::Vector3d delta = x.head<3>();
    std::size_t new_max = 0, new_min = 0;
    const double f_new = evaluate(c + delta, &d_new, &new_max, &new_min);
    const double ratio = (f - f_new) / predicted;
    if (f_new < f) {
      c += delta;
      d.swap(d_new);
      i_max = new_max;
      i_min = new_min;
      f = f_new;
    }
    const double step = delta.lpNorm<Eigen::Infinity>();
    if (ratio < 0.25) {
      radius = 0.25 * step;
    } else if (ratio > 0.75) {
      // A good model: allow four times the step (which also keeps the LP small as steps shrink).
      radius = 4.0 * step;
    }
    if (radius <= kEps * scale) {  // no move is resolvable any more: stationary to rounding
      mz.converged = true;
      break;
    }
  }
  mz.center = start_center + c;
  mz.outer_radius = d[i_max];
  mz.inner_radius = d[i_min];
  mz.width = f;
  mz.ok = true;
  return mz;
}

}  // namespace internal

/// Minimum-zone sphere of the points (see the file comment), started at `start_center` (use the
/// least-squares centre: the width returned is then never above the least-squares sphericity).
///
/// Many points: only points near the extremes can touch the zone, so it is found for the
/// MinimumZoneOptions::candidates farthest and nearest from the start centre first. When every
/// other point lies within that zone (to rounding), it is the zone of all points: optimal for a
/// subset and feasible for all (the LP at its centre predicts no decrease with the other rows
/// added). Otherwise the points outside are added and the zone found again, from the same start.
inline MinimumZoneSphere FitSphereMinimumZone(const std::vector<Eigen::Vector3d>& points,
                                              const Eigen::Vector3d& start_center,
                                              const MinimumZoneOptions& options = MinimumZoneOptions()) {
  const std::size_t n = points.size();
  const auto k = static_cast<std::size_t>(std::max(options.candidates, 0));
  if (k == 0 || n <= 4 * k || !start_center.allFinite())
    return internal::MinimumZoneOfAll(points, start_center, options);
  std::vector<double> d(n);
  for (std::size_t i = 0; i < n; ++i) d[i] = (points[i] - start_center).norm();
  // The k farthest and the k nearest points.
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  auto by_distance = [&](std::size_t a, std::size_t b) { return d[a] < d[b] || (d[a] == d[b] && a < b); };
  std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k), order.end(), by_distance);
  std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(k), order.end() - static_cast<std::ptrdiff_t>(k),
                   order.end(), by_distance);
  std::vector<std::size_t> chosen(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k));
  chosen.insert(chosen.end(), order.end() - static_cast<std::ptrdiff_t>(k), order.end());
  std::vector<char> in(n, 0);
  for (const std::size_t i : chosen) in[i] = 1;
  MinimumZoneSphere mz;
  int iterations = 0, lp_iterations = 0;
  for (int round = 0; round < 64; ++round) {
    std::sort(chosen.begin(), chosen.end());  // file order: the result does not depend on how they were found
    std::vector<Eigen::Vector3d> subset(chosen.size());
    for (std::size_t j = 0; j < chosen.size(); ++j) subset[j] = points[chosen[j]];
    mz = internal::MinimumZoneOfAll(subset, start_center, options);
    iterations += mz.iterations;
    lp_iterations += mz.lp_iterations;
    mz.iterations = iterations;
    mz.lp_iterations = lp_iterations;
    if (!mz.ok) return mz;
    // Every point against the zone; the farthest outside it join.
    const double rounding = 16.0 * std::numeric_limits<double>::epsilon() * mz.outer_radius;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    std::vector<std::pair<double, std::size_t>> outside;
    for (std::size_t i = 0; i < n; ++i) {
      const double di = (points[i] - mz.center).norm();
      lo = std::min(lo, di);
      hi = std::max(hi, di);
      const double excess = std::max(di - mz.outer_radius, mz.inner_radius - di);
      if (!in[i] && excess > rounding) outside.emplace_back(-excess, i);
    }
    if (outside.empty()) {
      mz.inner_radius = lo;
      mz.outer_radius = hi;
      mz.width = hi - lo;
      return mz;
    }
    const std::size_t add = std::min(outside.size(), k);
    std::partial_sort(outside.begin(), outside.begin() + static_cast<std::ptrdiff_t>(add), outside.end());
    for (std::size_t j = 0; j < add; ++j) {
      chosen.push_back(outside[j].second);
      in[outside[j].second] = 1;
    }
  }
  return internal::MinimumZoneOfAll(points, start_center, options);
}

/// Minimum-zone sphere started at the geometric least-squares centre; ok == false when the points
/// determine no sphere.
inline MinimumZoneSphere FitSphereMinimumZone(const std::vector<Eigen::Vector3d>& points,
                                              const MinimumZoneOptions& options = MinimumZoneOptions()) {
  const LeastSquaresSphere ls = FitSphereLeastSquares(points);
  if (!ls.sphere.ok) return MinimumZoneSphere();
  return FitSphereMinimumZone(points, ls.sphere.center, options);
}

/// Angular coverage of the points as seen from a centre.
struct SphereCoverage {
  /// Unit vector from the centre towards the points' mean direction; +z when the directions
  /// cancel (points all around the centre).
  Eigen::Vector3d mean_direction = Eigen::Vector3d::UnitZ();
  /// Half-angle of the cone about mean_direction that holds every point [deg]: 90 for an evenly
  /// covered hemisphere, near 180 for points all around the sphere. About the mean direction, not
  /// the smallest such cone: points crowded on one side tilt the axis and widen the angle. It
  /// describes the coverage; how well it determines the sphere is LeastSquaresSphere's dilution.
  double cap_half_angle_deg = 0.0;
};

/// Coverage of the points about `center` (see SphereCoverage).
inline SphereCoverage CoverageOf(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center) {
  SphereCoverage cov;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : points) {
    const Eigen::Vector3d v = p - center;
    if (v.norm() > 0.0) sum += v.normalized();
  }
  if (sum.norm() > 1e-9 * static_cast<double>(points.size())) cov.mean_direction = sum.normalized();
  double min_cos = 1.0;
  for (const auto& p : points) {
    const Eigen::Vector3d v = p - center;
    if (v.norm() > 0.0) min_cos = std::min(min_cos, v.normalized().dot(cov.mean_direction));
  }
  cov.cap_half_angle_deg = std::acos(std::clamp(min_cos, -1.0, 1.0)) * kDegPerRad;
  return cov;
}

}  // namespace sph

#endif  // SPH_MODEL_SPHERE_FORM_HPP_
