#include "simulate_cmd.hpp"

#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include <CLI/CLI.hpp>

#include "app_common.hpp"
#include "sph/core/error.hpp"
#include "sph/core/output_files.hpp"
#include "sph/core/simulate.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph::apps {

using internal::Format;
using internal::Quoted;

namespace {

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
void AddSphereOptions(const SimulateOptions& o, SimulationSpec& spec) {
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

}  // namespace

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

void SetupSimulateApp(CLI::App& app, SimulateOptions& o) {
  app.description(
      "Simulate the readings of an SCMS measuring a reference sphere, by intersecting the probe ray "
      "with the sphere. Defaults are the paper's study (Table 1 truth, 24 x 12 grid, 2 mm eccentricity).");
  app.option_defaults()->always_capture_default();
  app.add_option("-o,--output", o.output_path, "Points file to write ('-' for stdout)");
  app.add_option("--truth", o.truth_path, "Also write the truth (JSON) to this file");
  AddMachineOptions(app, o.machine);
  app.add_option("--center-mm", o.centers_mm, "Sphere centre x,y,z [mm]; repeat for several setups");
  AddSeedOption(app, o.seed, "Random seed");
  app.add_option("--sample-period-s", o.sample_period_s, "Time between samples [s]")
      ->check(InRange({0.0, 86400.0, "s"}));
  app.add_option("--effect-arcsec", o.effects_arcsec,
                 "An angle effect's parameter, id.param=value [arcsec], e.g. theta_encoder.c2=10; repeatable")
      ->group("Effects (not declared in the points file)");
  app.add_option("--effect-um", o.effects_um,
                 "A length effect's parameter, id.param=value [um], e.g. probe_drift.t1=0.5; repeatable")
      ->group("Effects (not declared in the points file)");
  app.add_option("--probe-range-mm", o.probe_range_mm,
                 "The probe's measuring range, readings 0 to it [mm]: probe_gain and probe_nonlinearity are given at "
                 "its ends (else at the ends of the readings); written into the header as probe_range_mm")
      ->check(InRange({0.002, 10000.0, "mm"}))
      ->group("Effects (not declared in the points file)");
  app.add_option("--phi-wobble-pivot-mm", o.phi_wobble_pivot_mm,
                 "Distance along the Phi axis from its frame's origin to the bearing phi_wobble tilts about [mm]")
      ->check(InRange(ranges::kPivotMm))
      ->group("Effects (not declared in the points file)");
  const std::string sphere = "The sphere on its mount and its form";
  app.add_option("--mount-rotation-deg", o.mount_rotations_deg,
                 "SETUP:rx,ry,rz: the rotation vector (axis times angle) [deg] that takes the sphere's body frame into "
                 "the frame turning with Theta, in that setup (each " +
                     ranges::kMountRotationDeg.Text() + "); written into the file's header; repeatable")
      ->group(sphere);
  app.add_option("--mount-unknown", o.mount_unknown,
                 "SETUP: the header says 'unknown' for that setup's rotation (simulated as given); repeatable")
      ->group(sphere);
  app.add_option("--other-sphere-radius-mm", o.sphere_radii_mm,
                 "SETUP:R: that setup measures another sphere, of radius R [mm], perfect (the form options shape the "
                 "reference sphere); written into the file's header as sphere_radius_mm@SETUP; repeatable")
      ->group(sphere);
  AddFormOptions(app, o.form, sphere);
  app.add_option("--scan-order", o.scan_orders,
                 std::string("ORDER or SETUP:ORDER: the time order of the pattern (") + ScanOrderNames() +
                     "; default rings: phi ring by ring, theta within); repeatable")
      ->group(sphere);
  app.add_option("--outlier-fraction", o.outlier_fraction, "Share of readings with a gross error in r")
      ->check(CLI::Range(0.0, 1.0))
      ->group("Effects (not declared in the points file)");
  app.add_option("--outlier-um", o.outlier_um, "Size of the gross error (random sign) [um]")
      ->check(InRange({0.0, 1e6, "um"}))
      ->group("Effects (not declared in the points file)");
}

namespace {

// The simulation the options describe: the machine, the centres, the effects, the sphere's form
// and mounts, and the outliers.
SimulationSpec SpecOfOptions(const SimulateOptions& o) {
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

// The points file's metadata: the generator, the seed and the probe's range.
void AddMetadata(const SimulateOptions& o, PointsHeader& header) {
  header.metadata.emplace_back("generator", "sph_simulate " SPH_VERSION);
  header.metadata.emplace_back("seed", std::to_string(o.seed));
  if (o.probe_range_mm) header.metadata.emplace_back("probe_range_mm", Format("%.17g", *o.probe_range_mm));
}

}  // namespace

int RunSimulate(const SimulateOptions& o, std::ostream& err) {
  try {
    RunPaths()
        .Input("--angles", o.machine.angles_path)
        .Output("--output", o.output_path)
        .Output("--truth", o.truth_path);
    const SimulationSpec spec = SpecOfOptions(o);
    EffectReference reference;
    PointsData data = Simulate(spec, &reference);
    AddMetadata(o, data.header);

    OutputFiles files;
    if (!o.truth_path.empty()) {
      const std::string truth = SimulationTruthJson(spec, reference, data);
      files.Stage(o.truth_path, [&](std::ostream& f) { f << truth; });
    }
    files.Stage(o.output_path, [&](std::ostream& f) { WritePoints(f, data); });
    files.Commit();
    return kExitOk;
  } catch (const std::exception& e) {
    err << "sph_simulate: error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace sph::apps
