// The form evaluations of sph/sphere/sphere_form.hpp; the minimum zone's algorithm: docs/method/sphere-evaluation.md.
#include "sph/sphere/sphere_form.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <Eigen/Eigenvalues>

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

using Vec5 = Eigen::Matrix<double, 5, 1>;
using Rows5 = Eigen::Matrix<double, Eigen::Dynamic, 5>;
constexpr double kEps = std::numeric_limits<double>::epsilon();

/// The minimum zone's iteration: the points q_i relative to the start centre, the centre c reached
/// (relative to it too), the distances d_i = |q_i - c| with the farthest and the nearest point, the
/// zone's width f there, and the buffers of the steps.
struct ZoneIteration {
  std::vector<Eigen::Vector3d> q;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  std::vector<double> d, d_new;
  std::size_t i_max = 0, i_min = 0;
  double f = 0.0;
  Rows5 a;
  Eigen::VectorXd h;
  std::vector<int> working;
};

/// The distances of the points `q` from `centre` into *dist, the farthest and the nearest into
/// *imax and *imin; returns the zone's width.
double Distances(const std::vector<Eigen::Vector3d>& q, const Eigen::Vector3d& centre, std::vector<double>* dist,
                 std::size_t* imax, std::size_t* imin) {
  *imax = *imin = 0;
  for (std::size_t i = 0; i < q.size(); ++i) {
    (*dist)[i] = (q[i] - centre).norm();
    if ((*dist)[i] > (*dist)[*imax]) *imax = i;
    if ((*dist)[i] < (*dist)[*imin]) *imin = i;
  }
  return (*dist)[*imax] - (*dist)[*imin];
}

/// The rows of the LP at c over the box |delta_k| <= box into z.a and z.h: outer rows
/// [-u_i, -1, 0] x <= -d_i, inner rows [u_i, 0, 1] x <= d_i (of the points that can still become
/// the farthest or the nearest), and the box. Returns the rows of the farthest and the nearest point.
std::pair<int, int> BuildStepLp(ZoneIteration& z, double box) {
  const std::size_t n = z.q.size();
  const double reach = 2.0 * std::sqrt(3.0) * box;
  const double outer_from = z.d[z.i_max] - reach;
  const double inner_to = z.d[z.i_min] + reach;
  std::size_t rows = 6;
  for (std::size_t i = 0; i < n; ++i) rows += (z.d[i] >= outer_from ? 1 : 0) + (z.d[i] <= inner_to ? 1 : 0);
  z.a.resize(static_cast<Eigen::Index>(rows), 5);
  z.h.resize(static_cast<Eigen::Index>(rows));
  Eigen::Index row = 0;
  int start_outer = -1, start_inner = -1;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d u = z.d[i] > 0.0 ? Eigen::Vector3d((z.q[i] - z.c) / z.d[i]) : Eigen::Vector3d::Zero();
    if (z.d[i] >= outer_from) {
      if (i == z.i_max) start_outer = static_cast<int>(row);
      z.a.row(row) << -u.transpose(), -1.0, 0.0;
      z.h(row++) = -z.d[i];
    }
    if (z.d[i] <= inner_to) {
      if (i == z.i_min) start_inner = static_cast<int>(row);
      z.a.row(row) << u.transpose(), 0.0, 1.0;
      z.h(row++) = z.d[i];
    }
  }
  for (int k = 0; k < 3; ++k) {
    z.a.row(row).setZero();
    z.a(row, k) = 1.0;
    z.h(row++) = box;
    z.a.row(row).setZero();
    z.a(row, k) = -1.0;
    z.h(row++) = box;
  }
  return {start_outer, start_inner};
}

/// The LP at c over the box |delta_k| <= box (BuildStepLp), started at the farthest and the
/// nearest point's rows; its optimum goes to *x and its iterations add to mz->lp_iterations. False
/// when it has none.
bool SolveStepLp(ZoneIteration& z, double box, const MinimumZoneOptions& options, MinimumZoneSphere* mz, Vec5* x) {
  Vec5 objective;
  objective << 0.0, 0.0, 0.0, 1.0, -1.0;
  const auto [start_outer, start_inner] = BuildStepLp(z, box);
  *x << 0.0, 0.0, 0.0, z.d[z.i_max], z.d[z.i_min];
  z.working.assign({start_outer, start_inner});
  return internal::SolveInequalityLp<5>(z.a, z.h, objective, options.max_lp_iterations, x, &z.working,
                                        &mz->lp_iterations) == internal::LpStatus::kOptimal;
}

/// Moves the centre by `delta` when that narrows the zone; returns the trust region's next radius,
/// from how much of the `predicted` decrease came true.
double TakeStep(ZoneIteration& z, const Eigen::Vector3d& delta, double predicted, double radius) {
  std::size_t new_max = 0, new_min = 0;
  const double f_new = Distances(z.q, z.c + delta, &z.d_new, &new_max, &new_min);
  const double ratio = (z.f - f_new) / predicted;
  if (f_new < z.f) {
    z.c += delta;
    z.d.swap(z.d_new);
    z.i_max = new_max;
    z.i_min = new_min;
    z.f = f_new;
  }
  const double step = delta.lpNorm<Eigen::Infinity>();
  if (ratio < 0.25) {
    return 0.25 * step;
  } else if (ratio > 0.75) {
    // A good model: allow four times the step (which also keeps the LP small as steps shrink).
    return 4.0 * step;
  }
  return radius;
}

