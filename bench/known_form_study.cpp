// The everyday calibration with the sphere's form known from a separation run: what the residual
// trace finds in one placement with the form as a prior (CalibrationOptions::form_prior) beside
// what it finds without it. A study program, run by hand (docs/validation.md, "A known form in
// one placement"):
//
//   build/bench/known_form_study [SEEDS]                  (default 5 seeds per cell)
//   build/bench/known_form_study --false-additions [RUNS] (default 500)
//   build/bench/known_form_study --case EFFECTS SIGMA_UM SEED [without|with|x100]
//       (one daily run traced, its report printed; EFFECTS ids joined by '+', or none)
//   build/bench/known_form_study --fisher SIGMA_UM
//       (what the Fisher information of one placement says of each effect beside the seven
//       errors, the centre and the form: free of degrees 2..6 or 2..8, known, known x100, and
//       known with the degrees above the known ones free)
//   build/bench/known_form_study --bound [SEEDS [L]]      (default 10 seeds per ratio, the bound on degrees 2..4)
//
// For each noise level (sigma_r 0.03 and 0.05 um) the sphere of form28 (0.050 um rms, degrees 2..8)
// is first separated as a lab would: measured in three known orientations on its mount, the
// calibration workflow run, its calibration file made; the prior is that file's form
// (FormPriorOfFile()). Then daily one-placement data of the same sphere (other seeds) with the
// effects {probe drift, probe nonlinearity, Theta encoder, Phi encoder} alone and in pairs are
// traced without the form, with it, and with its covariance inflated 100 times. Per cell: right
// (exactly the simulated effects added), wrong (an effect added that was not simulated), the rest
// (an effect missed, none wrong: the trace named it ambiguous or found it too small). Then the
// sphere turned by 90 deg about Theta in the daily run: its rotation stated (the verdict should
// be "agrees" and the drift found) and not stated (the reference orientation assumed:
// "disagrees"). The second form counts the runs that add any effect to clean one-placement data
// of the same sphere with its form known, with the rate's exact 95 % interval. The third: a
// certificate's bound (sphere_form_rms_um, degrees 2..L) on one placement of a sphere whose form of
// degrees 2..4 (0.043 um rms) is 3, 2, 1.5, 1 and 0.67 times the bound, with a probe drift: how
// often the form is reported to exceed its bound (KnownFormCheck::exceeds_bound), beside the
// prior's plain chi-square and the form fitted larger than the bound.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "sph/calib/calibrate_workflow.hpp"
#include "sph/calib/known_form.hpp"
#include "sph/model/units.hpp"
#include "sph/select/trace.hpp"
#include "sph/select/trace_report.hpp"
#include "sph/simulation/simulate.hpp"
#include "study_designs.hpp"

