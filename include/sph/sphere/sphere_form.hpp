// Form of a measured sphere: radial residuals, least-squares and minimum-zone sphericity, angular
// coverage. Eigen only, no exceptions (library sph::sphere, src/sphere/). Units: those of the points.
//
// Least-squares sphericity (ISO 12181-1 LSCS): the peak-to-valley of the radial residuals about the
// least-squares centre (sph/sphere/sphere_fit.hpp),
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
#ifndef SPH_SPHERE_SPHERE_FORM_HPP_
#define SPH_SPHERE_SPHERE_FORM_HPP_

#include <vector>

#include <Eigen/Core>

#include "sph/sphere/sphere_fit.hpp"

namespace sph {

/// Radial residuals e_i = |p_i - center| - radius, in the order of the points.
std::vector<double> RadialResiduals(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center,
                                    double radius);

/// max_i |p_i - center| - min_i |p_i - center|: the width of the thinnest spherical shell centred at
/// `center` that holds all points (the least-squares sphericity when `center` is c_LS). 0 for no points.
double RadialPeakToValley(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center);

/// Peak-to-valley (max - min) of values; 0 for none.
double PeakToValley(const std::vector<double>& values);

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

/// Minimum-zone sphere of the points (see the file comment), started at `start_center` (use the
/// least-squares centre: the width returned is then never above the least-squares sphericity).
///
/// Many points: only points near the extremes can touch the zone, so it is found for the
/// MinimumZoneOptions::candidates farthest and nearest from the start centre first. When every
/// other point lies within that zone (to rounding), it is the zone of all points: optimal for a
/// subset and feasible for all (the LP at its centre predicts no decrease with the other rows
/// added). Otherwise the points outside are added and the zone found again, from the same start.
MinimumZoneSphere FitSphereMinimumZone(const std::vector<Eigen::Vector3d>& points,
                                       const Eigen::Vector3d& start_center,
                                       const MinimumZoneOptions& options = MinimumZoneOptions());

/// Minimum-zone sphere started at the geometric least-squares centre; ok == false when the points
/// determine no sphere.
MinimumZoneSphere FitSphereMinimumZone(const std::vector<Eigen::Vector3d>& points,
                                       const MinimumZoneOptions& options = MinimumZoneOptions());

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
SphereCoverage CoverageOf(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center);

}  // namespace sph

#endif  // SPH_SPHERE_SPHERE_FORM_HPP_
