// The form evaluations of sph/sphere/sphere_form.hpp; the minimum zone's algorithm is described there.
#include "sph/sphere/sphere_form.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "sph/model/units.hpp"
#include "sph/sphere/inequality_lp.hpp"

namespace sph {

std::vector<double> RadialResiduals(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center,
                                    double radius) {
  std::vector<double> e(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) e[i] = (points[i] - center).norm() - radius;
  return e;
}

double RadialPeakToValley(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center) {
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

double PeakToValley(const std::vector<double>& values) {
  if (values.empty()) return 0.0;
  const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
  return *hi - *lo;
}

namespace {

/// The minimum zone of all `points` at once (FitSphereMinimumZone() without candidates).
MinimumZoneSphere MinimumZoneOfAll(const std::vector<Eigen::Vector3d>& points,
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

}  // namespace

MinimumZoneSphere FitSphereMinimumZone(const std::vector<Eigen::Vector3d>& points,
                                       const Eigen::Vector3d& start_center,
                                       const MinimumZoneOptions& options) {
  const std::size_t n = points.size();
  const auto k = static_cast<std::size_t>(std::max(options.candidates, 0));
  if (k == 0 || n <= 4 * k || !start_center.allFinite())
    return MinimumZoneOfAll(points, start_center, options);
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
    mz = MinimumZoneOfAll(subset, start_center, options);
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
  return MinimumZoneOfAll(points, start_center, options);
}

MinimumZoneSphere FitSphereMinimumZone(const std::vector<Eigen::Vector3d>& points,
                                       const MinimumZoneOptions& options) {
  const LeastSquaresSphere ls = FitSphereLeastSquares(points);
  if (!ls.sphere.ok) return MinimumZoneSphere();
  return FitSphereMinimumZone(points, ls.sphere.center, options);
}

SphereCoverage CoverageOf(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center) {
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
