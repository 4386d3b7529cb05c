// A certificate-style check of the error curves: an encoder error simulated by ray tracing, the
// calibration traced as sph_calibrate traces it, and the true curve held against the reported
// curve and its 95 % band at the table's angles, over independent noise seeds. A study program, run
// by hand (docs/validation.md, "Error curves against the truth"); it prints one line per case.
//
//   build/bench/curve_study [seeds]      (default 40)
//
// Both curves are taken about their mean over the pattern's angles (a constant is a zero of the
// axis, not determined). Printed per case: the runs whose trace added the encoder, the angles in the
// band of those runs (the fraction and its count), and the median U95 and range of the curve; then
// the same over the runs whose trace fitted exactly the true components (the band alone, without
// what the selection of the components adds or misses).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"
#include "sph/select/trace.hpp"

namespace {

struct Case {
  const char* name;
  sph::Effect effect;
  std::vector<sph::EffectComponent> components;
  std::vector<double> arcsec;
};

// The true curve [arcsec] at `deg`: the simulated components.
double TrueAt(const Case& c, double deg) {
  double v = 0.0;
  for (std::size_t i = 0; i < c.components.size(); ++i) {
    const double x = c.components[i].order * deg * sph::kRadPerDeg;
    v += c.arcsec[i] * (c.components[i].sine ? std::sin(x) : std::cos(x));
  }
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::atoi(argv[1]) : 40;
  const std::vector<Case> cases = {
      {"theta_encoder c2 6 + s3 4 arcsec, full turn",
       sph::Effect::kThetaEncoder,
       {{2, 0, false}, {3, 0, true}},
       {6.0, 4.0}},
      {"phi_encoder c1 8 arcsec, phi 7.5..172.5 deg", sph::Effect::kPhiEncoder, {{1, 0, false}}, {8.0}},
  };
  for (const Case& c : cases) {
    int added = 0, inside = 0, total = 0;
    int exact = 0, exact_inside = 0, exact_total = 0;  // runs that fitted exactly the true components
    std::vector<double> u95, pv;
    for (int seed = 1; seed <= seeds; ++seed) {
      sph::SimulationSpec spec;
      spec.seed = static_cast<std::uint64_t>(seed);
      spec.effects.model.terms = {{c.effect, c.components}};
      std::vector<double> values;
      for (double a : c.arcsec) values.push_back(a * sph::kRadPerArcsec);
      spec.effects.values = {values};
      const sph::PointsData points = sph::Simulate(spec);
      sph::CalibrationOptions options;
      options.sphere_radius_mm = spec.sphere_radius_mm;
      options.probe_offset_mm = spec.probe_offset_mm;
      const sph::CalibrationResult base = sph::Calibrate(points, options);
      const sph::TraceResult r = sph::TraceResidual(points, options, base, sph::TraceOptions{});
      const auto curve = std::find_if(r.curves.begin(), r.curves.end(),
                                      [&](const sph::ErrorCurve& e) { return e.effect == c.effect; });
      if (curve == r.curves.end()) continue;
      ++added;
      // The truth about its mean over the pattern's angles (the curve's own convention).
      std::vector<double> pattern;
      for (const sph::Sample& s : points.samples) {
        const double a = c.effect == sph::Effect::kPhiEncoder ? s.phi_deg : s.theta_deg;
        if (std::none_of(pattern.begin(), pattern.end(), [&](double p) { return std::abs(p - a) < 1e-6; }))
          pattern.push_back(a);
      }
      double mean = 0.0;
      for (double a : pattern) mean += TrueAt(c, a) / static_cast<double>(pattern.size());
      const bool as_true =
          curve->components.size() == c.components.size() &&
          std::all_of(c.components.begin(), c.components.end(), [&](const sph::EffectComponent& t) {
            return std::any_of(curve->components.begin(), curve->components.end(),
                               [&](const sph::EffectComponent& f) { return f.order == t.order && f.sine == t.sine; });
          });
      exact += as_true;
      for (std::size_t i = 0; i < curve->angle_deg.size(); ++i) {
        const double truth = TrueAt(c, curve->angle_deg[i]) - mean;
        const bool in = std::abs(curve->value[i] - truth) <= curve->u95[i];
        inside += in;
        ++total;
        if (as_true) {
          exact_inside += in;
          ++exact_total;
        }
        u95.push_back(curve->u95[i]);
      }
      pv.push_back(curve->pv);
    }
    std::sort(u95.begin(), u95.end());
    std::sort(pv.begin(), pv.end());
    std::printf(
        "%-46s encoder added in %d of %d runs; true curve in the band at %d of %d angles (%.3f); median U95 "
        "%.2f arcsec, median range %.2f arcsec\n",
        c.name, added, seeds, inside, total, total ? static_cast<double>(inside) / total : 0.0,
        u95.empty() ? 0.0 : u95[u95.size() / 2], pv.empty() ? 0.0 : pv[pv.size() / 2]);
    std::printf("%-46s   of those, %d fitted exactly the true components: in the band at %d of %d angles (%.3f)\n", "",
                exact, exact_inside, exact_total, exact_total ? static_cast<double>(exact_inside) / exact_total : 0.0);
  }
  return 0;
}
