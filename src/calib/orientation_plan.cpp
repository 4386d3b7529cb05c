// PlanOrientations(): see sph/calib/orientation_plan.hpp.
#include "sph/calib/orientation_plan.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "sph/core/error.hpp"
#include "sph/model/spherical_harmonics.hpp"

namespace sph {
namespace {

// The design with the sphere at the design's first centre in each of `rotations_deg` (one setup
// each, ids 0, 1, ...), read without noise.
PointsData DesignOf(const SimulationSpec& design, const std::vector<Eigen::Vector3d>& rotations_deg) {
  SimulationSpec spec = design;
  spec.centers_mm.assign(rotations_deg.size(), design.centers_mm.front());
  spec.mount_rotations_deg.clear();
  spec.mount_unknown.clear();
  for (std::size_t k = 0; k < rotations_deg.size(); ++k) {
    spec.mount_rotations_deg[static_cast<int>(k)] = rotations_deg[k];
  }
  spec.effects = SimulatedEffects{};
  PointsData points = SimulateExact(spec);
  points.source = "the planned design";
  return points;
}

FormIdentifiability Judge(const SimulationSpec& design, const OrientationPlanOptions& options,
                          const std::vector<Eigen::Vector3d>& rotations_deg) {
  const PointsData points = DesignOf(design, rotations_deg);
  CalibrationOptions calibration;
  calibration.sphere_radius_mm = design.sphere_radius_mm;
  calibration.probe_offset_mm = design.probe_offset_mm;
  EffectModel machine;
  machine.reference = EffectReferenceOf(points.samples);
  machine.phi_wobble_pivot_mm = options.phi_wobble_pivot_mm;
  for (const Effect e : options.effects) {
    if (machine.Find(e) < 0) machine.terms.push_back(DefaultTerm(e, options.harmonics, options.drift_order));
  }
  // Linearised at the truth: the seven errors and the centres as simulated, effects and form at 0.
  EffectFitStart at;
  at.geometry = design.truth;
  at.centers_mm = std::vector<Eigen::Vector3d>(rotations_deg.size(), design.centers_mm.front());
  return IdentifyForm(points, calibration, machine, at, FormTermsOfDegrees(2, options.form_degree_max));
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
  return plan;
}

}  // namespace sph
