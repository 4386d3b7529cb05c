// PlanOrientations(): see sph/select/orientation_plan.hpp.
#include "sph/select/orientation_plan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include "pair_separation.hpp"
#include "sph/core/error.hpp"
#include "sph/model/spherical_harmonics.hpp"

namespace sph {
namespace {

// The planned design: the sphere at the design's first centre in each of `rotations_deg` (one
// setup each, ids 0, 1, ...) and, when given, the setups of one more placement after them, read
// without noise; with the calibration options, the machine's model and the point to linearise at
// (the truth: the seven errors and the centres as simulated, effects and form at 0).
struct PlannedDesign {
  PointsData points;
  CalibrationOptions calibration;
  EffectModel machine;
  EffectFitStart at;
};

PlannedDesign DesignOf(const SimulationSpec& design, const OrientationPlanOptions& options,
                       const std::vector<Eigen::Vector3d>& rotations_deg, const internal::Placement* more = nullptr) {
  SimulationSpec spec = design;
  spec.centers_mm.assign(rotations_deg.size(), design.centers_mm.front());
  spec.mount_rotations_deg.clear();
  spec.mount_unknown.clear();
  spec.sphere_radii_mm.clear();
  for (std::size_t k = 0; k < rotations_deg.size(); ++k) {
    spec.mount_rotations_deg[static_cast<int>(k)] = rotations_deg[k];
  }
  if (more != nullptr) {
    const std::size_t n = std::max<std::size_t>(1, more->rotations_deg.size());
    for (std::size_t k = 0; k < n; ++k) {
      const auto setup = static_cast<int>(spec.centers_mm.size());
      spec.centers_mm.push_back(more->center_mm);
      if (more->other_radius_mm > 0.0) spec.sphere_radii_mm[setup] = more->other_radius_mm;
      if (k < more->rotations_deg.size()) spec.mount_rotations_deg[setup] = more->rotations_deg[k];
    }
  }
  spec.effects = SimulatedEffects{};
  PlannedDesign out;
  out.points = SimulateExact(spec);
  out.points.source = "the planned design";
  out.calibration.sphere_radius_mm = design.sphere_radius_mm;
  out.calibration.sphere_radii_mm = spec.sphere_radii_mm;
  out.calibration.probe_offset_mm = design.probe_offset_mm;
  out.machine.reference = EffectReferenceOf(out.points.samples);
  out.machine.phi_wobble_pivot_mm = options.phi_wobble_pivot_mm;
  for (const Effect e : options.effects) {
    if (out.machine.Find(e) < 0) out.machine.terms.push_back(DefaultTerm(e, options.harmonics, options.drift_order));
  }
  out.at.geometry = design.truth;
  out.at.centers_mm = spec.centers_mm;
  return out;
}

FormIdentifiability Judge(const SimulationSpec& design, const OrientationPlanOptions& options,
                          const std::vector<Eigen::Vector3d>& rotations_deg) {
  const PlannedDesign d = DesignOf(design, options, rotations_deg);
  return IdentifyForm(d.points, d.calibration, d.machine, d.at, FormTermsOfDegrees(2, options.form_degree_max));
}

// The effects' pairs on the planned orientations (with one more placement, when given); nothing
// when a probe ray of the placement misses its sphere.
std::optional<EffectSeparability> JudgeEffects(const SimulationSpec& design, const OrientationPlanOptions& options,
                                               const std::vector<Eigen::Vector3d>& rotations_deg,
                                               const internal::Placement* more = nullptr) {
  PlannedDesign d;
  try {
    d = DesignOf(design, options, rotations_deg, more);
  } catch (const Error&) {
    if (more == nullptr) throw;
    return std::nullopt;
  }
  return IdentifyEffectPairs(d.points, d.calibration, d.machine, d.at, FormTermsOfDegrees(2, options.form_degree_max));
}

// The factor of the pair (a, b) in `s`, or +inf when it is not among its pairs.
double FactorOf(const EffectSeparability& s, Effect a, Effect b) {
  for (const EffectPairInflation& p : s.pairs) {
    if ((p.a == a && p.b == b) || (p.a == b && p.b == a)) return p.factor;
  }
  return std::numeric_limits<double>::infinity();
}

// The pairs of effects that the plan's orientations leave confounded, each with the placement of
// internal::PlacementsToTry() that separates it best.
void AdviseOnEffects(const SimulationSpec& design, const OrientationPlanOptions& options,
                     const std::vector<Eigen::Vector3d>& rotations_deg, OrientationPlan* plan) {
  const EffectSeparability now = *JudgeEffects(design, options, rotations_deg);
  plan->undetermined = now.undetermined;
  for (const EffectPairInflation& p : now.pairs) {
    if (p.factor > kSeparatedPairInflation) plan->confounded_effects.emplace_back().pair = p;
  }
  std::sort(plan->confounded_effects.begin(), plan->confounded_effects.end(),
            [](const EffectPairAdvice& x, const EffectPairAdvice& y) { return x.pair.factor > y.pair.factor; });
  if (plan->confounded_effects.empty()) return;
  for (const internal::Placement& p :
       internal::PlacementsToTry(design.centers_mm.front(), design.sphere_radius_mm, /*with_form=*/true)) {
    const std::optional<EffectSeparability> with = JudgeEffects(design, options, rotations_deg, &p);
    if (!with) continue;  // a probe ray misses the sphere there
    plan->placements_tried += (plan->placements_tried.empty() ? "" : "; ") + p.words;
    for (EffectPairAdvice& advice : plan->confounded_effects) {
      const double factor = FactorOf(*with, advice.pair.a, advice.pair.b);
      if (factor < advice.factor_with) {
        advice.factor_with = factor;
        advice.placement = factor <= kSeparatedPairInflation ? p.words : "";
        advice.center_mm = p.center_mm;
        advice.other_sphere_radius_mm = p.other_radius_mm;
        advice.rotations_deg = p.rotations_deg;
      }
    }
  }
}

// Fewer confounded terms first; among equals, the smaller largest variance inflation.
bool Better(const FormIdentifiability& a, const FormIdentifiability& b) {
  if (a.confounded.size() != b.confounded.size()) return a.confounded.size() < b.confounded.size();
  return a.MaxVarianceInflation() < b.MaxVarianceInflation();
}

}  // namespace

std::vector<Eigen::Vector3d> DefaultOrientationCandidates() {
  const double third = 120.0 / std::sqrt(3.0);
  return {{0, 0, 90},  {0, 0, 180}, {0, 0, -90}, {90, 0, 0},  {-90, 0, 0},
          {180, 0, 0}, {0, 90, 0},  {0, -90, 0}, {0, 180, 0}, {third, third, third}};
}

OrientationPlan PlanOrientations(const SimulationSpec& design, const OrientationPlanOptions& options) {
  if (design.centers_mm.empty()) throw Error("the planned design has no sphere centre");
  if (options.form_degree_max < 2 || options.form_degree_max > kMaxHarmonicDegree) {
    throw Error("the form's degree to separate must be 2.." + std::to_string(kMaxHarmonicDegree) + ", not " +
                std::to_string(options.form_degree_max));
  }
  if (options.max_orientations < 1) throw Error("a plan holds at least one orientation");
  const std::vector<Eigen::Vector3d> candidates =
      options.candidates_deg.empty() ? DefaultOrientationCandidates() : options.candidates_deg;

  OrientationPlan plan;
  std::vector<Eigen::Vector3d> chosen{Eigen::Vector3d::Zero()};
  plan.steps.push_back({chosen.back(), Judge(design, options, chosen)});
  std::vector<bool> used(candidates.size(), false);
  while (!plan.Separable() && static_cast<int>(chosen.size()) < options.max_orientations) {
    int best = -1;
    FormIdentifiability best_id;
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      if (used[c]) continue;
      std::vector<Eigen::Vector3d> trial = chosen;
      trial.push_back(candidates[c]);
      FormIdentifiability id = Judge(design, options, trial);
      if (best < 0 || Better(id, best_id)) {
        best = static_cast<int>(c);
        best_id = std::move(id);
      }
    }
    if (best < 0 || best_id.confounded.size() >= plan.steps.back().identifiability.confounded.size()) break;
    used[static_cast<std::size_t>(best)] = true;
    chosen.push_back(candidates[static_cast<std::size_t>(best)]);
    plan.steps.push_back({chosen.back(), std::move(best_id)});
  }
  AdviseOnEffects(design, options, chosen, &plan);
  return plan;
}

}  // namespace sph
