// The truth file of a simulation: everything its points were made of.
#include <cmath>
#include <map>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

nlohmann::json Vector(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// The truth's form: what the options gave, on the body frame, and its size.
nlohmann::json FormTruth(const SimulationSpec& spec) {
  const SimulatedEffects& e = spec.effects;
  nlohmann::json terms = nlohmann::json::array();
  std::map<std::pair<int, int>, double> sum;  // a term given twice adds up
  for (const FormComponent& f : e.form) {
    terms.push_back({{"l", f.l}, {"m", f.m}, {"amplitude_um", f.amplitude_um}});
    sum[{f.l, f.m}] += f.amplitude_um;
  }
  double ms = 0.0;
  for (const auto& [lm, a] : sum) {
    if (lm.first >= 2) ms += a * a / (2.0 * lm.first + 1.0);
  }
  nlohmann::json flats = nlohmann::json::array(), bumps = nlohmann::json::array();
  for (const FormFlat& f : e.flats) {
    flats.push_back({{"depth_um", f.depth_um}, {"normal_body", Vector(f.normal_body.normalized())}});
  }
  for (const FormBump& b : e.bumps) {
    bumps.push_back(
        {{"height_um", b.height_um}, {"width_deg", b.width_deg}, {"center_body", Vector(b.center_body.normalized())}});
  }
  nlohmann::json form = {
      {"frame", "body: p_theta = R(mount_rotation_deg) p_body about the sphere's centre"},
      {"harmonics",
       {{"normalisation",
         "Schmidt semi-normalised real spherical harmonics of the body direction: |S_lm| <= 1, mean square "
         "1/(2l+1) over the sphere, cos(m lon) for m >= 0, sin(|m| lon) for m < 0, no Condon-Shortley phase"},
        {"terms", terms},
        {"rms_um", std::sqrt(ms)}}},
      {"flats", flats},
      {"bumps", bumps}};
  const FormSize size = FormSizeOf(e, spec.sphere_radius_mm);
  form["rms_um"] = size.rms_um;  // all of the form without its degree 0 and 1 parts
  form["pv_um"] = size.pv_um;
  return form;
}

// The truth's seven geometric errors, each in its report unit.
nlohmann::json GeometryTruth(const SimulationSpec& spec) {
  nlohmann::json geometry = nlohmann::json::object();
  for (int p = 0; p < kNumScmsParams; ++p) {
    const ScmsParamInfo& info = kScmsParamInfo[static_cast<std::size_t>(p)];
    geometry[info.name] = {{"value", ToReportUnits(p, spec.truth[static_cast<std::size_t>(p)])},
                           {"unit", ReportUnitsOf(p).coarse}};
  }
  return geometry;
}

// The sphere's centre in each setup.
nlohmann::json CentersTruth(const SimulationSpec& spec) {
  nlohmann::json centers = nlohmann::json::array();
  for (const Eigen::Vector3d& c : spec.centers_mm) centers.push_back(Vector(c));
  return centers;
}

// Each setup: its centre, mount rotation, what the header says of the rotation, and scan order.
nlohmann::json SetupsTruth(const SimulationSpec& spec) {
  nlohmann::json setups = nlohmann::json::array();
  for (std::size_t k = 0; k < spec.centers_mm.size(); ++k) {
    const int id = static_cast<int>(k);
    const auto rotation = spec.mount_rotations_deg.find(id);
    const auto order = spec.scan_orders.find(id);
    setups.push_back(
        {{"setup", id},
         {"center_mm", Vector(spec.centers_mm[k])},
         {"mount_rotation_deg",
          Vector(rotation == spec.mount_rotations_deg.end() ? Eigen::Vector3d::Zero() : rotation->second)},
         {"header", spec.mount_unknown.count(id)                 ? "unknown"
                    : rotation != spec.mount_rotations_deg.end() ? "rotation"
                                                                 : "none"},
         {"scan_order", ScanOrderName(order == spec.scan_orders.end() ? spec.scan_order : order->second)}});
    const auto other = spec.sphere_radii_mm.find(id);
    if (other != spec.sphere_radii_mm.end()) setups.back()["sphere_radius_mm"] = other->second;
  }
  return setups;
}

// The effects of the simulation, each parameter in arcsec or um.
nlohmann::json EffectsTruth(const SimulationSpec& spec) {
  nlohmann::json effects = nlohmann::json::array();
  for (std::size_t k = 0; k < spec.effects.model.terms.size(); ++k) {
    const EffectTerm& term = spec.effects.model.terms[k];
    const bool angle = term.info().quantity == Quantity::kAngle;
    nlohmann::json params = nlohmann::json::object();
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      params[term.ParamName(i)] = {{"value", spec.effects.values[k][i] / (angle ? kRadPerArcsec : kMmPerUm)},
                                   {"unit", angle ? "arcsec" : "um"}};
    }
    nlohmann::json entry = {{"id", term.info().id}, {"iso_name", term.info().iso_name}, {"parameters", params}};
    if (term.effect == Effect::kPhiWobble) entry["pivot_mm"] = spec.effects.model.phi_wobble_pivot_mm;
    effects.push_back(entry);
  }
  return effects;
}

// The truth file (JSON) of a simulation: everything the points were made of.
}  // namespace

std::string SimulationTruthJson(const SimulationSpec& spec, const EffectReference& reference, const PointsData& data) {
  nlohmann::json t;
  t["format"] = "sph-truth";
  t["generator"] = "sph_simulate " SPH_VERSION;
  t["geometry"] = GeometryTruth(spec);
  t["centers_mm"] = CentersTruth(spec);
  t["setups"] = SetupsTruth(spec);
  t["sphere_radius_mm"] = spec.sphere_radius_mm;
  t["probe_offset_mm"] = spec.probe_offset_mm;
  t["noise"] = {
      {"r_um", spec.noise_r_um}, {"theta_arcsec", spec.noise_theta_arcsec}, {"phi_arcsec", spec.noise_phi_arcsec}};
  t["seed"] = spec.seed;
  t["effects"] = EffectsTruth(spec);
  t["effect_reference"] = {{"r_ref_mm", reference.r_ref_mm},
                           {"r_half_range_mm", reference.r_half_range_mm},
                           {"t_start_s", reference.t_start_s},
                           {"t_span_s", reference.t_span_s}};
  t["form"] = FormTruth(spec);
  t["outliers"] = {{"fraction", spec.effects.outlier_fraction}, {"size_um", spec.effects.outlier_um}};
  t["n_points"] = data.samples.size();
  return t.dump(2) + "\n";
}

}  // namespace sph
