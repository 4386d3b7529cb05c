// The separation matrix: what the residual trace finds on data made by the simulator (ray-traced,
// independent of the fit), for each library effect alone, every pair among six of them and three
// at once, each with and without a form error of the sphere (0.050 um rms of degrees 2..8), in one
// placement, with the sphere in three orientations on its mount, in five placements, in five
// placements beside a second sphere of another radius, in five placements of one sphere that
// reach 15 mm up and 6 mm out, and in one placement scanned in shuffled order (Design()), at two
// noise levels; and the reversal value of each axis (2, 4, 8 arcsec) in one placement scanned ring
// by ring and in serpentine. A study program, run by hand
// (docs/validation.md, "The separation matrix"):
//
//   build/bench/separation_matrix [RUNS] [FILTER...]   (default 5 runs per cell, seeds 1..RUNS)
//
// Each FILTER narrows the cells run: "one", "three", "five", "spheres", "high", "shuffled" or
// "serpentine" (the design), "form" or "noform",
// "0.03" or "0.05" (sigma), or any other word, which the effects' names must contain (e.g.
// "phi_encoder+probe_gain"). "-v" prints each run's effects added and its candidates' notes.
// "hold" runs the trace with TraceOptions::hold_confounded: of two effects it cannot tell
// apart it adds neither. "confounded" runs only the cells of ConfoundedCells() instead: each a
// set of effects and a design of its own in which a single library effect or a pair of them
// imitates the simulated ones (with "0.03" or "0.05" to narrow them).
//
// Prints a row per cell (right: exactly the simulated effects added; wrong: an effect added that
// was not simulated; flagged: of the wrong runs, those whose every wrong effect the report names as
// an explanation it cannot tell from a simulated effect (ambiguous, with the measurement that
// would separate them); form ratio: the form rms found over the simulated one, median; cv/sigma:
// the cross-validated rms over the noise, median; the effects added with their counts), then a
// summary per group of cases.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"
#include "sph/select/form_report.hpp"
#include "sph/select/trace.hpp"
#include "study_designs.hpp"

