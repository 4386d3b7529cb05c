#include "sph/simulation/simulation_options.hpp"

#include <cmath>
#include <cstdlib>
#include <utility>

#include "sph/core/error.hpp"
#include "sph/core/ranges.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/effect_terms.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using internal::Format;
using internal::Quoted;

// The parts of "a,b,c" (none for an empty text; "a," has two, the second empty).
std::vector<std::string> SplitCommas(const std::string& text) {
  std::vector<std::string> parts;
  if (text.empty()) return parts;
  std::size_t start = 0;
  for (std::size_t comma; (comma = text.find(',', start)) != std::string::npos; start = comma + 1) {
    parts.push_back(text.substr(start, comma - start));
  }
  parts.push_back(text.substr(start));
  return parts;
}

// A direction of three parsed values, refused when it has no length.
Eigen::Vector3d Direction(const std::vector<double>& v, std::size_t first, const std::string& what) {
  const Eigen::Vector3d d(v[first], v[first + 1], v[first + 2]);
  if (!(d.norm() > 0.0)) throw Error(what + ": the direction nx,ny,nz has no length");
  return d;
}

// A setup id of an option's value; `what` names the option and its value.
int ParseSetup(const std::string& text, const std::string& what, int n_setups) {
  const int setup = ParseInteger(text, "setup", what + ": ");
  if (setup < 0 || setup >= n_setups) {
    throw Error(what + ": setup " + std::to_string(setup) + " does not exist (the setups are 0 to " +
                std::to_string(n_setups - 1) + ", one per --center-mm)");
  }
  return setup;
}

// "SETUP:rest" into its setup id and the rest; `expected` is the layout for the message.
std::pair<int, std::string> SplitSetup(const std::string& text, const std::string& what, const std::string& expected,
                                       int n_setups) {
  const auto colon = text.find(':');
  if (colon == std::string::npos) throw Error(what + ": expected " + expected);
  return {ParseSetup(text.substr(0, colon), what, n_setups), text.substr(colon + 1)};
}

// The sphere on its mount, its form and the scan orders of the options, into `spec`.
void AddSphereOptions(const SimulationOptions& o, SimulationSpec& spec) {
  const int n = static_cast<int>(spec.centers_mm.size());
  for (const std::string& text : o.mount_rotations_deg) {
    const std::string what = "--mount-rotation-deg " + Quoted(text);
    const std::string expected = "SETUP:rx,ry,rz (a setup id and a rotation vector in deg, axis times angle)";
    const auto [setup, rest] = SplitSetup(text, what, expected, n);
    if (!spec.mount_rotations_deg.emplace(setup, ParseRotationDeg(rest, what, expected)).second) {
      throw Error(what + ": setup " + std::to_string(setup) + " is given twice");
    }
  }
  for (const std::string& text : o.mount_unknown) {
    const std::string what = "--mount-unknown " + Quoted(text);
    if (!spec.mount_unknown.insert(ParseSetup(text, what, n)).second) throw Error(what + ": the setup is given twice");
  }
  for (const std::string& text : o.sphere_radii_mm) {
    const std::string what = "--other-sphere-radius-mm " + Quoted(text);
    const auto [setup, rest] = SplitSetup(text, what, "SETUP:R (a setup id and a radius in mm)", n);
    const double radius_mm =
        CheckedValue(ParseNumber(rest, "radius", what + ": "), ranges::kSphereRadiusMm, what + ": radius", rest);
    if (!spec.sphere_radii_mm.emplace(setup, radius_mm).second) {
      throw Error(what + ": setup " + std::to_string(setup) + " is given twice");
    }
  }
  bool order_for_all = false;
  for (const std::string& text : o.scan_orders) {
    const std::string what = "--scan-order " + Quoted(text);
    const auto colon = text.find(':');
    const std::string name = colon == std::string::npos ? text : text.substr(colon + 1);
    ScanOrder order;
    if (!ScanOrderFromName(name, &order)) {
      throw Error(what + ": unknown order " + Quoted(name) + " (known: " + ScanOrderNames() + ")");
    }
    if (colon == std::string::npos) {
      if (order_for_all) throw Error(what + ": an order for every setup is given twice");
      order_for_all = true;
      spec.scan_order = order;
    } else if (!spec.scan_orders.emplace(ParseSetup(text.substr(0, colon), what, n), order).second) {
      throw Error(what + ": the setup is given twice");
    }
  }
}

