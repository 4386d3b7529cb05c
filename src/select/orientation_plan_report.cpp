// The report of the orientation plan (sph/select/orientation_plan.hpp) of sph_montecarlo
// --plan-orientations: a table per eccentricity, and its JSON.
#include <cmath>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sph/calib/montecarlo_report.hpp"
#include "sph/internal/format.hpp"
#include "sph/select/orientation_plan.hpp"

namespace sph {
namespace {

using internal::Format;
using nlohmann::json;

std::string RotationText(const Eigen::Vector3d& r) { return Format("%g, %g, %g", r.x(), r.y(), r.z()); }

std::string TermsText(const std::vector<FormTerm>& terms) {
  if (terms.empty()) return "none";
  std::string s;
  for (const FormTerm& t : terms) s += (s.empty() ? "" : " ") + Format("S(%d,%d)", t.l, t.m);
  return s;
}

// One eccentricity's plan as text; its JSON.
json Report(std::ostream& out, double e_mm, const Eigen::Vector3d& center_mm, const OrientationPlan& plan,
            int max_orientations) {
  out << "\ne = " << Format("%g", e_mm) << " mm, sphere centre (" << RotationText(center_mm) << ") mm\n";
  out << Format("  %-4s %-22s %10s %9s  %s\n", "step", "mount_rotation_deg", "confounded", "max_vif",
                "form terms still confounded");
  json steps = json::array();
  for (std::size_t k = 0; k < plan.steps.size(); ++k) {
    const OrientationPlanStep& s = plan.steps[k];
    const FormIdentifiability& id = s.identifiability;
    const double vif = id.MaxVarianceInflation();
    out << Format("  %-4zu %-22s %10zu %9.2g  %s\n", k + 1,
                  (RotationText(s.rotation_deg) + (k == 0 ? " (ref.)" : "")).c_str(), id.confounded.size(), vif,
                  TermsText(id.confounded).c_str());
    json confounded = json::array();
    for (const FormTerm& t : id.confounded) confounded.push_back(Format("S(%d,%d)", t.l, t.m));
    json combinations = json::array();
    for (const ConfoundedCombination& c : id.combinations) combinations.push_back(c.words);
    steps.push_back({{"mount_rotation_deg", {s.rotation_deg.x(), s.rotation_deg.y(), s.rotation_deg.z()}},
                     {"confounded", confounded},
                     {"max_variance_inflation", std::isfinite(vif) ? json(vif) : json(nullptr)},
                     {"combinations", combinations}});
  }
  if (plan.Separable()) {
    out << "  separable with " << plan.steps.size() << " orientation(s); in the points file:";
    for (std::size_t k = 0; k < plan.steps.size(); ++k) {
      const Eigen::Vector3d& r = plan.steps[k].rotation_deg;
      out << (k == 0 ? " " : ", ") << "mount_rotation_deg@" << k << ": " << Format("%g %g %g", r.x(), r.y(), r.z());
    }
    out << "\n";
  } else {
    const FormIdentifiability& last = plan.steps.back().identifiability;
    out << "  not separable with these candidates"
        << (static_cast<int>(plan.steps.size()) >= max_orientations
                ? " within " + std::to_string(max_orientations) + " orientations"
                : std::string(": no further one helps"))
        << "; still confounded: " << TermsText(last.confounded) << "\n";
    if (!last.combinations.empty()) out << "  weakest: " << last.combinations.front().words << "\n";
  }
  json undetermined = json::array();
  if (!plan.undetermined.empty()) {
    out << "  effects the design does not see at all beside the seven errors, the centres and the form:";
    for (const Effect e : plan.undetermined) {
      out << " " << InfoOf(e).id;
      undetermined.push_back(InfoOf(e).id);
    }
    out << "\n";
  }
  json pairs = json::array();
  if (plan.confounded_effects.empty()) {
    out << "  the effects are told apart from each other (no pair inflates a component's variance more than "
        << Format("%g", kSeparatedPairInflation) << " times)\n";
  } else {
    out << "  effects these orientations do not tell apart (factor: the most one inflates the variance of a "
           "component of the other; turning the sphere turns its form, not the machine):\n";
  }
  for (const EffectPairAdvice& a : plan.confounded_effects) {
    const char* id_a = InfoOf(a.pair.a).id;
    const char* id_b = InfoOf(a.pair.b).id;
    out << Format("    %s and %s: %.3g; ", id_a, id_b, a.pair.factor)
        << (!a.placement.empty() ? a.placement + Format(": %.3g", a.factor_with)
            : std::isfinite(a.factor_with)
                ? Format("none of the placements tried brings it to %g (at best %.3g)", kSeparatedPairInflation,
                         a.factor_with)
                : Format("none of the placements tried brings it to %g", kSeparatedPairInflation))
        << "\n";
    json pair = {{"a", id_a},
                 {"b", id_b},
                 {"factor", std::isfinite(a.pair.factor) ? json(a.pair.factor) : json(nullptr)},
                 {"placement", a.placement.empty() ? json(nullptr) : json(a.placement)},
                 {"factor_with", std::isfinite(a.factor_with) ? json(a.factor_with) : json(nullptr)}};
    if (!a.placement.empty()) {  // the placement as numbers, for a script that plans the measurement
      json rotations = json::array();
      for (const Eigen::Vector3d& r : a.rotations_deg) rotations.push_back({r.x(), r.y(), r.z()});
      pair["placement_center_mm"] = {a.center_mm.x(), a.center_mm.y(), a.center_mm.z()};
      pair["placement_sphere_radius_mm"] =
          a.other_sphere_radius_mm > 0.0 ? json(a.other_sphere_radius_mm) : json(nullptr);
      pair["placement_mount_rotations_deg"] = rotations;
    }
    pairs.push_back(pair);
  }
  if (!plan.confounded_effects.empty()) out << "  placements tried: " << plan.placements_tried << "\n";
  return {{"eccentricity_mm", e_mm},
          {"center_mm", {center_mm.x(), center_mm.y(), center_mm.z()}},
          {"separable", plan.Separable()},
          {"steps", steps},
          {"undetermined_effects", undetermined},
          {"confounded_effects", pairs},
          {"placements_tried", plan.placements_tried}};
}

}  // namespace

std::string PlanOrientationsReport(std::ostream& out, const MonteCarloStudyOptions& spec,
                                   const OrientationPlanOptions& options, const std::string& pattern) {
  std::string effects;
  for (const Effect e : options.effects) effects += (effects.empty() ? "" : ", ") + std::string(InfoOf(e).id);
  out << "Orientations of the sphere on its mount that separate its form (degrees 2.." << options.form_degree_max
      << ") from the seven errors, the centres and " << (effects.empty() ? std::string("no further effect") : effects)
      << "; judged from the design's Jacobian at the truth (null space, relative singular values below "
      << Format("%g", kConfoundedSingularValue) << " confounded), " << pattern
      << " in every orientation; max_vif: the largest variance inflation of a form term (confounded above "
      << Format("%g", 1.0 / (kConfoundedSingularValue * kConfoundedSingularValue)) << ", inf: reproduced exactly)\n";
  json plans = json::array();
  for (const double e : spec.eccentricities_mm) {
    SimulationSpec design = spec.base;
    design.centers_mm = {PlacementCenters(spec, e).front()};
    plans.push_back(
        Report(out, e, design.centers_mm.front(), PlanOrientations(design, options), options.max_orientations));
  }
  json effect_ids = json::array();
  for (const Effect e : options.effects) effect_ids.push_back(InfoOf(e).id);
  const json j = {{"program", "sph_montecarlo " SPH_VERSION},
                  {"form_degree_max", options.form_degree_max},
                  {"effects", effect_ids},
                  {"confounded_below", kConfoundedSingularValue},
                  {"plans", plans}};
  return j.dump(2) + "\n";
}

}  // namespace sph