namespace {

using sph::Effect;

// One simulated effect: a component of a library effect and its size (rad or mm).
struct Simulated {
  Effect effect;
  sph::EffectComponent component;
  double value;
};

constexpr double kPivotMm = 80.0;  // the Phi wobble's pivot, told to the simulator and the trace

const std::map<Effect, Simulated>& Library() {
  const double as = sph::kRadPerArcsec, um = sph::kMmPerUm;
  static const std::map<Effect, Simulated> library{
      {Effect::kThetaEncoder, {Effect::kThetaEncoder, {3, 0, false}, 5 * as}},
      {Effect::kPhiEncoder, {Effect::kPhiEncoder, {1, 0, false}, 10 * as}},
      {Effect::kThetaRadialMotion, {Effect::kThetaRadialMotion, {2, 0, false}, 0.3 * um}},
      {Effect::kThetaAxialMotion, {Effect::kThetaAxialMotion, {2, 0, false}, 0.3 * um}},
      {Effect::kPhiWobble, {Effect::kPhiWobble, {2, 0, false}, 2 * as}},
      {Effect::kProbeGain, {Effect::kProbeGain, {1, 0, false}, 10 * um}},
      {Effect::kProbeNonlinearity, {Effect::kProbeNonlinearity, {3, 0, false}, 0.15 * um}},
      {Effect::kProbeDrift, {Effect::kProbeDrift, {1, 0, false}, 0.4 * um}},
      {Effect::kPhiRadialMotion, {Effect::kPhiRadialMotion, {2, 0, false}, 0.3 * um}},
      {Effect::kPhiAxialMotion, {Effect::kPhiAxialMotion, {2, 0, false}, 2 * um}},
      {Effect::kThetaTiltMotion, {Effect::kThetaTiltMotion, {2, 0, false}, 10 * as}},
      {Effect::kProbeIncidence, {Effect::kProbeIncidence, {1, 0, false}, 30 * um}},
      {Effect::kThetaReversal, {Effect::kThetaReversal, {1, 0, false}, 0.0}},  // of the size of its case
      {Effect::kPhiReversal, {Effect::kPhiReversal, {1, 0, false}, 0.0}},
  };
  return library;
}

struct Case {
  std::string group;  // "single", "pair", "three", "reversal"
  std::vector<Effect> effects;
  double arcsec = 0.0;  // a reversal case: its value b [arcsec] instead of the library's size
};

std::vector<Case> Cases() {
  std::vector<Case> cases;
  for (const auto& [e, s] : Library()) {
    if (!sph::IsReversal(e)) cases.push_back({"single", {e}});  // the reversals have cases of their own
  }
  const std::vector<Effect> six{Effect::kThetaEncoder, Effect::kPhiEncoder, Effect::kThetaRadialMotion,
                                Effect::kProbeDrift,   Effect::kProbeGain,  Effect::kProbeNonlinearity};
  for (std::size_t i = 0; i < six.size(); ++i) {
    for (std::size_t j = i + 1; j < six.size(); ++j) cases.push_back({"pair", {six[i], six[j]}});
  }
  cases.push_back({"three", {Effect::kThetaEncoder, Effect::kProbeDrift, Effect::kProbeNonlinearity}});
  // The reversal value of each axis at three sizes, run in designs "one" (ring order: every reading
  // approached the same way, the reversal a constant offset of the axis, which its zero takes: not
  // identifiable) and "serpentine" (the axis' direction alternating) only.
  for (const Effect e : {Effect::kThetaReversal, Effect::kPhiReversal}) {
    for (const double b : {2.0, 4.0, 8.0}) cases.push_back({"reversal", {e}, b});
  }
  return cases;
}

// The designs: "one", the paper's pattern at (2, 0, 0) mm; "three", the sphere also turned by 90
// deg about z and tilted by 90 deg about x about its own centre (so that the eccentricity points
// another way on its body in each), each setup in another scan order; "five", three more
// placements besides: turned by 90 deg about z with its mount on the Theta table (centre
// (0, 2, 0) mm), turned by 90 deg about y at another eccentricity and height (1, 0, 3) mm, and by
// 120 deg about (1, 1, 1) at (0, -1, 0) mm: other eccentricities, azimuths and a height, which
// tell a Theta encoder error from a spindle motion and a Phi positioning error from a Phi axis
// motion.
// "spheres" (run only when named): the five placements, the last of them at (0, -6, 0) mm instead,
// and a second sphere, of radius 10 mm, at (2, 0, 0) mm in two setups turned by 90 deg about y
// between them: a probe's gain and its incidence error differ on a sphere only as 1/R against
// 1/R^2, and a wobble of the Phi axis about its pivot differs from a radial motion only through the
// lever between the pivot and the probed point, which the eccentricity changes by +-e.
// "high" (run only when named): one sphere, the five placements with the fourth at (1, 0, 15) mm
// and the last at (0, -6, 0) mm, the placements `sph_montecarlo --plan-orientations` names for the
// pairs that the others leave confounded: 15 mm above the axes' common point the beam meets the
// surface far from its normal, where a probe's gain and its incidence error differ, and the probe
// reads over a span of about 30 mm.
// "shuffled" (run only when named): "one" scanned in shuffled order, which breaks the link between
// the time of a reading and its direction on the sphere: a drift is then no pattern on the sphere.
// "serpentine" (the reversal cases only, and the others when named): "one" scanned so that the
// direction of the axis alternates, ring to ring for Theta (serpentine), column to column for Phi
// (serpentine-columns), the Phi cases in the latter, every other case in the former.
enum class Setups { kOne, kThree, kFive, kSpheres, kHigh, kShuffled, kSerpentine };
constexpr Setups kAllSetups[] = {Setups::kOne,  Setups::kThree,    Setups::kFive,      Setups::kSpheres,
                                 Setups::kHigh, Setups::kShuffled, Setups::kSerpentine};
// The designs beyond the main three, run only when named.
bool OnlyWhenNamed(Setups s) {
  return s == Setups::kSpheres || s == Setups::kHigh || s == Setups::kShuffled || s == Setups::kSerpentine;
}
// The designs of a reversal case: one placement, in ring order and in serpentine.
bool ReversalDesign(Setups s) { return s == Setups::kOne || s == Setups::kSerpentine; }
const char* SetupsName(Setups s) {
  switch (s) {
    case Setups::kOne:
      return "one";
    case Setups::kThree:
      return "three";
    case Setups::kFive:
      return "five";
    case Setups::kSpheres:
      return "spheres";
    case Setups::kHigh:
      return "high";
    case Setups::kShuffled:
      return "shuffled";
    case Setups::kSerpentine:
      return "serpentine";
  }
  return "";
}

sph::SimulationSpec Design(const Case& c, bool form, Setups setups, double noise_um, std::uint64_t seed) {
  sph::SimulationSpec spec;
  spec.seed = seed;
  spec.noise_r_um = noise_um;
  if (setups == Setups::kShuffled) spec.scan_order = sph::ScanOrder::kShuffled;
  if (setups == Setups::kSerpentine) {
    const bool phi = std::find(c.effects.begin(), c.effects.end(), Effect::kPhiReversal) != c.effects.end();
    spec.scan_order = phi ? sph::ScanOrder::kSerpentineColumns : sph::ScanOrder::kSerpentine;
  }
  if (setups == Setups::kThree) {
    spec.centers_mm.assign(3, Eigen::Vector3d(2, 0, 0));
    spec.mount_rotations_deg = {{1, {0, 0, 90}}, {2, {90, 0, 0}}};
    spec.scan_orders = {{1, sph::ScanOrder::kSerpentine}, {2, sph::ScanOrder::kColumns}};
  } else if (setups == Setups::kFive || setups == Setups::kSpheres || setups == Setups::kHigh) {
    const double third = 120.0 / std::sqrt(3.0);
    spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0),
                       Eigen::Vector3d(1, 0, 3), Eigen::Vector3d(0, -1, 0)};
    spec.mount_rotations_deg = {{1, {90, 0, 0}}, {2, {0, 0, 90}}, {3, {0, 90, 0}}, {4, {third, third, third}}};
    spec.scan_orders = {{1, sph::ScanOrder::kColumns},
                        {2, sph::ScanOrder::kSerpentine},
                        {3, sph::ScanOrder::kReversed},
                        {4, sph::ScanOrder::kShuffled}};
    if (setups == Setups::kHigh) {
      spec.centers_mm[3] = Eigen::Vector3d(1, 0, 15);
      spec.centers_mm[4] = Eigen::Vector3d(0, -6, 0);
    }
    if (setups == Setups::kSpheres) {
      spec.centers_mm[4] = Eigen::Vector3d(0, -6, 0);
      spec.centers_mm.insert(spec.centers_mm.end(), 2, Eigen::Vector3d(2, 0, 0));
      spec.sphere_radii_mm = {{5, 10.0}, {6, 10.0}};
      spec.mount_rotations_deg[6] = {0, 90, 0};
      spec.scan_orders[6] = sph::ScanOrder::kSerpentine;
    }
  }
  spec.effects.model.phi_wobble_pivot_mm = kPivotMm;
  for (const Effect e : c.effects) {
    const Simulated& s = Library().at(e);
    spec.effects.model.terms.push_back({s.effect, {s.component}});
    spec.effects.values.push_back({c.arcsec != 0.0 ? -c.arcsec * sph::kRadPerArcsec : s.value});
  }
  if (form) spec.effects.form = sph::bench::Form28();
  return spec;
}