/// The trust-region steps from the start until the LP predicts no further decrease, no move is
/// resolvable any more or the iterations run out; `scale` is the largest distance at the start.
/// Returns whether the last LP was solved at the final c (and certifies it).
bool Iterate(ZoneIteration& z, double scale, const MinimumZoneOptions& options, MinimumZoneSphere* mz) {
  const double rounding = 16.0 * kEps * scale;
  double radius = z.f;              // trust region: the zone width is the scale of the centre's move
  mz->converged = z.f <= rounding;  // on a sphere already (e.g. four points)
  for (int it = 0; it < options.max_iterations && !mz->converged; ++it) {
    mz->iterations = it + 1;
    Vec5 x;
    if (!SolveStepLp(z, radius, options, mz, &x)) break;
    const double predicted = z.f - (x(3) - x(4));
    if (predicted <= options.tolerance * z.f + rounding) {
      mz->converged = true;
      mz->lp_box = radius;
      mz->lp_decrease = std::max(predicted, 0.0);
      return true;
    }
    radius = TakeStep(z, x.head<3>(), predicted, radius);
    if (radius <= kEps * scale) {  // no move is resolvable any more: stationary to rounding
      mz->converged = true;
      break;
    }
  }
  return false;
}

/// The minimum zone of all `points` at once (FitSphereMinimumZone() without candidates).
MinimumZoneSphere MinimumZoneOfAll(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& start_center,
                                   const MinimumZoneOptions& options) {
  MinimumZoneSphere mz;
  const std::size_t n = points.size();
  if (n < 4 || !start_center.allFinite()) return mz;

  // Work relative to the start centre: distances are then about R, and the offsets small.
  ZoneIteration z;
  z.q.resize(n);
  for (std::size_t i = 0; i < n; ++i) z.q[i] = points[i] - start_center;
  z.d.resize(n);
  z.f = Distances(z.q, z.c, &z.d, &z.i_max, &z.i_min);
  if (!std::isfinite(z.f)) return mz;
  z.d_new.resize(n);
  const bool certified = Iterate(z, z.d[z.i_max], options, &mz);
  if (mz.converged && z.f > 0.0 && !(certified && mz.lp_box >= z.f)) {
    // The trust region shrinks with the steps, and bound (2) grows as rho / Delta beyond the box:
    // one LP at the final centre over a box of the zone's width makes the certificate (whatever
    // decrease it still predicts, e.g. after a stop by rounding).
    Vec5 x;
    if (SolveStepLp(z, z.f, options, &mz, &x)) {
      mz.lp_box = z.f;
      mz.lp_decrease = std::max(z.f - (x(3) - x(4)), 0.0);
    }
  }
  mz.center = start_center + z.c;
  mz.outer_radius = z.d[z.i_max];
  mz.inner_radius = z.d[z.i_min];
  mz.width = z.f;
  mz.ok = true;
  return mz;
}

/// The roots of rho w - rho^2 / (2 (r - rho)) = 2 f (bound (3) of the header), i.e. of
/// (1 + 2 w) rho^2 - (2 r w + 4 f) rho + 4 r f = 0, and the vertex between them. Without real
/// roots nothing is excluded: both infinite.
struct NearFar {
  double near_radius, far_radius, vertex;
};
NearFar NearFarRoots(double w, double f, double r) {
  const double a = 1.0 + 2.0 * w, b = 2.0 * r * w + 4.0 * f, c = 4.0 * r * f;
  const double disc = b * b - 4.0 * a * c;
  const double vertex = b / (2.0 * a);
  if (!(disc >= 0.0)) return {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(), vertex};
  const double big = b + std::sqrt(disc);
  return {2.0 * c / big, big / (2.0 * a), vertex};  // the smaller root without cancellation
}

/// The directions u_i = (p_i - c) / |p_i - c|, their (population) covariance, and the nearest and
/// farthest distance.
struct Directions {
  std::vector<Eigen::Vector3d> u;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  double nearest = std::numeric_limits<double>::infinity(), farthest = 0.0;
};
Directions DirectionsFrom(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& c) {
  Directions dirs;
  dirs.u.resize(points.size());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d v = points[i] - c;
    const double d = v.norm();
    dirs.nearest = std::min(dirs.nearest, d);
    dirs.farthest = std::max(dirs.farthest, d);
    dirs.u[i] = d > 0.0 ? Eigen::Vector3d(v / d) : Eigen::Vector3d::Zero();
    mean += dirs.u[i];
    second += dirs.u[i] * dirs.u[i].transpose();
  }
  const double n = static_cast<double>(std::max<std::size_t>(points.size(), 1));
  mean /= n;
  dirs.covariance = second / n - mean * mean.transpose();
  return dirs;
}