// The points file's metadata: the generator, the seed and the probe's range.
void AddMetadata(const SimulationOptions& o, PointsHeader& header) {
  header.metadata.emplace_back("generator", "sph_simulate " SPH_VERSION);
  header.metadata.emplace_back("seed", std::to_string(o.seed));
  if (o.probe_range_mm) header.metadata.emplace_back("probe_range_mm", Format("%.17g", *o.probe_range_mm));
}

}  // namespace

std::vector<double> ParseFields(const std::string& text, const std::string& what, const std::string& expected,
                                const std::vector<Field>& fields) {
  const std::vector<std::string> parts = SplitCommas(text);
  if (parts.size() != fields.size() || text.back() == ',') throw Error(what + ": expected " + expected);
  std::vector<double> values;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const double v = ParseNumber(parts[i], fields[i].name, what + ": ");
    values.push_back(CheckedValue(v, fields[i].range, what + ": " + fields[i].name, parts[i]));
  }
  return values;
}

void AddForm(const FormOptions& o, double sphere_radius_mm, SimulatedEffects& effects) {
  for (const std::string& f : o.harmonics_um) {
    const std::vector<std::string> parts = SplitCommas(f);
    FormComponent c;
    try {
      if (parts.size() != 3) throw Error("");
      c = {ParseInteger(parts[0], "l", ""), ParseInteger(parts[1], "m", ""), ParseNumber(parts[2], "amplitude_um", "")};
    } catch (const Error&) {
      c.l = -1;  // refused below
    }
    if (c.l < 0 || c.l > 20 || std::abs(c.m) > c.l) {
      throw Error("--form-um " + f + ": expected l,m,amplitude_um with 0 <= l <= 20 and |m| <= l");
    }
    CheckedValue(c.amplitude_um, ranges::kEffectUm, "--form-um " + f, Format("%g", c.amplitude_um));
    effects.form.push_back(c);
  }
  for (const std::string& text : o.flats_um) {
    const std::string what = "--form-flat-um " + Quoted(text);
    const std::vector<double> v = ParseFields(text, what, "depth_um,nx,ny,nz",
                                              {{"depth_um", ranges::kFormDepthUm},
                                               {"nx", ranges::kDirection},
                                               {"ny", ranges::kDirection},
                                               {"nz", ranges::kDirection}});
    if (!(v[0] * kMmPerUm < sphere_radius_mm))
      throw Error(what + ": the depth must be smaller than the sphere's radius");
    effects.flats.push_back({v[0], Direction(v, 1, what)});
  }
  for (const std::string& text : o.bumps_um) {
    const std::string what = "--form-bump-um " + Quoted(text);
    const std::vector<double> v = ParseFields(text, what, "height_um,width_deg,nx,ny,nz",
                                              {{"height_um", ranges::kEffectUm},
                                               {"width_deg", ranges::kFormWidthDeg},
                                               {"nx", ranges::kDirection},
                                               {"ny", ranges::kDirection},
                                               {"nz", ranges::kDirection}});
    effects.bumps.push_back({v[0], v[1], Direction(v, 2, what)});
  }
}

Eigen::Vector3d ParseRotationDeg(const std::string& text, const std::string& what, const std::string& expected) {
  const std::vector<double> v = ParseFields(
      text, what, expected,
      {{"rx", ranges::kMountRotationDeg}, {"ry", ranges::kMountRotationDeg}, {"rz", ranges::kMountRotationDeg}});
  return {v[0], v[1], v[2]};
}

