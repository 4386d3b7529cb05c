#include "simulate_cmd.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>


#include <nlohmann/json.hpp>

#include "app_common.hpp"
#include "sph/core/error.hpp"
#include "sph/core/output_files.hpp"
#include "sph/core/simulate.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph::apps {

using internal::Format;

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
  char* end = nullptr;
  const std::string value_text = text.substr(eq + 1);
  const double value = std::strtod(value_text.c_str(), &end);
  if (value_text.empty() || *end != '\0') throw Error(opt + " " + text + ": '" + value_text + "' is not a number");
  CheckedValue(value, unit == Quantity::kAngle ? ranges::kEffectArcsec : ranges::kEffectUm, opt + " " + text,
               value_text);
  EffectComponent comp;
  if (!FindComponent(e, text.substr(0, eq), &comp)) throw Error(opt + " " + text + ": " + id + " has no parameter '" + param + "'");
  int t = effects.model.Find(e);
  if (t >= 0) {
    const EffectTerm& term = effects.model.terms[static_cast<std::size_t>(t)];
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      if (term.ParamName(i) == text.substr(0, eq)) throw Error(opt + " " + text + ": " + text.substr(0, eq) + " is given twice");
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
  app.description("Simulate the readings of an SCMS measuring a reference sphere, by intersecting the probe ray "
                  "with the sphere. Defaults are the paper's study (Table 1 truth, 24 x 12 grid, 2 mm eccentricity).");
  app.option_defaults()->always_capture_default();
  app.add_option("-o,--output", o.output_path, "Points file to write ('-' for stdout)");
  app.add_option("--truth", o.truth_path, "Also write the truth (JSON) to this file");
  AddMachineOptions(app, o.machine);
  app.add_option("--center-mm", o.centers_mm, "Sphere centre x,y,z [mm]; repeat for several setups");
  app.add_option("--seed", o.seed, "Random seed");
  app.add_option("--sample-period-s", o.sample_period_s, "Time between samples [s]")
      ->check(InRange({0.0, 86400.0, "s"}));
  app.add_option("--effect-arcsec", o.effects_arcsec,
                 "An angle effect's parameter, id.param=value [arcsec], e.g. theta_encoder.c2=10; repeatable")
      ->group("Effects (not declared in the points file)");
  app.add_option("--effect-um", o.effects_um,
                 "A length effect's parameter, id.param=value [um], e.g. probe_drift.t1=0.5; repeatable")
      ->group("Effects (not declared in the points file)");
  app.add_option("--form-um", o.form_um,
                 "Form error of the sphere: l,m,amplitude [um] of a Schmidt semi-normalised real spherical harmonic; "
                 "repeatable")
      ->group("Effects (not declared in the points file)");
  app.add_option("--outlier-fraction", o.outlier_fraction, "Share of readings with a gross error in r")
      ->check(CLI::Range(0.0, 1.0))
      ->group("Effects (not declared in the points file)");
  app.add_option("--outlier-um", o.outlier_um, "Size of the gross error (random sign) [um]")
      ->check(InRange({0.0, 1e6, "um"}))
      ->group("Effects (not declared in the points file)");
}

int RunSimulate(const SimulateOptions& o, std::ostream& err) {
  try {
    RunPaths()
        .Input("--angles", o.machine.angles_path)
        .Output("--output", o.output_path)
        .Output("--truth", o.truth_path);
    SimulationSpec spec = ToSimulationSpec(o.machine);
    spec.centers_mm.clear();
    for (const auto& c : o.centers_mm) spec.centers_mm.push_back(ParseVector3(c, "--center-mm"));
    spec.seed = o.seed;
    spec.sample_period_s = o.sample_period_s;
    for (const auto& e : o.effects_arcsec) AddEffectValue(e, Quantity::kAngle, spec.effects);
    for (const auto& e : o.effects_um) AddEffectValue(e, Quantity::kLength, spec.effects);
    for (const auto& f : o.form_um) {
      FormComponent c;
      char tail = 0;
      if (std::sscanf(f.c_str(), "%d,%d,%lf%c", &c.l, &c.m, &c.amplitude_um, &tail) != 3 || c.l < 0 || c.l > 20 ||
          std::abs(c.m) > c.l) {
        throw Error("--form-um " + f + ": expected l,m,amplitude_um with 0 <= l <= 20 and |m| <= l");
      }
      CheckedValue(c.amplitude_um, ranges::kEffectUm, "--form-um " + f, Format("%g", c.amplitude_um));
      spec.effects.form.push_back(c);
    }
    spec.effects.outlier_fraction = o.outlier_fraction;
    spec.effects.outlier_um = o.outlier_um;
    EffectReference reference;
    PointsData data = Simulate(spec, &reference);
    data.header.metadata.emplace_back("generator", "sph_simulate " SPH_VERSION);
    data.header.metadata.emplace_back("seed", std::to_string(o.seed));

    OutputFiles files;
    if (!o.truth_path.empty()) {
      nlohmann::json t;
      t["format"] = "sph-truth";
      t["generator"] = "sph_simulate " SPH_VERSION;
      nlohmann::json geometry = nlohmann::json::object();
      for (int p = 0; p < kNumScmsParams; ++p) {
        const ScmsParamInfo& info = kScmsParamInfo[static_cast<std::size_t>(p)];
        geometry[info.name] = {{"value", ToReportUnits(p, spec.truth[static_cast<std::size_t>(p)])},
                               {"unit", info.quantity == Quantity::kAngle ? "deg" : "mm"}};
      }
      t["geometry"] = geometry;
      nlohmann::json centers = nlohmann::json::array();
      for (const auto& c : spec.centers_mm) centers.push_back({c.x(), c.y(), c.z()});
      t["centers_mm"] = centers;
      t["sphere_radius_mm"] = o.machine.sphere_radius_mm;
      t["probe_offset_mm"] = o.machine.probe_offset_mm;
      t["noise"] = {{"r_um", o.machine.noise_r_um},
                    {"theta_arcsec", o.machine.noise_theta_arcsec},
                    {"phi_arcsec", o.machine.noise_phi_arcsec}};
      t["seed"] = o.seed;
      nlohmann::json effects = nlohmann::json::array();
      for (std::size_t k = 0; k < spec.effects.model.terms.size(); ++k) {
        const EffectTerm& term = spec.effects.model.terms[k];
        const bool angle = term.info().quantity == Quantity::kAngle;
        nlohmann::json params = nlohmann::json::object();
        for (std::size_t i = 0; i < term.components.size(); ++i) {
          params[term.ParamName(i)] = {{"value", spec.effects.values[k][i] / (angle ? kRadPerArcsec : kMmPerUm)},
                                       {"unit", angle ? "arcsec" : "um"}};
        }
        effects.push_back({{"id", term.info().id}, {"parameters", params}});
      }
      t["effects"] = effects;
      t["effect_reference"] = {{"r_ref_mm", reference.r_ref_mm},
                               {"r_half_range_mm", reference.r_half_range_mm},
                               {"t_start_s", reference.t_start_s},
                               {"t_span_s", reference.t_span_s}};
      nlohmann::json form = nlohmann::json::array();
      for (const FormComponent& f : spec.effects.form) form.push_back({{"l", f.l}, {"m", f.m}, {"amplitude_um", f.amplitude_um}});
      t["form_um"] = form;
      t["outliers"] = {{"fraction", o.outlier_fraction}, {"size_um", o.outlier_um}};
      t["n_points"] = data.samples.size();
      files.Stage(o.truth_path, [&](std::ostream& f) { f << t.dump(2) << "\n"; });
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
