// A certificate-style check of the error curves: an encoder error simulated by ray tracing, the
// calibration traced as sph_calibrate traces it, and the true curve held against the reported
// curve and its 95 % band at the table's angles, over independent noise seeds. A study program, run
// by hand (docs/validation.md, "Error curves against the truth"); it prints a few lines per case.
//
//   build/bench/curve_study [seeds] [-v]      (default 40; -v lists the runs that fitted other components)
//
// Both curves are taken about their mean over the pattern's angles (a constant is a zero of the
// axis, not determined). Printed per case:
// - traced: the runs whose trace added the encoder, the angles in the band of those runs (the
//   fraction and its count), and the median U95 and range of the curve;
// - the same over the runs whose trace fitted exactly the true components, over those that fitted
//   other components of the encoder alone, and over those whose model holds another effect too;
// - fixed: the curve of a fit of exactly the true components (no selection), the band's coverage
//   without what the choice of the components adds or misses;
// - bias: over the traced runs, the mean of (curve - truth) at each table angle against the band's
//   standard uncertainty U95 / k there (the largest ratio over the angles, and the standard error of
//   that mean in the same unit: a ratio well above it is a bias the band does not hold).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "sph/calib/effect_fit.hpp"
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

// The band of the chosen components' noise alone, k sqrt(g^T C g), without the truncation.
double NoiseU95At(const sph::ErrorCurve& curve, double deg) {
  const Eigen::VectorXd g = curve.Basis(deg);
  return curve.coverage_factor * std::sqrt(std::max(0.0, g.dot(curve.covariance * g)));
}

// Angles of a curve's table in the band (the reported one, and the noise's alone), of all.
struct Count {
  int inside = 0, noise_inside = 0, total = 0, runs = 0;
  void Add(const Case& c, const sph::ErrorCurve& curve, double mean) {
    ++runs;
    for (std::size_t i = 0; i < curve.angle_deg.size(); ++i) {
      const double error = std::abs(curve.value[i] - (TrueAt(c, curve.angle_deg[i]) - mean));
      inside += error <= curve.u95[i];
      noise_inside += error <= NoiseU95At(curve, curve.angle_deg[i]);
      ++total;
    }
  }
  double Fraction() const { return total ? static_cast<double>(inside) / total : 0.0; }
  double NoiseFraction() const { return total ? static_cast<double>(noise_inside) / total : 0.0; }
};