// Cells with a design of their own, where a single effect or a pair imitates the simulated set:
// a Phi encoder error once per turn (10 arcsec) and a probe drift of 1 um, one placement (a Phi
// radial motion takes part of each); a Phi encoder error and form28 with the sphere in one known
// orientation and remounted in one the file calls unknown (KnownAndUnknown(): a drift in time
// takes what differs between the two setups' forms), and the same with a true drift of 0.4 um,
// beside the encoder error and alone; a probe incidence error (i1 = 30 um) with the sphere at
// (2, 0, 0) and (0, 1, 0) mm (a gain imitates it: with one radius both leave a term in sin^2 psi),
// and the same beside a second sphere, of radius 10 mm, at (2, 0, 0) mm (gain as 1/R, incidence as
// 1/R^2: told apart).
struct ConfoundedCell {
  std::string name;
  std::vector<Effect> effects;  // simulated, with their Library() sizes but for the drift's
  std::function<void(sph::SimulationSpec&)> design;
};

std::vector<ConfoundedCell> ConfoundedCells() {
  const auto WithForm28 = [](sph::SimulationSpec& spec) {
    sph::bench::KnownAndUnknown(spec);
    spec.effects.form = sph::bench::Form28();
  };
  return {
      {"phi_encoder+probe_drift_1um, one",
       {Effect::kPhiEncoder, Effect::kProbeDrift},
       [](sph::SimulationSpec& spec) { spec.effects.values[1] = {1.0 * sph::kMmPerUm}; }},
      {"phi_encoder+form28, known+unknown", {Effect::kPhiEncoder}, WithForm28},
      {"phi_encoder+probe_drift+form28, known+unknown", {Effect::kPhiEncoder, Effect::kProbeDrift}, WithForm28},
      {"probe_drift+form28, known+unknown", {Effect::kProbeDrift}, WithForm28},
      {"probe_incidence, two placements",
       {Effect::kProbeIncidence},
       [](sph::SimulationSpec& spec) {
         spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 1, 0)};
       }},
      {"probe_incidence, two placements + sphere 10mm",
       {Effect::kProbeIncidence},
       [](sph::SimulationSpec& spec) {
         spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(2, 0, 0)};
         spec.sphere_radii_mm = {{2, 10.0}};
       }},
  };
}

