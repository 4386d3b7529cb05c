// sph_montecarlo --plan-orientations: the mount orientations that separate the sphere's form from
// the machine (sph/select/orientation_plan.hpp), as a table or JSON.
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#include "montecarlo_cmd.hpp"
#include "sph/calib/montecarlo.hpp"
#include "sph/calib/montecarlo_report.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/select/orientation_plan.hpp"

namespace sph::apps {
namespace {

using internal::Format;

OrientationPlanOptions PlanOptionsOf(const MonteCarloAppOptions& o) {
  OrientationPlanOptions p;
  for (const std::string& id : o.effects) {
    Effect e;
    EffectFromId(id, &e);  // checked by the option's validator
    p.effects.push_back(e);
  }
  if (o.effects.empty()) {
    for (int e = 0; e < kNumEffects; ++e) p.effects.push_back(static_cast<Effect>(e));
  }
  p.form_degree_max = o.form_degree_max;
  p.max_orientations = o.max_orientations;
  p.phi_wobble_pivot_mm = o.phi_wobble_pivot_mm;
  for (const std::string& text : o.candidate_rotations) {
    p.candidates_deg.push_back(ParseRotationDeg(text, "--candidate-rotation-deg " + internal::Quoted(text),
                                                "rx,ry,rz (a rotation vector in deg, axis times angle)"));
  }
  return p;
}

}  // namespace

int RunOrientationPlan(const MonteCarloAppOptions& o, const MonteCarloStudyOptions& spec, std::ostream& report,
                       OutputFiles& files) {
  std::ostringstream discarded;
  const std::string pattern = o.machine.angles_path.empty() ? Format("%d", o.machine.theta_steps) + " x " +
                                                                  Format("%d", o.machine.phi_steps) + " grid"
                                                            : "pattern " + o.machine.angles_path;
  const std::string json =
      PlanOrientationsReport(o.json_path == "-" ? discarded : report, spec, PlanOptionsOf(o), pattern);
  if (!o.json_path.empty()) files.Stage(o.json_path, [&](std::ostream& f) { f << json; });
  files.Commit();
  return kExitOk;
}

}  // namespace sph::apps
