// The lab's statements tested against the readings (sph/calib/statements.hpp): how often a wrong
// one makes the calibration not usable, how often a right one is rejected, and, for a known form
// stated in the wrong mount orientation, how often the orientation the readings support is the
// right one. A study program, run by hand (docs/validation.md, "The lab's statements against the
// readings"):
//
//   build/bench/statement_study --orientation [SEEDS [THREADS [FIRST [SIGMA_UM]]]]   (default 20
//       seeds per cell from 1, both noises; each run's outcome also on stderr, one line)
//       the sphere of form28 in the reference orientation, the daily one-placement run stating
//       it turned by each of the 23 other turns by right angles, or by 5, 15 or 45 deg about x, y
//       or z; 0, 1 or 2 true effects (seed s takes the (s mod 4)-th of the study's four effects, or
//       pair); sigma_r 0.03 and 0.05 um; the known form from a separation run at that noise
//   build/bench/statement_study --false-alarms [RUNS [THREADS]]  (default 500 runs without an
//       effect, RUNS / 10 with each single effect of the library): the right orientation stated
//   build/bench/statement_study --bound [SEEDS [THREADS]]        (default 40 per ratio) the
//       certificate's bound 0.1 to 10 times form28's RMS, as the prior, one placement
//   build/bench/statement_study --prior [SEEDS [THREADS]]        (default 100 per offset) a prior on
//       alpha, and alpha held, 0 to 10 standard uncertainties from the truth
//   build/bench/statement_study --case ROTATION EFFECTS SIGMA_UM SEED
//       (one daily run, its report printed; ROTATION "rx,ry,rz" in deg, EFFECTS ids joined by '+' or
//       none)
//
// THREADS runs calibrations in parallel (each trace on one thread; default 1). Every run's seed is
// its own: the counts do not depend on the threads.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <iterator>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <unistd.h>

#include "sph/calib/calibrate_workflow.hpp"
#include "sph/calib/known_form.hpp"
#include "sph/internal/format.hpp"
#include "sph/internal/parallel.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/spherical_harmonics.hpp"
#include "sph/model/units.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/stats/gum.hpp"
#include "study_designs.hpp"

namespace {

using sph::Effect;

constexpr double kPivotMm = 80.0;  // the Phi wobble's pivot, told to the simulator and the trace

struct Simulated {
  Effect effect;
  sph::EffectComponent component;
  double value;  // rad or mm
};

// The library's effects at the separation matrix's sizes (no reversal: in ring order it is a zero).
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
  };
  return library;
}

// The four effects of a daily check, and their six pairs: seed s takes the (s mod 4)-th or
// (s mod 6)-th.
const std::vector<Effect> kFour{Effect::kProbeDrift, Effect::kThetaEncoder, Effect::kPhiEncoder,
                                Effect::kProbeNonlinearity};

std::vector<Effect> TrueEffects(int count, int seed) {
  if (count == 0) return {};
  if (count == 1) return {kFour[static_cast<std::size_t>(seed % 4)]};
  std::vector<std::vector<Effect>> pairs;
  for (std::size_t i = 0; i < kFour.size(); ++i) {
    for (std::size_t j = i + 1; j < kFour.size(); ++j) pairs.push_back({kFour[i], kFour[j]});
  }
  return pairs[static_cast<std::size_t>(seed % 6)];
}

// The folder of the separations' calibration files.
std::string Folder() {
  static const std::string dir = [] {
    std::string d = "/tmp/statement_study_" + std::to_string(static_cast<long>(getpid()));
    std::system(("mkdir -p " + d).c_str());
    return d;
  }();
  return dir;
}

sph::CalibrationWorkflowOptions Options() {
  sph::CalibrationWorkflowOptions o;
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  o.trace_options.threads = 1;
  o.trace_options.phi_wobble_pivot_mm = kPivotMm;
  return o;
}

