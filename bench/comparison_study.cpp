// The comparison with an earlier calibration on one unchanged machine: pairs of calibrations of
// the simulator's machine (ray-traced, independent of the fit), each run of a pair with its own
// noise seed, the same R0 certificate and the same probe (one R0 error and one probe scale error
// drawn per pair, from the stated u, acting on both runs alike), compared by
// CompareCalibrations(). A study program, run by hand (docs/validation.md, "The comparison with
// an earlier calibration"):
//
//   build/bench/comparison_study [PAIRS] [seven|trace]   (default 500 pairs, seven)
//
// seven: a machine of the seven errors alone, calibrated so (--no-trace); trace: a machine with a
// Theta encoder error (3rd harmonic, 5 arcsec) and a Theta axial motion (2nd, 0.3 um), the effects
// selected by the trace. One placement, the paper's 24 x 12 grid, 2 mm eccentricity, sigma_r
// 0.05 um, u(R0) 0.1 um, u(probe scale) 2e-5.
//
// Prints, per parameter of the verdict's rows, the share of pairs with |En| <= 1, the mean U, the
// scatter of the differences as a ratio to U / 2 (1 when U is right) and the share with |En| <= 1
// over the pairs whose two runs chose the same model; then the share over every parameter compared
// (>= 95 % expected), the same over the pairs of one model, over the parameters of effects the
// machine lacks (a trace's false additions: how far from zero each side is), how many pairs were compared like with
// like (refitted with the earlier model) or could not be, the share that today's own model's rows
// alone would give, and of the pairs whose second run had d' moved by 3 U (U: that pair's own U of
// d'), those detected (|En(d')| > 1).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "sph/calib/calibrate_workflow.hpp"
#include "sph/io/calibration_comparison.hpp"
#include "sph/stats/random.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"

namespace {

constexpr double kRadiusUUm = 0.1;
constexpr double kProbeScaleU = 2e-5;

enum class Mode { kSeven, kTrace };

// One run of the pair: the machine with d' moved by `d_prime_shift_mm`, noise of `seed`, R0 told
// `r0_error_mm` off the truth, readings scaled by 1 + scale_error; with the options it ran with.
struct Run {
  sph::CalibrationWorkflowOptions options;
  sph::CalibrationWorkflowResult result;
};

Run Calibrate(Mode mode, std::uint64_t seed, double d_prime_shift_mm, double r0_error_mm, double scale_error) {
  sph::SimulationSpec spec;
  spec.seed = seed;
  spec.truth[sph::kDPrime] += d_prime_shift_mm;
  if (mode == Mode::kTrace) {
    spec.effects.model.terms.push_back({sph::Effect::kThetaEncoder, {{3, 0, false}}});
    spec.effects.values.push_back({5.0 * sph::kRadPerArcsec});
    spec.effects.model.terms.push_back({sph::Effect::kThetaAxialMotion, {{2, 0, false}}});
    spec.effects.values.push_back({0.3 * sph::kMmPerUm});
  }
  sph::PointsData points = sph::Simulate(spec);
  for (sph::Sample& s : points.samples) s.r_mm *= 1.0 + scale_error;
  Run run;
  sph::CalibrationWorkflowOptions& o = run.options;
  o.sphere_radius_mm = spec.sphere_radius_mm + r0_error_mm;
  o.conditions.sphere_radius_u_um = kRadiusUUm;
  o.conditions.probe_scale_u = kProbeScaleU;
  o.trace = mode == Mode::kTrace;
  run.result = sph::RunCalibrationWorkflow(points, "simulated", o);
  if (!run.result.usability.usable) {
    std::fprintf(stderr, "seed %llu: the calibration is not usable\n", static_cast<unsigned long long>(seed));
  }
  return run;
}

struct Tally {
  int within = 0, compared = 0;
  int same_within = 0, same_compared = 0;  // of the pairs whose runs hold the same parameters
  double sum_u = 0.0, sum_d2 = 0.0;
  std::string unit;
};

}  // namespace