double Median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string Name(const Case& c) {
  std::string s;
  for (const Effect e : c.effects) s += (s.empty() ? "" : "+") + std::string(sph::InfoOf(e).id);
  if (c.arcsec != 0.0) s += " " + std::to_string(static_cast<int>(c.arcsec)) + "arcsec";
  return s;
}

std::string Name(const std::vector<Effect>& effects) { return Name(Case{"", effects}); }

struct Tally {
  int runs = 0, right = 0, wrong = 0;
  int flagged = 0;  // runs with a wrong effect, each of which the trace named as ambiguous with a simulated one
  std::vector<double> form_ratio, cv_over_sigma;
};

// Whether the trace `r` added a wrong effect and the report names each wrong effect it added, with
// a simulated one, as an explanation it cannot tell apart (ambiguous).
bool Flagged(const sph::TraceResult& r, const std::set<Effect>& expected) {
  const auto is_wrong = [&](Effect e) { return expected.count(e) == 0; };
  const auto named = [&](Effect e) {
    return std::any_of(r.ambiguous.begin(), r.ambiguous.end(), [&](const sph::Ambiguity& a) {
      const std::string id = sph::InfoOf(e).id;
      for (const Effect x : expected) {
        const std::string truth = sph::InfoOf(x).id;
        if ((a.chosen == id && a.other == truth) || (a.chosen == truth && a.other == id)) return true;
      }
      return false;
    });
  };
  return std::any_of(r.added.begin(), r.added.end(), is_wrong) &&
         std::all_of(r.added.begin(), r.added.end(), [&](Effect e) { return !is_wrong(e) || named(e); });
}

// The cells asked for on the command line.
struct Filter {
  std::set<std::string> setups, forms, sigmas;
  std::vector<std::string> names;
  bool verbose = false;
  bool hold = false;        // "hold": TraceOptions::hold_confounded
  bool confounded = false;  // "confounded": the cells of ConfoundedCells() only

  bool Wants(const Case& c, Setups setups_, bool form, double noise) const {
    const auto in = [](const std::set<std::string>& s, const std::string& v) { return s.empty() || s.count(v) > 0; };
    const std::string name = Name(c);
    for (const std::string& n : names) {
      if (name.find(n) == std::string::npos) return false;
    }
    // A reversal case only in its designs, there whether named or not; the other cases not in "serpentine"
    // unless it is named.
    if (c.group == "reversal")
      return ReversalDesign(setups_) && in(forms, form ? "form" : "noform") &&
             in(sigmas, noise < 0.04 ? "0.03" : "0.05") && (setups.empty() || setups.count(SetupsName(setups_)) > 0);
    // "spheres", "high" and "shuffled" run only when asked for (docs/validation.md lists them apart).
    if (OnlyWhenNamed(setups_) && setups.count(SetupsName(setups_)) == 0) return false;
    return in(setups, SetupsName(setups_)) && in(forms, form ? "form" : "noform") &&
           in(sigmas, noise < 0.04 ? "0.03" : "0.05");
  }
};