// The separation run of form28 at `noise_um` (three known orientations at (2, 0, 0) mm, no machine
// effects), its calibration file written; returns its path.
std::string Separate(double noise_um) {
  sph::SimulationSpec spec;
  spec.seed = 1000;
  spec.noise_r_um = noise_um;
  spec.centers_mm.assign(3, Eigen::Vector3d(2, 0, 0));
  spec.mount_rotations_deg = {{1, {0, 0, 90}}, {2, {90, 0, 0}}};
  spec.scan_orders = {{1, sph::ScanOrder::kSerpentine}, {2, sph::ScanOrder::kColumns}};
  spec.effects.form = sph::bench::Form28();
  const sph::CalibrationWorkflowResult run = sph::RunCalibrationWorkflow(sph::Simulate(spec), "separation", Options());
  const std::string path = Folder() + "/separation_" + sph::internal::Format("%.2f", noise_um) + ".json";
  sph::WriteCalibrationFile(path, run.MakeCalibrationFile());
  return path;
}

// One placement of the sphere with form28 in the reference orientation and `effects`.
sph::PointsData Daily(const std::vector<Effect>& effects, double noise_um, std::uint64_t seed) {
  sph::SimulationSpec spec;
  spec.seed = seed;
  spec.noise_r_um = noise_um;
  for (const Effect e : effects) {
    const Simulated& s = Library().at(e);
    spec.effects.model.terms.push_back({s.effect, {s.component}});
    spec.effects.values.push_back({s.value});
  }
  spec.effects.model.phi_wobble_pivot_mm = kPivotMm;
  spec.effects.form = sph::bench::Form28();
  return sph::Simulate(spec);
}

// The 23 turns by right angles other than none, and 5, 15, 45 deg about x, y, z: rotation vectors
// [deg], with a label.
std::vector<std::pair<std::string, Eigen::Vector3d>> WrongOrientations() {
  std::vector<std::pair<std::string, Eigen::Vector3d>> out;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& p : perms) {
    for (int signs = 0; signs < 8; ++signs) {
      Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
      for (int row = 0; row < 3; ++row) m(row, p[row]) = (signs >> row) & 1 ? -1.0 : 1.0;
      if (m.determinant() < 0.0 || m.isIdentity()) continue;
      const Eigen::AngleAxisd aa(m);
      const Eigen::Vector3d v = aa.axis() * aa.angle() / sph::kRadPerDeg;
      out.emplace_back(sph::internal::Format("turn %.0f,%.0f,%.0f", v.x(), v.y(), v.z()), v);
    }
  }
  for (const double deg : {5.0, 15.0, 45.0}) {
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Vector3d v = Eigen::Vector3d::Zero();
      v(axis) = deg;
      out.emplace_back(sph::internal::Format("%.0f deg about %c", deg, "xyz"[axis]), v);
    }
  }
  return out;
}

// RMS over the sphere [um] of form28 turned by `rotation_deg` less form28: what a wrong statement
// leaves of the form, on 20000 directions uniform on the sphere.
double TurnedDifferenceRmsUm(const Eigen::Vector3d& rotation_deg) {
  const std::vector<sph::FormComponent>& form = sph::bench::Form28();
  const Eigen::Matrix3d r = sph::MountRotationMatrix(rotation_deg);
  const auto value = [&](const Eigen::Vector3d& u) {
    std::vector<double> s;
    sph::SchmidtHarmonicsOf(u.x(), u.y(), u.z(), 8, &s);
    double f = 0.0;
    for (const sph::FormComponent& c : form) f += c.amplitude_um * s[sph::HarmonicIndex(c.l, c.m)];
    return f;
  };
  double sum = 0.0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {  // a Fibonacci lattice
    const double z = 1.0 - (2.0 * i + 1.0) / n;
    const double a = i * 2.39996322972865332;
    const Eigen::Vector3d u(std::sqrt(1.0 - z * z) * std::cos(a), std::sqrt(1.0 - z * z) * std::sin(a), z);
    const double d = value(r.transpose() * u) - value(u);
    sum += d * d;
  }
  return std::sqrt(sum / n);
}

const sph::StatementCheck* FormStatement(const sph::CalibrationWorkflowResult& run) {
  for (const sph::StatementCheck& c : run.statements) {
    if (c.kind == sph::StatementKind::kKnownForm || c.kind == sph::StatementKind::kFormBound) return &c;
  }
  return nullptr;
}

// What one daily run with a known form gave.
struct Outcome {
  bool usable = false, rejected = false, named = false, searched = false;
  int added = 0, withheld = 0, dof = 0;
  double p = 1.0, chi_square = 0.0;
};

