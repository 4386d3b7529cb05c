// Planning a separation: which orientations of the sphere on its mount make its form separable
// from a given machine, before anything is measured.
//
// The judgement is IdentifyForm()'s (sph/select/identifiability.hpp): the null space of the design's
// Jacobian. The plan is greedy. It starts from the sphere in its reference orientation and adds,
// one at a time, the candidate mount rotation after which the fewest form terms remain
// confounded (ties: the smaller largest variance inflation of a form term), until none is, or no
// candidate lowers the count, or the plan holds `max_orientations`. Every orientation measures the
// same pattern with the sphere's centre where the design puts it (a rotation on the mount turns
// the sphere about its own centre), so the eccentricity's direction on the body changes with the
// orientation: that is what separates the probe's own terms from the form. A greedy plan is not
// proved the smallest; it is checked, in the same way as any design, by the last step's judgement,
// which is returned with it.
//
// Then the machine's effects are judged among themselves on the planned orientations
// (IdentifyEffectPairs()), and for each pair that stays confounded the plan tries one more
// placement of a sphere (the placements a trace checks its advice on: another eccentricity, azimuth
// or height, a sphere of half the radius) and names the one that separates it best.
#ifndef SPH_SELECT_ORIENTATION_PLAN_HPP_
#define SPH_SELECT_ORIENTATION_PLAN_HPP_

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/simulation/simulate.hpp"
#include "sph/select/identifiability.hpp"

namespace sph {

struct OrientationPlanOptions {
  std::vector<Effect> effects;  ///< the machine's effects beyond the seven errors
  int harmonics = 4;            ///< highest harmonic order of the harmonic effects
  int drift_order = 2;          ///< highest power of time of probe_drift
  int form_degree_max = 4;      ///< the form's terms of degrees 2..L are to be separated
  double phi_wobble_pivot_mm = 0.0;
  /// Mount rotations to choose from (rotation vectors, deg); empty: DefaultOrientationCandidates().
  std::vector<Eigen::Vector3d> candidates_deg;
  int max_orientations = 5;  ///< the reference orientation included
};

/// One orientation of the plan, with what is still confounded once it is measured too.
struct OrientationPlanStep {
  Eigen::Vector3d rotation_deg = Eigen::Vector3d::Zero();  ///< the mount rotation added
  FormIdentifiability identifiability;                     ///< of every orientation up to this one
};

/// Two of the machine's effects that the planned orientations leave confounded with each other,
/// and what one more placement of a sphere would do for them.
struct EffectPairAdvice {
  EffectPairInflation pair;  ///< on the planned orientations
  /// The placement tried that brings the factor lowest, in words, when that is
  /// kSeparatedPairInflation or below; empty when none of those tried does.
  std::string placement;
  double factor_with = std::numeric_limits<double>::infinity();  ///< the lowest of those tried
  /// Where that placement puts the sphere's centre [mm] (meaningful when `placement` is not empty).
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  /// The radius of another sphere measured there [mm]; 0: the planned sphere.
  double other_sphere_radius_mm = 0.0;
  /// The mount rotations it is read in, one setup each (rotation vectors, deg); empty: one setup
  /// in the reference orientation.
  std::vector<Eigen::Vector3d> rotations_deg;
};

struct OrientationPlan {
  std::vector<OrientationPlanStep> steps;  ///< the first: the reference orientation alone
  /// The effects the planned orientations do not determine at all beside the seven errors, the
  /// centres and the form (IdentifyEffectPairs()).
  std::vector<Effect> undetermined;
  /// The pairs of effects whose factor on the planned orientations exceeds
  /// kSeparatedPairInflation, the worst first: orientations of the sphere turn its form, not the
  /// machine, and do not tell two machine effects apart; another eccentricity, height or sphere can.
  std::vector<EffectPairAdvice> confounded_effects;
  std::string placements_tried;  ///< the placements tried for them, in words (those where the probe meets the sphere)
  /// The last step leaves no form term confounded.
  bool Separable() const { return !steps.empty() && steps.back().identifiability.confounded.empty(); }
};

/// Turns by 90, 180 and 270 deg about the Theta axis' direction (z) and by 90 and 180 deg about
/// x and y, +-90 deg tilts, and a turn of 120 deg about (1, 1, 1) (x to y to z): what a mount with
/// a V-block or an indexing collet offers.
std::vector<Eigen::Vector3d> DefaultOrientationCandidates();

/// The greedy plan (see the file comment) for the design of `design`: its truth, sphere, probe
/// offset, pattern, scan order and the first of its centres (its mount rotations, noise and
/// effects are not used). Throws sph::Error for a design IdentifyForm() cannot judge, a form
/// degree outside 2..40 or max_orientations below 1.
OrientationPlan PlanOrientations(const SimulationSpec& design, const OrientationPlanOptions& options);

}  // namespace sph

#endif  // SPH_SELECT_ORIENTATION_PLAN_HPP_
