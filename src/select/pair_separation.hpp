// Private to sph::calib: whether one more placement of the sphere would tell apart two effects
// that explain a residual about equally, judged from the design's Jacobian before any
// measurement: the advice a trace gives is checked, not only argued.
#ifndef SPH_SRC_SELECT_PAIR_SEPARATION_HPP_
#define SPH_SRC_SELECT_PAIR_SEPARATION_HPP_

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fit_problem.hpp"
#include "sph/calib/effect_fit.hpp"
#include "sph/io/points_file.hpp"

namespace sph::internal {

/// Two effects count as told apart when no component of either has a variance inflation above
/// this with both in the model: a correlation of at most 0.995 with the rest.
inline constexpr double kSeparatedVif = 100.0;

/// One more placement of a sphere that may tell two effects apart: where its centre is, the radius
/// of another sphere measured there (0: the same sphere), and the mount rotations it is read in,
/// one setup each (empty: one setup in the reference orientation).
struct Placement {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  std::string words;
  double other_radius_mm = 0.0;
  std::vector<Eigen::Vector3d> rotations_deg;
};

/// The placements a trace checks its advice on and a plan proposes, for a design whose first
/// sphere centre is c0: half the eccentricity (2 mm from the axis when it is below 0.5 mm), three
/// times it (the lever of a Phi axis wobble from its pivot changes by the eccentricity), 90 deg
/// further round the Theta axis, a quarter and three quarters of the radius higher along it, and a
/// sphere of half the radius in the same place (a probe's gain and its incidence error differ on a
/// sphere only as 1/R against 1/R^2); where the form of the sphere is modelled (`with_form`), the
/// other sphere is read in two orientations, 90 deg apart about y, for it has a form of its own.
std::vector<Placement> PlacementsToTry(const Eigen::Vector3d& c0, double sphere_radius_mm, bool with_form);

/// What one more placement would do for a pair of effect terms.
struct PairSeparation {
  /// The largest variance inflation of the pair's components, both terms in the model, on the
  /// readings as measured (+inf where the design cannot tell them apart at all).
  double vif_now = std::numeric_limits<double>::infinity();
  /// The placement tried that brings it lowest, when that is kSeparatedVif or below, in words;
  /// empty when none of those tried does.
  std::string placement;
  /// The lowest of those tried.
  double vif_with = std::numeric_limits<double>::infinity();
  std::string tried;  ///< the placements tried, in words
};

/// The largest variance inflation of the components of a (with a_values) and b (with b_values),
/// both beside the model of `current`, on the readings of `table` as measured:
/// CheckPairSeparation()'s vif_now alone, without the placements it tries.
double PairVifNow(const ReadingTable& table, const CalibrationOptions& options, const EffectFit& current,
                  const EffectTerm& a, const std::vector<double>& a_values, const EffectTerm& b,
                  const std::vector<double>& b_values);

/// The most that a (with a_values) and b (with b_values), both beside the model of `current`,
/// inflate the variance of a component of each other on the readings of `table`: the variance
/// inflation of each component with both over that with its own term alone beside the model, 1 /
/// (1 - rho^2) for its partial correlation with the other term (as IdentifyEffectPairs()). Unlike
/// PairVifNow(), a term whose components are poorly determined beside the model anyway does not
/// make every pair with it look confounded.
double PairInflationNow(const ReadingTable& table, const CalibrationOptions& options, const EffectFit& current,
                        const EffectTerm& a, const std::vector<double>& a_values, const EffectTerm& b,
                        const std::vector<double>& b_values);

/// Checks the pair (a with a_values, b with b_values) beside the model of `current` (a fit of
/// `points`): first on the readings as they are, then with each of PlacementsToTry(), the pattern
/// of the first setup read once more there (where the probe still meets the sphere). The readings
/// of the added setups are those of the sphere at the fitted geometry (ray-traced); nothing is
/// fitted.
PairSeparation CheckPairSeparation(const PointsData& points, const CalibrationOptions& options,
                                   const EffectFit& current, const EffectTerm& a, const std::vector<double>& a_values,
                                   const EffectTerm& b, const std::vector<double>& b_values);

}  // namespace sph::internal

#endif  // SPH_SRC_SELECT_PAIR_SEPARATION_HPP_
