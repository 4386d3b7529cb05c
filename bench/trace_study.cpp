// How often the residual trace adds an effect: on data without any (false additions) and on data
// with one effect of a given size (detection), over independent noise seeds. A study program, run
// by hand (docs/validation.md, "Tracing the residual"); it prints one line per case.
//
//   build/bench/trace_study [trials]      (default 100 for the clean case, 40 for the others)
//   build/bench/trace_study --false-additions [runs] [WORD]   (default 500; WORD: only the cases named so)
//
// The second form counts the runs that add any effect to data that have none: clean data, data
// with a form error of the sphere in one placement, the same sphere in three orientations on its
// mount, in serpentine, and in one known orientation beside one the file calls unknown, with the
// rate's exact (Clopper-Pearson) 95 % confidence interval.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"
#include "sph/select/trace.hpp"
#include "study_designs.hpp"

namespace {

struct Case {
  const char* name;
  sph::Effect effect;
  sph::EffectComponent component;
  double value;  // rad or mm
  const char* size;
  std::vector<sph::FormComponent> form;  // instead of an effect: the reference sphere's own form error
};

int FalseAdditions(int runs, const std::string& only, const sph::CalibrationOptions& o) {
  struct Clean {
    const char* name;
    bool form;
    bool turned;
    bool serpentine = false;     // each axis' direction alternating: a reversal is identifiable
    bool known_unknown = false;  // sph::bench::KnownAndUnknown()
  };
  std::printf(
      "false additions: data without any effect of the machine, %d runs per case, sigma_r 0.05 um,\n"
      "the paper's pattern at 2 mm; form28: 0.050 um rms of degrees 2..8; turned: three setups, the sphere\n"
      "at 0 deg, turned by 90 deg about z and tilted by 90 deg about x, each in another scan order;\n"
      "serpentine: one placement, the Theta direction alternating ring to ring; known+unknown: two setups,\n"
      "the sphere in one known orientation and turned by 90 deg about y in one the file calls unknown\n",
      runs);
  std::printf("%-28s %6s %6s %8s %22s  %s\n", "case", "runs", "added", "rate", "95 % interval (exact)",
              "effects added (count)");
  for (const Clean& c :
       {Clean{"clean, one placement", false, false}, Clean{"form28, one placement", true, false},
        Clean{"form28, turned", true, true}, Clean{"clean, serpentine", false, false, true},
        Clean{"form28, serpentine", true, false, true}, Clean{"clean, known+unknown", false, false, false, true},
        Clean{"form28, known+unknown", true, false, false, true}}) {
    if (std::string(c.name).find(only) == std::string::npos) continue;
    int added = 0;
    std::map<std::string, int> counts;
    for (int seed = 1; seed <= runs; ++seed) {
      sph::SimulationSpec spec;
      spec.seed = static_cast<std::uint64_t>(1000 + seed);
      if (c.form) spec.effects.form = sph::bench::Form28();
      if (c.serpentine) spec.scan_order = sph::ScanOrder::kSerpentine;
      if (c.known_unknown) sph::bench::KnownAndUnknown(spec);
      if (c.turned) {
        spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(2, 0, 0)};
        spec.mount_rotations_deg = {{1, {0, 0, 90}}, {2, {90, 0, 0}}};
        spec.scan_orders = {{1, sph::ScanOrder::kSerpentine}, {2, sph::ScanOrder::kColumns}};
      }
      const sph::PointsData points = sph::Simulate(spec);
      const sph::TraceResult r = sph::TraceResidual(points, o, sph::Calibrate(points, o), sph::TraceOptions{});
      added += !r.added.empty();
      for (sph::Effect e : r.added) counts[sph::InfoOf(e).id]++;
    }
    const auto [lo, hi] = sph::bench::ClopperPearson(added, runs);
    std::string list;
    for (const auto& [id, k] : counts) list += id + " " + std::to_string(k) + "  ";
    std::printf("%-28s %6d %6d %7.2f%% %9.2f%% to %6.2f%%  %s\n", c.name, runs, added, 100.0 * added / runs, 100.0 * lo,
                100.0 * hi, list.c_str());
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  sph::CalibrationOptions paper;
  paper.sphere_radius_mm = 20.0;
  paper.probe_offset_mm = 25.0;
  if (argc > 1 && std::strcmp(argv[1], "--false-additions") == 0) {
    return FalseAdditions(argc > 2 ? std::atoi(argv[2]) : 500, argc > 3 ? argv[3] : "", paper);
  }
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
  const sph::CalibrationOptions& o = paper;
  std::printf(
      "the paper's set-up (one position at 2 mm, 24 x 12 points, sigma_r 0.05 um), one effect at a time;\n"
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