namespace {

using sph::Effect;

struct Simulated {
  Effect effect;
  sph::EffectComponent component;
  double value;  // rad or mm
};

// The effects a daily check is for, at the separation matrix's sizes.
const std::map<Effect, Simulated>& Library() {
  const double as = sph::kRadPerArcsec, um = sph::kMmPerUm;
  static const std::map<Effect, Simulated> library{
      {Effect::kProbeDrift, {Effect::kProbeDrift, {1, 0, false}, 0.4 * um}},
      {Effect::kProbeNonlinearity, {Effect::kProbeNonlinearity, {3, 0, false}, 0.15 * um}},
      {Effect::kThetaEncoder, {Effect::kThetaEncoder, {3, 0, false}, 5 * as}},
      {Effect::kPhiEncoder, {Effect::kPhiEncoder, {1, 0, false}, 10 * as}},
  };
  return library;
}

std::vector<std::vector<Effect>> Cases() {
  std::vector<Effect> four;
  for (const auto& [e, s] : Library()) four.push_back(e);
  std::vector<std::vector<Effect>> cases;
  for (const Effect e : four) cases.push_back({e});
  for (std::size_t i = 0; i < four.size(); ++i) {
    for (std::size_t j = i + 1; j < four.size(); ++j) cases.push_back({four[i], four[j]});
  }
  return cases;
}

std::string Name(const std::vector<Effect>& effects) {
  std::string s;
  for (const Effect e : effects) s += (s.empty() ? "" : "+") + std::string(sph::InfoOf(e).id);
  return s.empty() ? "none" : s;
}

sph::CalibrationOptions Paper() {
  sph::CalibrationOptions o;
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  return o;
}

// The separation run: form28 in three known orientations at (2, 0, 0) mm, no machine effects;
// its calibration file's form as the prior.
sph::FormPrior Separate(double noise_um) {
  sph::SimulationSpec spec;
  spec.seed = 1000;
  spec.noise_r_um = noise_um;
  spec.centers_mm.assign(3, Eigen::Vector3d(2, 0, 0));
  spec.mount_rotations_deg = {{1, {0, 0, 90}}, {2, {90, 0, 0}}};
  spec.scan_orders = {{1, sph::ScanOrder::kSerpentine}, {2, sph::ScanOrder::kColumns}};
  spec.effects.form = sph::bench::Form28();
  sph::CalibrationWorkflowOptions o;
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  const sph::CalibrationWorkflowResult run = sph::RunCalibrationWorkflow(sph::Simulate(spec), "separation", o);
  const sph::CalibrationFile file = run.MakeCalibrationFile();
  std::vector<std::string> notes;
  sph::FormPrior prior = sph::FormPriorOfFile(file, "separation", &notes);
  for (const std::string& n : notes) std::printf("  note: %s\n", n.c_str());
  std::vector<double> mean(prior.terms.size());
  for (std::size_t i = 0; i < mean.size(); ++i) mean[i] = prior.mean_mm(static_cast<Eigen::Index>(i));
  std::printf("separation at sigma %.2f um: form of degrees 2..%d, %.4f um rms (simulated %.4f)\n", noise_um,
              prior.terms.back().l, sph::FormRms(prior.terms, mean) * sph::kUmPerMm,
              sph::FormSizeOf(spec.effects, 20.0).rms_um);
  return prior;
}

sph::PointsData Daily(const std::vector<Effect>& effects, double noise_um, std::uint64_t seed, double turn_deg = 0.0) {
  sph::SimulationSpec spec;
  spec.seed = seed;
  spec.noise_r_um = noise_um;
  for (const Effect e : effects) {
    const Simulated& s = Library().at(e);
    spec.effects.model.terms.push_back({s.effect, {s.component}});
    spec.effects.values.push_back({s.value});
  }
  spec.effects.form = sph::bench::Form28();
  if (turn_deg != 0.0) spec.mount_rotations_deg[0] = Eigen::Vector3d(0, 0, turn_deg);
  return sph::Simulate(spec);
}

struct Traced {
  sph::TraceResult trace;
  sph::CalibrationOptions options;
};

Traced Trace(const sph::PointsData& points, const sph::FormPrior* prior) {
  Traced t;
  t.options = Paper();
  if (prior != nullptr) t.options.form_prior = *prior;
  const sph::CalibrationResult base = sph::Calibrate(points, t.options);
  t.trace = sph::TraceResidual(points, t.options, base, sph::TraceOptions{});
  return t;
}

// 'r' right, 'w' wrong, 'o' other (missed, nothing wrong).
char Judge(const sph::TraceResult& r, const std::vector<Effect>& truth) {
  for (const Effect e : r.added) {
    if (std::find(truth.begin(), truth.end(), e) == truth.end()) return 'w';
  }
  return r.added.size() == truth.size() ? 'r' : 'o';
}

struct Tally {
  int right = 0, wrong = 0, other = 0;
  std::map<std::string, int> added;
  void Add(const sph::TraceResult& r, const std::vector<Effect>& truth) {
    const char j = Judge(r, truth);
    (j == 'r' ? right : j == 'w' ? wrong : other) += 1;
    added[Name(r.added)] += 1;
  }
  std::string Text() const {
    char head[64];
    std::snprintf(head, sizeof head, "%2d/%2d/%2d", right, wrong, other);
    return head;
  }
};

int FalseAdditions(int runs) {
  const sph::FormPrior prior = Separate(0.03);
  int added = 0;
  for (int run = 1; run <= runs; ++run) {
    const Traced t = Trace(Daily({}, 0.03, static_cast<std::uint64_t>(run)), &prior);
    if (!t.trace.added.empty()) {
      ++added;
      std::printf("  run %d added %s\n", run, Name(t.trace.added).c_str());
    }
    if (run % 50 == 0) std::printf("  %d runs, %d with an addition\n", run, added), std::fflush(stdout);
  }
  std::printf(
      "false additions with the form known, one placement, sigma 0.03 um: %d of %d (%.2f %%, 95 %% upper %.2f %%)\n",
      added, runs, 100.0 * added / runs, 100.0 * sph::bench::ClopperPearson(added, runs).second);
  return 0;
}

// One daily run traced, its trace report printed: what a cell's counts come from.
int OneCase(const std::string& ids, double noise_um, std::uint64_t seed, const std::string& prior_kind) {
  std::vector<Effect> effects;
  for (std::size_t at = 0; ids != "none" && at <= ids.size();) {
    const std::size_t end = std::min(ids.find('+', at), ids.size());
    Effect e{};
    if (!sph::EffectFromId(ids.substr(at, end - at), &e) || Library().count(e) == 0) {
      std::fprintf(stderr, "known_form_study: %s is not one of the study's effects\n", ids.substr(at, end - at).c_str());
      return 2;
    }
    effects.push_back(e);
    at = end + 1;
  }
  sph::FormPrior prior = Separate(noise_um);
  if (prior_kind == "x100") prior.covariance_mm2 *= 100.0;
  const Traced t = Trace(Daily(effects, noise_um, seed), prior_kind == "without" ? nullptr : &prior);
  sph::WriteTraceText(std::cout, t.trace, nullptr);
  std::printf("simulated %s, added %s: %c\n", Name(effects).c_str(), Name(t.trace.added).c_str(),
              Judge(t.trace, effects));
  return 0;
}

// The Fisher information of one placement (daily data of the sphere, seed 1) for each effect's
// simulated component alone beside the seven errors and the centre, with the form: none, free of
// degrees 2..6 and 2..8 (no prior), known from the separation (its degrees), known x100, and
// either with the degrees above the known ones free up to 8: its variance inflation and its t
// (simulated value over its standard uncertainty at the readings' noise).
int Fisher(double noise_um) {
  const sph::FormPrior known = Separate(noise_um);
  sph::FormPrior loose = known;
  loose.covariance_mm2 *= 100.0;
  const sph::PointsData points = Daily({}, noise_um, 1);
  sph::CalibrationOptions plain = Paper();
  plain.prior_sigma_mm = noise_um * sph::kMmPerUm;
  const sph::CalibrationResult base = sph::Calibrate(points, plain);
  struct FormCase {
    const char* name;
    int degree;
    const sph::FormPrior* prior;
  };
  const int l_known = known.terms.back().l;
  const FormCase forms[] = {{"no form", 0, nullptr},     {"free 2..6", 6, nullptr},
                            {"free 2..8", 8, nullptr},   {"known", l_known, &known},
                            {"known x100", l_known, &loose}, {"known + free to 8", 8, &known},
                            {"known x100 + free to 8", 8, &loose}};
  std::printf("Fisher information, one placement, sigma %.2f um: VIF and t of each effect's simulated component\n",
              noise_um);
  for (const auto& [e, sim] : Library()) {
    std::printf("  %-20s", sph::InfoOf(e).id);
    for (const FormCase& f : forms) {
      sph::CalibrationOptions o = plain;
      if (f.prior != nullptr) o.form_prior = *f.prior;
      sph::EffectModel model;
      model.reference = sph::EffectReferenceOf(points.samples);
      model.terms.push_back({e, {sim.component}});
      if (f.degree > 0) model.form = sph::FormModelOf(points, sph::FormTermsOfDegrees(2, f.degree));
      sph::EffectFitStart start = sph::EffectFitStart::From(base);
      if (f.prior != nullptr) {  // from the known form's mean
        start.form_values.assign(1, std::vector<double>(model.form.terms.size(), 0.0));
        for (std::size_t k = 0; k < f.prior->terms.size(); ++k) {
          const auto it = std::find(model.form.terms.begin(), model.form.terms.end(), f.prior->terms[k]);
          start.form_values[0][static_cast<std::size_t>(it - model.form.terms.begin())] =
              f.prior->mean_mm(static_cast<Eigen::Index>(k));
        }
      }
      const sph::EffectFit fit = sph::FitEffects(points, o, model, start);
      const int col = fit.TermOffset(0);
      const sph::ObservabilityReport& a = fit.calibration.analysis;
      const double std_si = std::sqrt(a.covariance(col, col)) / a.residual_sigma_mm * noise_um * sph::kMmPerUm;
      std::printf(" | %s: VIF %.3g t %.3g", f.name, a.vif(col), std::abs(sim.value) / std_si);
    }
    std::printf("\n");
  }
  return 0;
}

int Bound(int seeds, int degree_max) {
  const std::vector<sph::FormComponent> form = {{2, 0, 0.08}, {3, 1, 0.05}, {4, -2, 0.04}};
  sph::SimulatedEffects set;
  set.form = form;
  const double rms_um = sph::FormSizeOf(set, 20.0).rms_um;
  std::printf(
      "form of degrees 2..4, %.4f um rms; one placement, sigma 0.03 um, probe drift 0.4 um; the bound on degrees "
      "2..%d; seeds 11..%d\n",
      rms_um, degree_max, 10 + seeds);
  for (const double ratio : {3.0, 2.0, 1.5, 1.0, 0.67}) {
    sph::CalibrationWorkflowOptions o;
    o.sphere_radius_mm = 20.0;
    o.probe_offset_mm = 25.0;
    o.conditions.sphere_form_rms_um = rms_um / ratio;
    o.trace_options.form_degree_max = degree_max;
    int exceeds = 0, plain = 0, larger = 0;
    for (int s = 11; s <= 10 + seeds; ++s) {
      sph::SimulationSpec spec;
      spec.seed = static_cast<std::uint64_t>(s);
      spec.noise_r_um = 0.03;
      spec.effects.form = form;
      spec.effects.model.terms = {{Effect::kProbeDrift, {{1, 0, false}}}};
      spec.effects.values = {{0.4 * sph::kMmPerUm}};
      const sph::CalibrationWorkflowResult run = sph::RunCalibrationWorkflow(sph::Simulate(spec), "daily", o);
      const sph::KnownFormCheck& k = *run.known_form;
      exceeds += k.exceeds_bound ? 1 : 0;
      plain += k.p_value < sph::kKnownFormP ? 1 : 0;
      larger += k.fitted_rms_um > *k.bound_rms_um ? 1 : 0;
      std::printf(
          "  form %.2f x bound, seed %d: fitted %.4f um, chi2 %.1f p %.3g, conflict chi2 %.1f for %d p %.3g%s\n", ratio,
          s, k.fitted_rms_um, k.chi_square, k.p_value, k.conflict_chi_square, k.conflict_dof, k.conflict_p_value,
          k.exceeds_bound ? " exceeds" : "");
    }
    std::printf("form %.2f x bound: exceeds %d/%d; prior's chi2 p < %.2g %d/%d; fitted rms > bound %d/%d\n", ratio,
                exceeds, seeds, sph::kKnownFormP, plain, seeds, larger, seeds);
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 3 && std::strcmp(argv[1], "--fisher") == 0) return Fisher(std::atof(argv[2]));
  if (argc >= 5 && std::strcmp(argv[1], "--case") == 0) {
    return OneCase(argv[2], std::atof(argv[3]), static_cast<std::uint64_t>(std::atoll(argv[4])),
                   argc >= 6 ? argv[5] : "with");
  }
  if (argc >= 2 && std::strcmp(argv[1], "--false-additions") == 0) {
    return FalseAdditions(argc >= 3 ? std::atoi(argv[2]) : 500);
  }
  if (argc >= 2 && std::strcmp(argv[1], "--bound") == 0) {
    return Bound(argc >= 3 ? std::atoi(argv[2]) : 10, argc >= 4 ? std::atoi(argv[3]) : 4);
  }
  const int seeds = argc >= 2 ? std::atoi(argv[1]) : 5;
  std::printf("right/wrong/other of %d seeds per cell: without the form | with it | its covariance x100\n", seeds);
  for (const double noise : {0.03, 0.05}) {
    const sph::FormPrior prior = Separate(noise);
    sph::FormPrior inflated = prior;
    inflated.covariance_mm2 *= 100.0;
    Tally total[3];
    for (const std::vector<Effect>& c : Cases()) {
      Tally cell[3];
      for (int s = 1; s <= seeds; ++s) {
        const sph::PointsData points = Daily(c, noise, static_cast<std::uint64_t>(s));
        const sph::FormPrior* priors[3] = {nullptr, &prior, &inflated};
        for (int k = 0; k < 3; ++k) {
          const Traced t = Trace(points, priors[k]);
          cell[k].Add(t.trace, c);
          total[k].Add(t.trace, c);
        }
      }
      std::string with_added;
      for (const auto& [name, n] : cell[1].added) with_added += " " + name + " x" + std::to_string(n);
      std::printf("sigma %.2f %-36s %s | %s | %s   with: %s\n", noise, Name(c).c_str(), cell[0].Text().c_str(),
                  cell[1].Text().c_str(), cell[2].Text().c_str(), with_added.c_str());
      std::fflush(stdout);
    }
    std::printf("sigma %.2f %-36s %s | %s | %s\n", noise, "all", total[0].Text().c_str(), total[1].Text().c_str(),
                total[2].Text().c_str());
    // The sphere turned by 90 deg about Theta in the daily run, with a probe drift.
    int agree_stated = 0, drift_stated = 0, disagree_unstated = 0;
    for (int s = 1; s <= seeds; ++s) {
      const sph::PointsData stated = Daily({Effect::kProbeDrift}, noise, static_cast<std::uint64_t>(s), 90.0);
      sph::PointsData unstated = stated;
      unstated.header.mount_rotations.clear();
      const Traced a = Trace(stated, &prior);
      const sph::KnownFormCheck ka = sph::CheckKnownForm(stated, a.options, a.trace.after.fit, "separation", {}, true);
      agree_stated += ka.agrees ? 1 : 0;
      drift_stated += Judge(a.trace, {Effect::kProbeDrift}) == 'r' ? 1 : 0;
      const Traced b = Trace(unstated, &prior);
      const sph::KnownFormCheck kb =
          sph::CheckKnownForm(unstated, b.options, b.trace.after.fit, "separation", {}, true);
      disagree_unstated += kb.agrees ? 0 : 1;
      std::printf(
          "  turned 90 deg, seed %d: stated chi2 %.1f p %.3g (%s, added %s); not stated chi2 %.1f p %.3g "
          "(%s, rms %.4f with, %.4f without)\n",
          s, ka.chi_square, ka.p_value, ka.agrees ? "agrees" : "disagrees", Name(a.trace.added).c_str(), kb.chi_square,
          kb.p_value, kb.agrees ? "agrees" : "disagrees", kb.rms_with_um, kb.rms_without_um);
    }
    std::printf(
        "sigma %.2f turned 90 deg about Theta: stated: agrees %d/%d, drift right %d/%d; not stated: disagrees %d/%d\n",
        noise, agree_stated, seeds, drift_stated, seeds, disagree_unstated, seeds);
    std::fflush(stdout);
  }
  return 0;
}