Eigen::Vector3d ParseVector3(const std::string& text, const std::string& what) {
  const std::vector<std::string> parts = SplitCommas(text);
  if (parts.size() != 3 || text.back() == ',') throw Error(what + " " + Quoted(text) + ": expected x,y,z in mm");
  Eigen::Vector3d c;
  for (int i = 0; i < 3; ++i) {
    const std::string& part = parts[static_cast<std::size_t>(i)];
    c(i) =
        CheckedValue(ParseNumber(part, Quoted(text), what + " "), ranges::kCenterMm, what + " " + Quoted(text), part);
  }
  return c;
}

SimulationSpec ToSimulationSpec(const MachineOptions& o) {
  using namespace ranges;
  const double errors[] = {o.alpha_deg, o.a_mm, o.beta_deg, o.b_mm, o.epsilon_deg, o.c_mm, o.d_prime_mm};
  const char* const error_options[] = {"--alpha-deg",   "--a-mm", "--beta-deg",  "--b-mm",
                                       "--epsilon-deg", "--c-mm", "--d-prime-mm"};
  for (int p = 0; p < kNumScmsParams; ++p) CheckedValue(errors[p], ErrorRange(p), error_options[p]);
  CheckedValue(o.sphere_radius_mm, kSphereRadiusMm, "--sphere-radius-mm");
  CheckedValue(o.probe_offset_mm, kProbeOffsetMm, "--probe-offset-mm");
  CheckedValue(o.theta_steps, kGridSteps, "--theta-steps");
  CheckedValue(o.phi_steps, kGridSteps, "--phi-steps");
  CheckedValue(o.noise_r_um, kNoiseUm, "--noise-r-um");
  CheckedValue(o.noise_theta_arcsec, kNoiseArcsec, "--noise-theta-arcsec");
  CheckedValue(o.noise_phi_arcsec, kNoiseArcsec, "--noise-phi-arcsec");
  SimulationSpec spec;
  spec.truth = {o.alpha_deg * kRadPerDeg,
                o.a_mm,
                o.beta_deg * kRadPerDeg,
                o.b_mm,
                o.epsilon_deg * kRadPerDeg,
                o.c_mm,
                o.d_prime_mm};
  spec.sphere_radius_mm = o.sphere_radius_mm;
  spec.probe_offset_mm = o.probe_offset_mm;
  if (!(std::abs(o.d_prime_mm) < o.probe_offset_mm)) {
    throw Error("--d-prime-mm " + Format("%g", o.d_prime_mm) +
                ": the error of the probe zero distance must be "
                "smaller than the distance itself (--probe-offset-mm " +
                Format("%g", o.probe_offset_mm) + ")");
  }
  if (o.angles_path.empty() && static_cast<long>(o.theta_steps) * o.phi_steps > kMaxPatternPoints) {
    throw Error("--theta-steps " + std::to_string(o.theta_steps) + " x --phi-steps " + std::to_string(o.phi_steps) +
                " is a grid of " + std::to_string(static_cast<long>(o.theta_steps) * o.phi_steps) +
                " points; at most " + std::to_string(kMaxPatternPoints) + " are simulated");
  }
  spec.pattern = o.angles_path.empty() ? GridPattern(o.theta_steps, o.phi_steps) : ReadAnglePattern(o.angles_path);
  spec.noise_r_um = o.noise_r_um;
  spec.noise_theta_arcsec = o.noise_theta_arcsec;
  spec.noise_phi_arcsec = o.noise_phi_arcsec;
  return spec;
}

