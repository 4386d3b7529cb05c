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
// Algorithm: sequential linear programming with a trust region, started at a given centre (the
// least-squares one). About a centre c, with q_i = p_i - c, d_i = |q_i| and u_i = q_i / d_i, the
// distances are modelled by L_i(delta) = d_i - u_i . delta (the limacon approximation), and the
// problem becomes the linear programme in x = (delta, a, b)
//   min a - b   s.t.   L_i(delta) <= a,   L_i(delta) >= b   (all i),   |delta_k| <= Delta,
// whose value is the minimum over the box of the convex, piecewise linear function
//   F(delta) = max_i L_i(delta) - min_i L_i(delta),   F(0) = f(c).
// The step delta is taken when the exact f decreases; Delta follows the ratio of actual to
// predicted decrease. The iteration stops when the LP predicts a decrease pi of at most
// tolerance * f (plus rounding): delta = 0 then solves the LP, the first-order optimality condition
// of the exact problem (the convex hulls of the outer and of the inner contact directions u_i
// meet). Near a solution with five contact points (the generic case) the LP step is a Newton step
// on the contact equations, so convergence is quadratic and the result is exact to rounding.
//
// Why not minimise f directly: f is not smooth (a max minus a min), so a general-purpose minimiser
// stalls at its kinks; the LP treats the kinks exactly.
//
// What the result is. f is not convex either: max_i d_i is convex, but min_i d_i is not concave,
// so f is a difference of convex functions, and that the LP is convex proves nothing about f away
// from c: a cap or a hemisphere can hold several local minima (tests/sphere/ has one). What
// holds is a bound. For a step delta of length rho < d_i, exactly
//   |q_i - delta|^2 = L_i^2 + rho^2 - (u_i . delta)^2,   L_i = L_i(delta) >= d_i - rho > 0,
// and as sqrt(l^2 + s) <= l + s / (2 l) for s >= 0 (square both sides), with
// 0 <= s = rho^2 - (u_i . delta)^2 <= rho^2,
//   L_i(delta) <= d_i(c + delta) <= L_i(delta) + rho^2 / (2 (d_i - rho)).              (1)
// The 1/2 cannot be lowered: for delta perpendicular to u_i the excess is rho^2 / (2 d_i) + O(rho^4).
// The left side of (1) bounds max_i d_i(c + delta) from below by max_i L_i, the right side
// min_i d_i(c + delta) from above by min_i L_i + rho^2 / (2 (r_in - rho)), r_in = min_i d_i, so
//   f(c + delta) >= F(delta) - rho^2 / (2 (r_in - rho)).
// F is convex and, at the last LP, F >= f(c) - pi on the box |delta|_inf <= Delta (the rows the LP
// left out cannot reach the extremes there, see below). Along a segment from 0, convexity extends
// this to F(delta) >= f(c) - pi max(1, |delta|_inf / Delta) everywhere. Together:
//   no centre within rho of c gives a zone narrower than
//   f(c) - pi max(1, rho / Delta) - rho^2 / (2 (r_in - rho))                                 (2)
// (MinimumZoneSphere::MaxDecreaseWithin; CertifiedRadius inverts it). With pi at rounding, the
// radius certified to a slack s is about sqrt(2 r_in s): 6.3 um for s = 1 nm on a 20 mm sphere.
//
// Where narrower zones can be. Take i and j at the two ends of the spread of u . e along a unit
// vector e, w(e) = max_i u_i . e - min_i u_i . e, in (1): for every rho < r_in,
//   f(c + rho e) >= rho w(e) - f(c) - rho^2 / (2 (r_in - rho)).                              (3)
// So a centre at least as good as c lies, along e, within the smaller root rho_near of
// rho w - rho^2 / (2 (r_in - rho)) = 2 f(c) (about 2 f(c) / w), or beyond the larger root rho_far
// (about 2 w r_in / (1 + 2 w)): far off, the centre of a sphere of quite another size (on a cap of
// half-angle t, f tends to the sagitta r (1 - cos t) as the centre recedes along the axis). With
// w >= 2 sigma(e) >= 2 sqrt(lambda_min), the range of the u_i . e at least twice their standard
// deviation (Popoviciu), lambda_min the smallest eigenvalue of the covariance of the u_i, (3)
// holds with one w in every direction: MinimumZoneSphere::near_radius and far_radius, and by (2)
// no centre nearer than far_radius gives a zone narrower by more than MaxDecreaseWithin(near_radius).
// Over the whole sphere w is near 2 (the bound 2 sqrt(lambda_min) about 1), rho_near about 2 f and
// that bound about 2 f^2 / R (9 pm for a form of 0.3 um on a 20 mm sphere): the minimum found is
// the global one. On a cap the
// directions spread little along the axis (w = 1 - cos t: 0.13 at 30 deg, 0.015 at 10 deg), the
// near region grows to 2 f / w and, with it, room for other local minima: for partial coverage
// FitSphereMinimumZoneMultiStart() searches again from starts displaced along the principal
// directions of the u_i (the cap's axis and two across it) by 2/3 of rho_near(e) computed at the
// least-squares centre: with it, 0 and +-2/3 rho_near are the centres of three equal cells that
// cover [-rho_near, rho_near], where by (3) every centre better than the least-squares one lies
// (short of rho_far).
// The narrowest zone is returned with what every start reached, so that disagreement is seen.
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