Filter FilterOf(int argc, char** argv) {
  Filter f;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (std::any_of(std::begin(kAllSetups), std::end(kAllSetups), [&a](Setups d) { return a == SetupsName(d); })) {
      f.setups.insert(a);
    } else if (a == "form" || a == "noform") {
      f.forms.insert(a);
    } else if (a == "0.03" || a == "0.05") {
      f.sigmas.insert(a);
    } else if (a == "-v") {
      f.verbose = true;
    } else if (a == "hold") {
      f.hold = true;
    } else if (a == "confounded") {
      f.confounded = true;
    } else {
      f.names.push_back(a);
    }
  }
  return f;
}

// The cells of ConfoundedCells() at both noise levels (or those of the filter): right, wrong and
// the effects added, per cell.
int RunConfoundedCells(int runs, const Filter& filter, const sph::CalibrationOptions& o,
                       const sph::TraceOptions& trace) {
  std::printf("%-46s %5s %5s %6s %6s %7s %8s  %s\n", "cell", "sigma", "runs", "right", "wrong", "flagged", "cv/sig",
              "effects added (count)");
  for (const ConfoundedCell& cell : ConfoundedCells()) {
    for (const double noise : {0.03, 0.05}) {
      if (!filter.sigmas.empty() && filter.sigmas.count(noise < 0.04 ? "0.03" : "0.05") == 0) continue;
      Tally t;
      std::map<std::string, int> counts;
      const std::set<Effect> expected(cell.effects.begin(), cell.effects.end());
      for (int seed = 1; seed <= runs; ++seed) {
        sph::SimulationSpec spec =
            Design({"cell", cell.effects}, false, Setups::kOne, noise, static_cast<std::uint64_t>(seed));
        cell.design(spec);
        const sph::PointsData points = sph::Simulate(spec);
        sph::CalibrationOptions with_radii = o;
        with_radii.sphere_radii_mm = points.header.sphere_radii_mm;
        const sph::TraceResult r = sph::TraceResidual(points, with_radii, sph::Calibrate(points, with_radii), trace);
        const std::set<Effect> added(r.added.begin(), r.added.end());
        ++t.runs;
        t.right += added == expected;
        t.wrong += std::any_of(added.begin(), added.end(), [&](Effect e) { return expected.count(e) == 0; });
        t.flagged += Flagged(r, expected);
        for (const Effect e : added) counts[sph::InfoOf(e).id]++;
        t.cv_over_sigma.push_back(r.after.cv_rms_um / noise);
        if (filter.verbose) {
          std::printf("  seed %d: added %s\n", seed, Name(r.added).c_str());
          for (const sph::Ambiguity& a : r.ambiguous) {
            std::printf("    ambiguous: %s / %s; separate by: %s; checked: %s\n", a.chosen.c_str(), a.other.c_str(),
                        a.separate_by.c_str(), a.checked.c_str());
          }
        }
      }
      std::string list;
      for (const auto& [id, k] : counts) list += id + " " + std::to_string(k) + "  ";
      std::printf("%-46s %5.2f %5d %6d %6d %7d %8.3f  %s\n", cell.name.c_str(), noise, t.runs, t.right, t.wrong,
                  t.flagged, Median(t.cv_over_sigma), list.c_str());
      std::fflush(stdout);
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const int runs = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  const Filter filter = FilterOf(argc, argv);
  sph::CalibrationOptions o;
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  sph::TraceOptions trace;
  trace.phi_wobble_pivot_mm = kPivotMm;
  trace.hold_confounded = filter.hold;
  std::printf(
      "separation matrix: %d runs per cell (seeds 1..%d), the paper's pattern at 2 mm; form: 0.050 um rms of\n"
      "degrees 2..8; three: the sphere also turned by 90 deg about z and tilted by 90 deg about x; five: and\n"
      "at other eccentricities, azimuths and a height; spheres (only when named): five, one at 6 mm, and a\n"
      "second sphere of 10 mm in two orientations; high (only when named): five, one at 15 mm up, one at\n"
      "6 mm; shuffled (only when named): one, scanned in shuffled order; serpentine: one, the axis' direction\n"
      "alternating (reversal cases: a backlash of 2, 4, 8 arcsec, b = -2, -4, -8 arcsec, in one and\n"
      "serpentine only) (bench/separation_matrix.cpp, Design())\n",
      runs, runs);
  if (filter.hold) std::printf("hold: of two effects the trace cannot tell apart it adds neither\n");
  if (filter.confounded) return RunConfoundedCells(runs, filter, o, trace);
  std::printf("%-52s %-5s %-6s %5s %5s %6s %6s %7s %8s %8s  %s\n", "effects", "form", "setup", "sigma", "runs", "right",
              "wrong", "flagged", "form_r", "cv/sig", "effects added (count)");
  std::map<std::string, Tally> summary;  // by group, form, design, sigma
  for (const Case& c : Cases()) {
    for (const double noise : {0.03, 0.05}) {
      for (const Setups setups : kAllSetups) {
        for (const bool form : {false, true}) {
          if (!filter.Wants(c, setups, form, noise)) continue;
          Tally t;
          std::map<std::string, int> counts;
          const std::set<Effect> expected(c.effects.begin(), c.effects.end());
          for (int seed = 1; seed <= runs; ++seed) {
            const sph::SimulationSpec spec = Design(c, form, setups, noise, static_cast<std::uint64_t>(seed));
            const sph::PointsData points = sph::Simulate(spec);
            sph::CalibrationOptions with_radii = o;
            with_radii.sphere_radii_mm = points.header.sphere_radii_mm;
            const sph::TraceResult r =
                sph::TraceResidual(points, with_radii, sph::Calibrate(points, with_radii), trace);
            const std::set<Effect> added(r.added.begin(), r.added.end());
            ++t.runs;
            t.right += added == expected;
            const auto is_wrong = [&](Effect e) { return expected.count(e) == 0; };
            t.wrong += std::any_of(added.begin(), added.end(), is_wrong);
            t.flagged += Flagged(r, expected);
            for (const Effect e : added) counts[sph::InfoOf(e).id]++;
            if (filter.verbose) {
              std::printf("  seed %d: added %s; cv/sigma %.3f\n", seed, Name(r.added).c_str(),
                          r.after.cv_rms_um / noise);
              for (const sph::CandidateScore& cs : r.candidates) {
                std::printf("    round %d %-20s dBIC %8.1f %s%s\n", cs.round, cs.Id().c_str(), cs.delta_bic,
                            cs.added ? "ADDED " : "", cs.note.c_str());
              }
              for (const sph::Ambiguity& a : r.ambiguous) {
                std::printf("    ambiguous: %s / %s\n", a.chosen.c_str(), a.other.c_str());
              }
            }
            t.cv_over_sigma.push_back(r.after.cv_rms_um / noise);
            if (form && r.form.degree_max > 0) {
              const std::vector<sph::SphereFormResult> found = sph::SphereFormOf(r);
              if (!found.empty()) {
                t.form_ratio.push_back(found[0].rms_um / sph::FormSizeOf(spec.effects, spec.sphere_radius_mm).rms_um);
              }
            }
          }
          std::string list;
          for (const auto& [id, k] : counts) list += id + " " + std::to_string(k) + "  ";
          std::printf("%-52s %-5s %-6s %5.2f %5d %6d %6d %7d %8.3f %8.3f  %s\n", Name(c).c_str(), form ? "yes" : "no",
                      SetupsName(setups), noise, t.runs, t.right, t.wrong, t.flagged, Median(t.form_ratio),
                      Median(t.cv_over_sigma), list.c_str());
          std::fflush(stdout);
          Tally& s =
              summary[c.group + (form ? " form " : " - ") + SetupsName(setups) + (noise < 0.04 ? " 0.03" : " 0.05")];
          s.runs += t.runs;
          s.right += t.right;
          s.wrong += t.wrong;
          s.flagged += t.flagged;
          s.form_ratio.insert(s.form_ratio.end(), t.form_ratio.begin(), t.form_ratio.end());
          s.cv_over_sigma.insert(s.cv_over_sigma.end(), t.cv_over_sigma.begin(), t.cv_over_sigma.end());
        }
      }
    }
  }
  std::printf("\nsummary: group form setup sigma | runs right wrong flagged | median form ratio, cv/sigma\n");
  for (const auto& [key, s] : summary) {
    std::printf("%-26s %5d %6d %6d %7d %8.3f %8.3f\n", key.c_str(), s.runs, s.right, s.wrong, s.flagged,
                Median(s.form_ratio), Median(s.cv_over_sigma));
  }
  return 0;
}