/// near_radius and far_radius of bound (3), with w >= 2 sqrt(lambda_min) in every direction.
void Localise(const std::vector<Eigen::Vector3d>& points, MinimumZoneSphere* mz) {
  const Directions dirs = DirectionsFrom(points, mz->center);
  const double lambda_min =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(dirs.covariance, Eigen::EigenvaluesOnly).eigenvalues()(0);
  const NearFar nf = NearFarRoots(2.0 * std::sqrt(std::max(lambda_min, 0.0)), mz->width, mz->inner_radius);
  mz->near_radius = nf.near_radius;
  mz->far_radius = nf.far_radius;
}

MinimumZoneSphere FitFromStart(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& start_center,
                               const MinimumZoneOptions& options) {
  const std::size_t n = points.size();
  const auto k = static_cast<std::size_t>(std::max(options.candidates, 0));
  if (k == 0 || n <= 4 * k || !start_center.allFinite()) return MinimumZoneOfAll(points, start_center, options);
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

}  // namespace

double MinimumZoneSphere::MaxDecreaseWithin(double rho) const {
  if (!(lp_box > 0.0) || !(rho < inner_radius)) return width;
  const double bound = lp_decrease * std::max(1.0, rho / lp_box) + rho * rho / (2.0 * (inner_radius - rho));
  return std::min(width, bound);
}

double MinimumZoneSphere::CertifiedRadius(double slack) const {
  if (slack >= width) return std::numeric_limits<double>::infinity();
  if (!(lp_box > 0.0) || lp_decrease > slack) return 0.0;
  // MaxDecreaseWithin rises from lp_decrease <= slack at 0 to width > slack at inner_radius.
  double lo = 0.0, hi = inner_radius;
  for (int k = 0; k < 200 && hi - lo > std::numeric_limits<double>::epsilon() * hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    (MaxDecreaseWithin(mid) <= slack ? lo : hi) = mid;
  }
  return lo;
}

double MinimumZoneSphere::StartWidthSpread() const {
  double lo = width, hi = width;
  for (const MinimumZoneStart& s : starts) {
    if (!s.converged) continue;
    lo = std::min(lo, s.width);
    hi = std::max(hi, s.width);
  }
  return hi - lo;
}

double MinimumZoneSphere::StartCenterSpread() const {
  double far = 0.0;
  for (const MinimumZoneStart& s : starts) {
    if (s.converged) far = std::max(far, (s.center - center).norm());
  }
  return far;
}

bool MinimumZoneSphere::StartsAgree() const {
  const bool all_converged =
      std::all_of(starts.begin(), starts.end(), [](const MinimumZoneStart& s) { return s.converged; });
  return all_converged && StartWidthSpread() <= 1e-10 * outer_radius;
}

MinimumZoneSphere FitSphereMinimumZone(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& start_center,
                                       const MinimumZoneOptions& options) {
  MinimumZoneSphere mz = FitFromStart(points, start_center, options);
  if (mz.ok) Localise(points, &mz);
  return mz;
}

MinimumZoneSphere FitSphereMinimumZoneMultiStart(const std::vector<Eigen::Vector3d>& points,
                                                 const Eigen::Vector3d& start_center,
                                                 const MinimumZoneOptions& options) {
  MinimumZoneSphere best = FitSphereMinimumZone(points, start_center, options);
  if (!best.ok) return best;
  std::vector<MinimumZoneStart> starts{{start_center, best.center, best.width, best.converged}};
  // Bound (3) at the start: along each principal direction e of the u_i, every centre better
  // than the start lies within rho_near(e) (or very far); 0 and +-2/3 rho_near(e) are the centres
  // of three equal cells covering [-rho_near, rho_near].
  const Directions dirs = DirectionsFrom(points, start_center);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(dirs.covariance);
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d e = eig.eigenvectors().col(k);
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Eigen::Vector3d& u : dirs.u) {
      lo = std::min(lo, u.dot(e));
      hi = std::max(hi, u.dot(e));
    }
    const NearFar nf = NearFarRoots(hi - lo, dirs.farthest - dirs.nearest, dirs.nearest);
    const double rho = std::isfinite(nf.near_radius) ? nf.near_radius : nf.vertex;
    for (const double sign : {1.0, -1.0}) {
      const Eigen::Vector3d s = start_center + sign * (2.0 / 3.0) * rho * e;
      MinimumZoneSphere mz = FitSphereMinimumZone(points, s, options);
      if (!mz.ok) continue;
      starts.push_back({s, mz.center, mz.width, mz.converged});
      if ((mz.converged && !best.converged) || (mz.converged == best.converged && mz.width < best.width)) {
        best = std::move(mz);
      }
    }
  }
  best.starts = std::move(starts);
  return best;
}

MinimumZoneSphere FitSphereMinimumZone(const std::vector<Eigen::Vector3d>& points, const MinimumZoneOptions& options) {
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