bool SameComponents(const std::vector<sph::EffectComponent>& a, const std::vector<sph::EffectComponent>& b) {
  return a.size() == b.size() && std::all_of(a.begin(), a.end(), [&](const sph::EffectComponent& t) {
           return std::any_of(b.begin(), b.end(), [&](const sph::EffectComponent& f) {
             return f.order == t.order && f.sine == t.sine && f.axis == t.axis;
           });
         });
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::atoi(argv[1]) : 40;
  const bool verbose = argc > 2 && std::string(argv[2]) == "-v";
  const std::vector<Case> cases = {
      {"theta_encoder c2 6 + s3 4 arcsec, full turn",
       sph::Effect::kThetaEncoder,
       {{2, 0, false}, {3, 0, true}},
       {6.0, 4.0}},
      {"phi_encoder c1 8 arcsec, phi 7.5..172.5 deg", sph::Effect::kPhiEncoder, {{1, 0, false}}, {8.0}},
  };
  for (const Case& c : cases) {
    Count traced, exact, other_components, other_effects, fixed;
    std::vector<double> u95, noise_u95, pv;
    std::vector<double> bias_sum, bias_sq, u_sum;  // per table angle, over the traced runs
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
      // The truth about its mean over the pattern's angles (the curve's own convention).
      std::vector<double> pattern;
      for (const sph::Sample& s : points.samples) {
        const double a = c.effect == sph::Effect::kPhiEncoder ? s.phi_deg : s.theta_deg;
        if (std::none_of(pattern.begin(), pattern.end(), [&](double p) { return std::abs(p - a) < 1e-6; }))
          pattern.push_back(a);
      }
      double mean = 0.0;
      for (double a : pattern) mean += TrueAt(c, a) / static_cast<double>(pattern.size());
      // The fit of exactly the true components, no selection.
      sph::EffectModel model = r.before.fit.model;
      model.terms = {{c.effect, c.components}};
      const sph::EffectFit exact_fit = sph::FitEffects(points, options, model, sph::EffectFitStart::From(base));
      for (const sph::ErrorCurve& e :
           sph::ErrorCurvesOf(points, options, exact_fit, r.harmonics, sph::TraceOptions{}.max_vif)) {
        if (e.effect == c.effect) fixed.Add(c, e, mean);
      }
      const auto curve = std::find_if(r.curves.begin(), r.curves.end(),
                                      [&](const sph::ErrorCurve& e) { return e.effect == c.effect; });
      if (curve == r.curves.end()) continue;
      traced.Add(c, *curve, mean);
      if (r.after.fit.model.terms.size() > 1) {
        other_effects.Add(c, *curve, mean);
      } else if (SameComponents(curve->components, c.components)) {
        exact.Add(c, *curve, mean);
      } else {
        other_components.Add(c, *curve, mean);
        if (verbose) {
          std::printf("  seed %d fitted", seed);
          for (std::size_t i = 0; i < curve->fitted.size(); ++i) {
            std::printf(" %s=%.2f", curve->fitted[i].c_str(), curve->coefficients(static_cast<Eigen::Index>(i)));
          }
          std::printf("\n");
        }
      }
      bias_sum.resize(curve->angle_deg.size(), 0.0);
      bias_sq.resize(curve->angle_deg.size(), 0.0);
      u_sum.resize(curve->angle_deg.size(), 0.0);
      for (std::size_t i = 0; i < curve->angle_deg.size() && i < bias_sum.size(); ++i) {
        const double d = curve->value[i] - (TrueAt(c, curve->angle_deg[i]) - mean);
        bias_sum[i] += d;
        bias_sq[i] += d * d;
        u_sum[i] += curve->u95[i] / curve->coverage_factor;
        u95.push_back(curve->u95[i]);
        noise_u95.push_back(NoiseU95At(*curve, curve->angle_deg[i]));
      }
      pv.push_back(curve->pv);
    }
    std::printf("%s\n", c.name);
    std::printf(
        "  traced: encoder added in %d of %d runs; true curve in the band at %d of %d angles (%.3f), in the noise's "
        "band alone at %d (%.3f); median U95 %.2f arcsec (the noise's alone %.2f), median range %.2f arcsec\n",
        traced.runs, seeds, traced.inside, traced.total, traced.Fraction(), traced.noise_inside, traced.NoiseFraction(),
        Median(u95), Median(noise_u95), Median(pv));
    const auto line = [](const char* what, const Count& n) {
      std::printf("    %-44s %3d runs: %5d of %5d angles (%.3f), the noise's band alone %5d (%.3f)\n", what, n.runs,
                  n.inside, n.total, n.Fraction(), n.noise_inside, n.NoiseFraction());
    };
    line("the true components exactly:", exact);
    line("other components of the encoder alone:", other_components);
    line("another effect in the model too:", other_effects);
    line("fixed: a fit of exactly the true components:", fixed);
    double worst = 0.0, worst_se = 0.0;
    std::size_t worst_at = 0;
    for (std::size_t i = 0; i < bias_sum.size() && traced.runs > 1; ++i) {
      const double n = traced.runs;
      const double m = bias_sum[i] / n, u = u_sum[i] / n;
      const double se = std::sqrt(std::max(0.0, bias_sq[i] / n - m * m) / (n - 1.0));
      if (std::abs(m) / u > worst) {
        worst = std::abs(m) / u;
        worst_se = se / u;
        worst_at = i;
      }
    }
    std::printf("  bias: largest |mean(curve - truth)| / (U95 / k) over the table %.2f (+- %.2f), at table angle %d\n",
                worst, worst_se, static_cast<int>(worst_at));
  }
  return 0;
}
