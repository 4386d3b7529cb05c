// Private to sph::calib: whether one more placement of the sphere would tell apart two effects
// that explain a residual about equally, judged from the design's Jacobian before any
// measurement: the advice a trace gives is checked, not only argued.
#ifndef SPH_SRC_CALIB_PAIR_SEPARATION_HPP_
#define SPH_SRC_CALIB_PAIR_SEPARATION_HPP_

#include <limits>
#include <string>
#include <vector>

#include "sph/calib/effect_fit.hpp"
#include "sph/core/points_file.hpp"

namespace sph::internal {

/// Two effects count as told apart when no component of either has a variance inflation above
/// this with both in the model: a correlation of at most 0.995 with the rest.
inline constexpr double kSeparatedVif = 100.0;

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
/// both beside the model of `current`, on the readings `points` as measured: CheckPairSeparation()'s
/// vif_now alone, without the placements it tries.
double PairVifNow(const PointsData& points, const CalibrationOptions& options, const EffectFit& current,
                  const EffectTerm& a, const std::vector<double>& a_values, const EffectTerm& b,
                  const std::vector<double>& b_values);

/// Checks the pair (a with a_values, b with b_values) beside the model of `current` (a fit of
/// `points`): first on the readings as they are, then with one more setup, the pattern of the first
/// setup read once more with the sphere at another eccentricity, azimuth, or a quarter and three
/// quarters of its radius higher (where the probe still meets it). The readings of
/// the added setup are those of the sphere at the fitted geometry (ray-traced); nothing is fitted.
PairSeparation CheckPairSeparation(const PointsData& points, const CalibrationOptions& options,
                                   const EffectFit& current, const EffectTerm& a, const std::vector<double>& a_values,
                                   const EffectTerm& b, const std::vector<double>& b_values);

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_PAIR_SEPARATION_HPP_