int main(int argc, char** argv) {
  const int pairs = argc > 1 ? std::atoi(argv[1]) : 500;
  const std::string mode_name = argc > 2 ? argv[2] : "seven";
  const Mode mode = mode_name == "trace" ? Mode::kTrace : Mode::kSeven;
  if (pairs < 1 || (mode == Mode::kSeven && mode_name != "seven")) {
    std::fprintf(stderr, "usage: comparison_study [PAIRS] [seven|trace]\n");
    return 2;
  }
  sph::Random random(20261205);
  std::map<std::string, Tally> tally;
  std::vector<std::string> order;
  int detected = 0, shifted = 0, one_run_only = 0, all_within = 0, all_compared = 0;
  // The same over the pairs whose two runs chose the same model; the pairs refitted with the earlier
  // model, those it could not be fitted to; the rows of today's own model alone.
  int same_pairs = 0, same_within = 0, same_compared = 0, refitted = 0, not_refitted = 0;
  int own_within = 0, own_compared = 0;
  // The parameters of effects the simulated machine lacks (added by a trace only): |En| <= 1, and
  // the mean |value| / (U / 2) of the earlier run and of today's refit.
  int lacking_within = 0, lacking_compared = 0;
  double lacking_previous_z = 0.0, lacking_now_z = 0.0;
  for (int k = 0; k < pairs; ++k) {
    const double r0_error_mm = random.Normal() * kRadiusUUm * sph::kMmPerUm;
    const double scale_error = random.Normal() * kProbeScaleU;
    const std::uint64_t seed_previous = 1000 + 2 * static_cast<std::uint64_t>(k), seed_now = seed_previous + 1;
    try {
      const sph::CalibrationFile previous =
          Calibrate(mode, seed_previous, 0.0, r0_error_mm, scale_error).result.MakeCalibrationFile();
      const Run now = Calibrate(mode, seed_now, 0.0, r0_error_mm, scale_error);
      const sph::CalibrationComparison cmp = sph::CompareWithEarlier(now.result, previous, "previous", now.options);
      const bool same = cmp.models.empty();
      same_pairs += same;
      refitted += cmp.model == sph::kPreviousModel;
      not_refitted += !same && cmp.model == sph::kTodaysModel;
      for (const sph::ComparedParameter& c : cmp.model == sph::kPreviousModel ? cmp.todays_model : cmp.parameters) {
        if (!c.Compared()) continue;
        ++own_compared;
        own_within += std::abs(c.En) <= 1.0;
      }
      double u_d_prime_mm = 0.0;
      for (const sph::ComparedParameter& c : cmp.parameters) {
        if (c.found != sph::ComparedParameter::Found::kBoth) {
          ++one_run_only;
          continue;
        }
        if (!c.Compared()) continue;
        if (tally.find(c.parameter) == tally.end()) order.push_back(c.parameter);
        Tally& t = tally[c.parameter];
        t.unit = c.unit;
        ++t.compared;
        t.within += std::abs(c.En) <= 1.0;
        t.same_compared += same;
        t.same_within += same && std::abs(c.En) <= 1.0;
        t.sum_u += c.U;
        t.sum_d2 += c.difference * c.difference / (c.U * c.U / 4.0);
        ++all_compared;
        all_within += std::abs(c.En) <= 1.0;
        same_compared += same;
        same_within += same && std::abs(c.En) <= 1.0;
        if (c.parameter == "d_prime") u_d_prime_mm = c.U * sph::kMmPerUm;
        if (c.parameter.find('.') != std::string::npos && c.parameter != "theta_encoder.c3" &&
            c.parameter != "theta_axial_motion.c2") {
          ++lacking_compared;
          lacking_within += std::abs(c.En) <= 1.0;
          lacking_previous_z += std::abs(c.previous) / (c.U / 2.0);
          lacking_now_z += std::abs(c.now) / (c.U / 2.0);
        }
      }
      // The same second run with d' moved by 3 U of this pair's comparison.
      const Run moved = Calibrate(mode, seed_now, 3.0 * u_d_prime_mm, r0_error_mm, scale_error);
      for (const sph::ComparedParameter& c :
           sph::CompareWithEarlier(moved.result, previous, "previous", moved.options).parameters) {
        if (c.parameter != "d_prime") continue;
        ++shifted;
        detected += c.Compared() && std::abs(c.En) > 1.0;
      }
    } catch (const std::exception& e) {
      std::fprintf(stderr, "pair %d: %s\n", k, e.what());
    }
  }
  std::printf("comparison study: %d pairs, %s, one placement, sigma_r 0.05 um, u(R0) %.2g um, u(probe scale) %.2g\n",
              pairs, mode_name.c_str(), kRadiusUUm, kProbeScaleU);
  std::printf("%-24s %6s %9s %10s %-7s %16s %11s %14s\n", "parameter", "pairs", "|En|<=1", "mean U", "unit",
              "rms(diff)/(U/2)", "same model", "|En|<=1 there");
  for (const std::string& name : order) {
    const Tally& t = tally[name];
    std::printf("%-24s %6d %8.1f%% %10.4f %-7s %16.3f %11d %13.1f%%\n", name.c_str(), t.compared,
                100.0 * t.within / t.compared, t.sum_u / t.compared, t.unit.c_str(), std::sqrt(t.sum_d2 / t.compared),
                t.same_compared, t.same_compared > 0 ? 100.0 * t.same_within / t.same_compared : 0.0);
  }
  std::printf("all parameters compared: %d, |En| <= 1: %.2f%%; values found in one run only: %d\n", all_compared,
              all_compared > 0 ? 100.0 * all_within / all_compared : 0.0, one_run_only);
  std::printf("pairs whose runs chose the same model: %d, their parameters compared: %d, |En| <= 1: %.2f%%\n",
              same_pairs, same_compared, same_compared > 0 ? 100.0 * same_within / same_compared : 0.0);
  std::printf("pairs of two models: %d compared like with like (refitted with the earlier model), %d not (the earlier "
              "model not fitted to today's readings)\n",
              refitted, not_refitted);
  if (lacking_compared > 0) {
    std::printf("parameters of effects the machine lacks: %d compared, |En| <= 1: %.2f%%, mean |value| / (U/2): "
                "%.2f earlier, %.2f today\n",
                lacking_compared, 100.0 * lacking_within / lacking_compared, lacking_previous_z / lacking_compared,
                lacking_now_z / lacking_compared);
  }
  std::printf("today's own model's rows alone: %d compared, |En| <= 1: %.2f%%\n", own_compared,
              own_compared > 0 ? 100.0 * own_within / own_compared : 0.0);
  std::printf("d' moved by 3 U in the second run: detected (|En| > 1) in %d of %d pairs\n", detected, shifted);
  return 0;
}