/// Where one search of FitSphereMinimumZoneMultiStart() started and what it reached.
struct MinimumZoneStart {
  Eigen::Vector3d start = Eigen::Vector3d::Zero();
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double width = 0.0;
  bool converged = false;
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

  /// The certificate of the last linear programme solved at `center` (bound (2) of the file
  /// comment): the half-width Delta of its box and the decrease pi >= 0 it still predicted.
  /// lp_box == 0: no certificate (not converged, or nothing to solve: a zone of width 0).
  double lp_box = 0.0;
  double lp_decrease = 0.0;
  /// Every centre that gives a zone at least as narrow lies within near_radius of `center` or
  /// farther than far_radius (bound (3)); near_radius is infinite when the coverage bounds nothing.
  double near_radius = 0.0;
  double far_radius = 0.0;
  /// FitSphereMinimumZoneMultiStart(): each start and what it reached, the given centre first;
  /// empty for a single start.
  std::vector<MinimumZoneStart> starts;

  /// By how much at most a centre within `rho` of `center` can narrow the zone (bound (2), never
  /// above the width itself: no zone is narrower than 0).
  double MaxDecreaseWithin(double rho) const;
  /// The largest distance from `center` within which no centre narrows the zone by more than
  /// `slack` (the inverse of MaxDecreaseWithin); infinite when slack >= width, 0 without certificate.
  double CertifiedRadius(double slack) const;
  /// Over the converged starts: the widest minus the narrowest width, and the largest distance of
  /// a start's centre from `center` (0 for a single start).
  double StartWidthSpread() const;
  double StartCenterSpread() const;
  /// Every start converged and reached this width to 1e-10 of the radius.
  bool StartsAgree() const;
};

/// Minimum-zone sphere of the points (see the file comment), started at `start_center` (use the
/// least-squares centre: the width returned is then never above the least-squares sphericity).
///
/// Many points: only points near the extremes can touch the zone, so it is found for the
/// MinimumZoneOptions::candidates farthest and nearest from the start centre first. When every
/// other point lies within that zone (to rounding), it is the zone of all points: optimal for a
/// subset and feasible for all (the LP at its centre predicts no decrease with the other rows
/// added). Otherwise the points outside are added and the zone found again, from the same start.
MinimumZoneSphere FitSphereMinimumZone(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& start_center,
                                       const MinimumZoneOptions& options = MinimumZoneOptions());

/// Minimum-zone sphere started at the geometric least-squares centre; ok == false when the points
/// determine no sphere.
MinimumZoneSphere FitSphereMinimumZone(const std::vector<Eigen::Vector3d>& points,
                                       const MinimumZoneOptions& options = MinimumZoneOptions());

/// The minimum zone searched from `start_center` (the least-squares centre) and from six starts
/// displaced from it along +-e for the three principal directions e of the directions u_i seen from
/// it, by 2/3 of the near-region radius rho_near(e) of bound (3) at the start (file comment). The
/// narrowest converged zone is returned, with `starts` listing what each search reached (the first
/// is the given centre). Meant for partial coverage (caps, hemispheres); costs seven searches.
MinimumZoneSphere FitSphereMinimumZoneMultiStart(const std::vector<Eigen::Vector3d>& points,
                                                 const Eigen::Vector3d& start_center,
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
