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
// and c_MZ, the minimising centre. Always S_MZ <= S_LS = f(c_LS). Found by sequential linear
// programming with a trust region from a given centre; f is not convex, so what is proven is a
// bound: (2), no centre within rho narrows the zone by more than MaxDecreaseWithin(rho), and (3),
// a narrower zone's centre lies within near_radius or beyond far_radius. The algorithm and the
// derivation of bounds (1) to (3): docs/method/sphere-evaluation.md.
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

  /// The certificate of the last linear programme solved at `center` (bound (2)): the half-width
  /// Delta of its box and the decrease pi >= 0 it still predicted.
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

/// Minimum-zone sphere of the points, started at `start_center` (use the least-squares centre: the
/// width returned is then never above the least-squares sphericity).
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
/// it, by 2/3 of the near-region radius rho_near(e) of bound (3) at the start. The
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
