// How often the residual trace adds an effect: on data without any (false additions) and on data
// with one effect of a given size (detection), over independent noise seeds. A study program, run
// by hand (README.md, "Closing the loop"); it prints one line per case.
//
//   build/bench/trace_study [trials]      (default 100 for the clean case, 40 for the others)
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "sph/calib/trace.hpp"
#include "sph/core/simulate.hpp"
#include "sph/model/units.hpp"

namespace {

struct Case {
  const char* name;
  sph::Effect effect;
  sph::EffectComponent component;
  double value;  // rad or mm
  const char* size;
  std::vector<sph::FormComponent> form;  // instead of an effect: the reference sphere's own form error
};

}  // namespace

int main(int argc, char** argv) {
  const int trials = argc > 1 ? std::atoi(argv[1]) : 0;
  using sph::Effect;
  const double as = sph::kRadPerArcsec, um = sph::kMmPerUm;
  const std::vector<Case> cases{
      {"none", Effect::kProbeDrift, {1, 0, false}, 0.0, "-", {}},
      {"probe_drift.t1", Effect::kProbeDrift, {1, 0, false}, 0.3 * um, "0.3 um", {}},
      {"probe_drift.t1", Effect::kProbeDrift, {1, 0, false}, 0.6 * um, "0.6 um", {}},
      {"theta_encoder.c2", Effect::kThetaEncoder, {2, 0, false}, 3 * as, "3 arcsec", {}},
      {"theta_encoder.c2", Effect::kThetaEncoder, {2, 0, false}, 5 * as, "5 arcsec", {}},
      {"theta_encoder.c2", Effect::kThetaEncoder, {2, 0, false}, 10 * as, "10 arcsec", {}},
      {"probe_gain.u1", Effect::kProbeGain, {1, 0, false}, 1 * um, "1 um (500 ppm)", {}},
      {"probe_gain.u1", Effect::kProbeGain, {1, 0, false}, 10 * um, "10 um (0.5 %)", {}},
      {"form S(3,2)", Effect::kProbeGain, {}, 0.0, "0.2 um", {{3, 2, 0.2}}},
      {"form S(5,3)", Effect::kProbeGain, {}, 0.0, "0.3 um", {{5, 3, 0.3}}},
  };
  sph::CalibrationOptions o;
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  std::printf("the paper's set-up (one position at 2 mm, 24 x 12 points, sigma_r 0.05 um), one effect at a time;\n"
              "'form': the reference sphere's own form error, which no effect of the library is\n");
  std::printf("%-18s %-16s %7s %9s %9s %11s %12s  %s\n", "effect", "size", "trials", "added", "it alone", "ambiguous",
              "unexplained", "effects added (count)");
  for (const Case& c : cases) {
    const bool clean = c.value == 0.0 && c.form.empty();
    const int n = trials > 0 ? trials : (clean ? 100 : 40);
    int any = 0, exact = 0, ambiguous = 0, unexplained = 0;
    std::map<std::string, int> counts;
    for (int seed = 1; seed <= n; ++seed) {
      sph::SimulationSpec spec;
      spec.seed = static_cast<std::uint64_t>(seed);
      if (c.value != 0.0) {
        spec.effects.model.terms = {{c.effect, {c.component}}};
        spec.effects.values = {{c.value}};
      }
      spec.effects.form = c.form;
      const sph::PointsData points = sph::Simulate(spec);
      const sph::CalibrationResult base = sph::Calibrate(points, o);
      const sph::TraceResult r = sph::TraceResidual(points, o, base, sph::TraceOptions{});
      any += !r.added.empty();
      exact += r.added.size() == 1 && r.added[0] == c.effect && c.value != 0.0;
      unexplained += !r.unexplained.empty();
      for (const sph::Ambiguity& a : r.ambiguous) {
        if (a.other != "sphere_form") {
          ++ambiguous;
          break;
        }
      }
      for (sph::Effect e : r.added) counts[sph::InfoOf(e).id]++;
    }
    std::string list;
    for (const auto& [id, k] : counts) list += id + " " + std::to_string(k) + "  ";
    std::printf("%-18s %-16s %7d %9d %9d %11d %12d  %s\n", c.name, c.size, n, any, exact, ambiguous, unexplained,
                list.c_str());
  }
  return 0;
}