void AddEffectValue(const std::string& text, Quantity unit, SimulatedEffects& effects) {
  const std::string opt = unit == Quantity::kAngle ? "--effect-arcsec" : "--effect-um";
  const auto dot = text.find('.'), eq = text.find('=');
  if (dot == std::string::npos || eq == std::string::npos || eq < dot) {
    throw Error(opt + " " + text + ": expected id.param=value, e.g. theta_encoder.c2=10");
  }
  const std::string id = text.substr(0, dot), param = text.substr(dot + 1, eq - dot - 1);
  Effect e;
  if (!EffectFromId(id, &e)) throw Error(opt + " " + text + ": unknown effect '" + id + "'");
  if (InfoOf(e).quantity != unit) {
    throw Error(opt + " " + text + ": " + id + " is " + (unit == Quantity::kAngle ? "a length" : "an angle") +
                "; give it with " + (unit == Quantity::kAngle ? "--effect-um" : "--effect-arcsec"));
  }
  const std::string value_text = text.substr(eq + 1);
  const double value = ParseNumber(value_text, text, opt + " ");
  CheckedValue(value, unit == Quantity::kAngle ? ranges::kEffectArcsec : ranges::kEffectUm, opt + " " + text,
               value_text);
  EffectComponent comp;
  if (!FindComponent(e, text.substr(0, eq), &comp))
    throw Error(opt + " " + text + ": " + id + " has no parameter '" + param + "'");
  int t = effects.model.Find(e);
  if (t >= 0) {
    const EffectTerm& term = effects.model.terms[static_cast<std::size_t>(t)];
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      if (term.ParamName(i) == text.substr(0, eq))
        throw Error(opt + " " + text + ": " + text.substr(0, eq) + " is given twice");
    }
  }
  if (t < 0) {
    effects.model.terms.push_back({e, {}});
    effects.values.emplace_back();
    t = static_cast<int>(effects.model.terms.size()) - 1;
  }
  const double internal = unit == Quantity::kAngle ? value * kRadPerArcsec : value * kMmPerUm;
  effects.model.terms[static_cast<std::size_t>(t)].components.push_back(comp);
  effects.values[static_cast<std::size_t>(t)].push_back(internal);
}

SimulationSpec SimulationSpecOf(const SimulationOptions& o) {
  CheckedValue(o.sample_period_s, ranges::kSamplePeriodS, "--sample-period-s");
  CheckedValue(o.outlier_fraction, ranges::kOutlierFraction, "--outlier-fraction");
  CheckedValue(o.outlier_um, ranges::kOutlierUm, "--outlier-um");
  CheckedValue(o.phi_wobble_pivot_mm, ranges::kPivotMm, "--phi-wobble-pivot-mm");
  if (o.probe_range_mm) CheckedValue(*o.probe_range_mm, ranges::kProbeRangeMm, "--probe-range-mm");
  SimulationSpec spec = ToSimulationSpec(o.machine);
  spec.centers_mm.clear();
  for (const auto& c : o.centers_mm) spec.centers_mm.push_back(ParseVector3(c, "--center-mm"));
  spec.seed = o.seed;
  spec.sample_period_s = o.sample_period_s;
  for (const auto& e : o.effects_arcsec) AddEffectValue(e, Quantity::kAngle, spec.effects);
  for (const auto& e : o.effects_um) AddEffectValue(e, Quantity::kLength, spec.effects);
  spec.effects.model.phi_wobble_pivot_mm = o.phi_wobble_pivot_mm;
  spec.probe_range_mm = o.probe_range_mm;
  AddForm(o.form, spec.sphere_radius_mm, spec.effects);
  AddSphereOptions(o, spec);
  spec.effects.outlier_fraction = o.outlier_fraction;
  spec.effects.outlier_um = o.outlier_um;
  return spec;
}

SimulationRun RunSimulation(const SimulationOptions& o) {
  SimulationRun run;
  const SimulationSpec spec = SimulationSpecOf(o);
  EffectReference reference;
  run.points = Simulate(spec, &reference);
  AddMetadata(o, run.points.header);
  run.truth_json = SimulationTruthJson(spec, reference, run.points);
  return run;
}

}  // namespace sph