Outcome Judge(const sph::CalibrationWorkflowResult& run) {
  Outcome o;
  o.usable = run.usability.usable;
  const sph::StatementCheck* c = FormStatement(run);
  if (c != nullptr) {
    o.rejected = c->rejected;
    o.p = c->p_value;
    o.chi_square = c->chi_square;
    o.dof = c->dof;
    if (c->orientation) {
      o.searched = true;
      const sph::SupportedOrientation& s = *c->orientation;
      // Named right: the readings agree with it and it is the reference orientation (the turn by
      // right angles named is none, and the fitted rotation within 3 u, at least 2 deg, of it).
      const double fitted = s.fitted_deg.norm();
      o.named = s.agrees && s.right_angle_deg.norm() < 1e-6 &&
                (std::isfinite(s.u_deg) ? fitted <= std::max(3.0 * s.u_deg, 2.0) : true);
    }
  }
  if (run.trace) {
    o.added = static_cast<int>(run.trace->added.size() - run.trace->stated.size());
  }
  o.withheld = static_cast<int>(run.withheld.size());
  return o;
}

// The critical value of a known form's test on `dof` degrees of freedom: P(chi^2 > c) = kStatementP
// over the number of its tests (sph::kConflictDetermined; the one of the smaller p is reported).
double Critical(int dof) {
  const double level = sph::kStatementP / static_cast<double>(std::size(sph::kConflictDetermined));
  double lo = 0.0, hi = 1000.0 + 20.0 * dof;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (sph::gum::ChiSquareSf(mid, dof) > level ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// The test's power against a noncentrality `lambda` on `dof` degrees of freedom: P(chi'^2 > c), the
// noncentral chi-square as the Poisson mixture of central ones.
double NoncentralPower(double lambda, int dof) {
  if (dof <= 0) return 0.0;
  const double c = Critical(dof), half = std::max(0.0, 0.5 * lambda);
  double power = 0.0, weight = std::exp(-half);
  for (int j = 0; j < 2000; ++j) {
    if (j > 0) weight *= half / j;
    power += weight * sph::gum::ChiSquareSf(c, dof + 2.0 * j);
    if (j > half && weight < 1e-16) break;
  }
  return std::min(1.0, power);
}

int Orientation(int seeds, int threads, int first, double only_sigma) {
  const std::vector<std::pair<std::string, Eigen::Vector3d>> wrong = WrongOrientations();
  std::mutex print;
  std::printf(
      "wrong mount orientations stated for form28 (0.050 um rms), one placement; %d seeds per cell; the known form "
      "from a separation at the same noise; a statement rejected when p < %g. diff: the rms over the sphere of the "
      "form turned less the form; chi2/dof: the means over the cell of the test reported (of its two, the one of "
      "the smaller p); power: that test's power at half the level and the noncentrality mean(chi2 - dof), an "
      "estimate (resolvable: at least 99 %%); named: of the rejected, the reference "
      "orientation named; added: rejected runs with an effect added; withheld: effects found and not applied, per "
      "run; seeds %d..%d; each run on stderr\n",
      seeds, sph::kStatementP, first, first + seeds - 1);
  std::printf("%-6s %-2s %-18s %7s %7s %5s %7s %5s %11s %9s %7s %6s %9s\n", "sigma", "n", "stated", "diff um", "chi2",
              "dof", "power", "runs", "not usable", "rejected", "named", "added", "withheld");
  for (const double noise : {0.03, 0.05}) {
    if (only_sigma > 0.0 && std::abs(noise - only_sigma) > 1e-9) continue;
    const std::string form = Separate(noise);
    int total_runs = 0, total_rejected = 0, total_named = 0, total_added_rejected = 0, total_resolvable = 0,
        total_rejected_resolvable = 0;
    for (int count = 0; count <= 2; ++count) {
      for (const auto& [label, rotation] : wrong) {
        std::vector<Outcome> out(static_cast<std::size_t>(seeds));
        sph::internal::ParallelFor(out.size(), threads, [&] {
          return [&](std::size_t i) {
            const int seed = static_cast<int>(i) + first;
            sph::PointsData points = Daily(TrueEffects(count, seed), noise, static_cast<std::uint64_t>(seed));
            points.header.mount_rotations[0] = sph::MountRotation::Known(rotation);
            sph::CalibrationWorkflowOptions o = Options();
            o.sphere_form_paths = {form};
            out[i] = Judge(sph::RunCalibrationWorkflow(std::move(points), "daily", o));
            const Outcome& x = out[i];
            std::string tag = label;
            std::replace(tag.begin(), tag.end(), ' ', '_');
            const std::lock_guard<std::mutex> lock(print);
            std::fprintf(
                stderr,
                "run %.2f %d %s %d rejected %d usable %d named %d added %d withheld %d chi2 %.6g dof %d p %.3g\n",
                noise, count, tag.c_str(), seed, x.rejected, x.usable, x.named, x.added, x.withheld, x.chi_square,
                x.dof, x.p);
          };
        });
        int not_usable = 0, rejected = 0, named = 0, added_rejected = 0, withheld = 0;
        double chi2 = 0.0, dof = 0.0;
        for (const Outcome& x : out) {
          not_usable += x.usable ? 0 : 1;
          rejected += x.rejected ? 1 : 0;
          named += x.named ? 1 : 0;
          added_rejected += x.rejected && x.added > 0 ? 1 : 0;
          withheld += x.withheld;
          chi2 += x.chi_square / seeds;
          dof += static_cast<double>(x.dof) / seeds;
        }
        const double diff_um = TurnedDifferenceRmsUm(rotation);
        // Resolvable: the test at its level detects the difference the readings see (their mean
        // chi-square less its degrees of freedom: the noncentrality) at least 99 % of the time.
        const double power = NoncentralPower(chi2 - dof, static_cast<int>(std::lround(dof)));
        const bool resolvable = power >= 0.99;
        std::printf("%-6.2f %-2d %-18s %7.4f %7.1f %5.1f %6.1f%% %5d %11d %9d %7d %6d %9.2f%s\n", noise, count,
                    label.c_str(), diff_um, chi2, dof, 100.0 * power, seeds, not_usable, rejected, named,
                    added_rejected, static_cast<double>(withheld) / seeds, resolvable ? "" : "  (not resolvable)");
        std::fflush(stdout);
        total_runs += seeds;
        total_rejected += rejected;
        total_named += named;
        total_added_rejected += added_rejected;
        if (resolvable) {
          total_resolvable += seeds;
          total_rejected_resolvable += rejected;
        }
      }
    }
    const auto [lo, hi] = sph::bench::ClopperPearson(total_rejected_resolvable, std::max(1, total_resolvable));
    std::printf(
        "sigma %.2f: rejected %d of %d runs (resolvable cells: %d of %d, 95 %% interval %.1f-%.1f %%); right "
        "orientation named in %d of the %d rejected; an effect added on a rejected form in %d\n",
        noise, total_rejected, total_runs, total_rejected_resolvable, total_resolvable, 100 * lo, 100 * hi, total_named,
        total_rejected, total_added_rejected);
  }
  return 0;
}

int FalseAlarms(int runs, int threads) {
  std::vector<std::pair<std::string, std::vector<Effect>>> cases{{"none", {}}};
  for (const auto& [e, s] : Library()) cases.push_back({sph::InfoOf(e).id, {e}});
  std::printf(
      "the right orientation stated, form28 known from a separation, one placement, sigma 0.03 and 0.05 um; "
      "%d runs without an effect, %d with each; a statement rejected when p < %g (its nominal level)\n",
      runs, std::max(1, runs / 10), sph::kStatementP);
  for (const double noise : {0.03, 0.05}) {
    const std::string form = Separate(noise);
    int all = 0, all_rejected = 0;
    for (const auto& [name, effects] : cases) {
      const int n = effects.empty() ? runs : std::max(1, runs / 10);
      std::vector<Outcome> out(static_cast<std::size_t>(n));
      sph::internal::ParallelFor(out.size(), threads, [&] {
        return [&](std::size_t i) {
          const int seed = 2000 + static_cast<int>(i);
          sph::CalibrationWorkflowOptions o = Options();
          o.sphere_form_paths = {form};
          out[i] =
              Judge(sph::RunCalibrationWorkflow(Daily(effects, noise, static_cast<std::uint64_t>(seed)), "daily", o));
        };
      });
      int rejected = 0, not_usable = 0, below_tenth = 0;
      for (const Outcome& x : out) {
        rejected += x.rejected ? 1 : 0;
        not_usable += x.usable ? 0 : 1;
        below_tenth += x.p < 0.1 * sph::kStatementP ? 1 : 0;
      }
      const auto [lo, hi] = sph::bench::ClopperPearson(rejected, n);
      std::printf(
          "  sigma %.2f %-20s runs %4d rejected %3d (%.2f %%, 95 %% %.2f-%.2f %%), not usable %d; p below a tenth of "
          "the level %d\n",
          noise, name.c_str(), n, rejected, 100.0 * rejected / n, 100 * lo, 100 * hi, not_usable, below_tenth);
      std::fflush(stdout);
      all += n;
      all_rejected += rejected;
    }
    const auto [lo, hi] = sph::bench::ClopperPearson(all_rejected, all);
    std::printf("sigma %.2f: rejected %d of %d (%.2f %%, 95 %% %.2f-%.2f %%) at a nominal level of %g %%\n", noise,
                all_rejected, all, 100.0 * all_rejected / all, 100 * lo, 100 * hi, 100 * sph::kStatementP);
  }
  return 0;
}

int Bound(int seeds, int threads) {
  sph::SimulatedEffects set;
  set.form = sph::bench::Form28();
  const double rms_um = sph::FormSizeOf(set, 20.0).rms_um;
  std::printf(
      "the certificate's bound as the prior: form28 (%.4f um rms), one placement, no effect of the machine, "
      "sigma 0.03 um; %d seeds per ratio; rejected when p < %g\n",
      rms_um, seeds, sph::kStatementP);
  for (const double ratio : {0.1, 0.2, 0.5, 0.8, 1.0, 1.25, 2.0, 5.0, 10.0}) {
    std::vector<Outcome> out(static_cast<std::size_t>(seeds));
    sph::internal::ParallelFor(out.size(), threads, [&] {
      return [&](std::size_t i) {
        sph::CalibrationWorkflowOptions o = Options();
        o.conditions.sphere_form_rms_um = ratio * rms_um;
        out[i] = Judge(sph::RunCalibrationWorkflow(Daily({}, 0.03, 3000 + i), "daily", o));
      };
    });
    int rejected = 0;
    for (const Outcome& x : out) rejected += x.rejected ? 1 : 0;
    const auto [lo, hi] = sph::bench::ClopperPearson(rejected, seeds);
    std::printf("  bound %5.2f x the form's rms: rejected %3d of %d (%.0f %%, 95 %% %.0f-%.0f %%)\n", ratio, rejected,
                seeds, 100.0 * rejected / seeds, 100 * lo, 100 * hi);
    std::fflush(stdout);
  }
  return 0;
}

// P(|N(delta, 1)| > z) for the two-sided level kStatementP (0.001): the test's power at an offset of
// delta of its own standard deviations.
double Power(double delta) {
  static_assert(sph::kStatementP == 0.001, "the quantile below is that of the level");
  const double z = 3.2905267314919;  // the 0.9995 quantile of N(0, 1)
  return 0.5 * std::erfc((z - delta) / std::sqrt(2.0)) + 0.5 * std::erfc((z + delta) / std::sqrt(2.0));
}

int Prior(int seeds, int threads) {
  // alpha's standard uncertainty from the readings of one placement at sigma 0.05 um (the paper's
  // design): measured on seed 1, the prior's u set equal to it.
  sph::SimulationSpec spec;
  spec.seed = 1;
  const sph::CalibrationWorkflowResult first = sph::RunCalibrationWorkflow(sph::Simulate(spec), "daily", Options());
  const double u_x = first.seven.analysis.std(sph::kAlpha);
  const double truth = spec.truth[sph::kAlpha];
  std::printf(
      "a prior on alpha, and alpha held, delta standard uncertainties from the truth; one placement, sigma 0.05 um, "
      "no effect; the readings' u(alpha) %.3g urad, the prior's u the same; %d seeds per offset; rejected when "
      "p < %g; expected: the test's power at delta / sqrt(2) (prior) and delta (held) of its standard deviations\n",
      u_x * 1e6, seeds, sph::kStatementP);
  for (const double delta : {0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 7.0, 10.0}) {
    int rejected[2] = {0, 0};
    for (int held = 0; held < 2; ++held) {
      std::vector<Outcome> out(static_cast<std::size_t>(seeds));
      std::vector<int> r(out.size(), 0);
      sph::internal::ParallelFor(out.size(), threads, [&] {
        return [&](std::size_t i) {
          sph::SimulationSpec s;
          s.seed = 4000 + i;
          sph::CalibrationWorkflowOptions o = Options();
          o.trace = false;  // the seven errors: what a prior on alpha is tested in
          if (held == 1) {
            o.fit.fixed.push_back({"alpha", truth + delta * u_x});
          } else {
            o.fit.priors.push_back({"alpha", truth + delta * u_x, u_x});
          }
          const sph::CalibrationWorkflowResult run = sph::RunCalibrationWorkflow(sph::Simulate(s), "daily", o);
          for (const sph::StatementCheck& c : run.statements) r[i] += c.rejected ? 1 : 0;
        };
      });
      for (const int x : r) rejected[held] += x;
    }
    std::printf(
        "  delta %4.1f: prior rejected %3d of %d (expected %.0f %%), held rejected %3d of %d (expected %.0f %%)\n",
        delta, rejected[0], seeds, 100 * Power(delta / std::sqrt(2.0)), rejected[1], seeds, 100 * Power(delta));
    std::fflush(stdout);
  }
  return 0;
}

int OneCase(const std::string& rotation, const std::string& ids, double noise_um, std::uint64_t seed) {
  Eigen::Vector3d r;
  if (std::sscanf(rotation.c_str(), "%lf,%lf,%lf", &r.x(), &r.y(), &r.z()) != 3) {
    std::fprintf(stderr, "statement_study: the rotation is rx,ry,rz in deg\n");
    return 2;
  }
  std::vector<Effect> effects;
  for (std::size_t at = 0; ids != "none" && at <= ids.size();) {
    const std::size_t end = std::min(ids.find('+', at), ids.size());
    Effect e{};
    if (!sph::EffectFromId(ids.substr(at, end - at), &e) || Library().count(e) == 0) {
      std::fprintf(stderr, "statement_study: %s is not one of the study's effects\n", ids.substr(at, end - at).c_str());
      return 2;
    }
    effects.push_back(e);
    at = end + 1;
  }
  sph::PointsData points = Daily(effects, noise_um, seed);
  points.header.mount_rotations[0] = sph::MountRotation::Known(r);
  sph::CalibrationWorkflowOptions o = Options();
  o.sphere_form_paths = {Separate(noise_um)};
  const sph::CalibrationWorkflowResult run = sph::RunCalibrationWorkflow(std::move(points), "daily", o);
  run.WriteTextReport(std::cout);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const auto arg = [&](int i, int fallback) { return argc > i ? std::atoi(argv[i]) : fallback; };
  if (argc >= 2 && std::strcmp(argv[1], "--orientation") == 0) {
    return Orientation(arg(2, 20), arg(3, 1), arg(4, 1), argc > 5 ? std::atof(argv[5]) : 0.0);
  }
  if (argc >= 2 && std::strcmp(argv[1], "--false-alarms") == 0) return FalseAlarms(arg(2, 500), arg(3, 1));
  if (argc >= 2 && std::strcmp(argv[1], "--bound") == 0) return Bound(arg(2, 40), arg(3, 1));
  if (argc >= 2 && std::strcmp(argv[1], "--prior") == 0) return Prior(arg(2, 100), arg(3, 1));
  if (argc >= 6 && std::strcmp(argv[1], "--case") == 0) {
    return OneCase(argv[2], argv[3], std::atof(argv[4]), static_cast<std::uint64_t>(std::atoll(argv[5])));
  }
  std::fprintf(stderr,
               "usage: statement_study --orientation [SEEDS [THREADS [FIRST [SIGMA_UM]]]] | --false-alarms [RUNS "
               "[THREADS]] | --bound "
               "[SEEDS [THREADS]] | --prior [SEEDS [THREADS]] | --case ROTATION EFFECTS SIGMA_UM SEED\n");
  return 2;
}
