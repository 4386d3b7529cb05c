#include "sph/core/calibration_file.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <Eigen/Eigenvalues>

#include <nlohmann/json.hpp>

#include "sph/core/error.hpp"
#include "sph/core/output_files.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using internal::Format;
using nlohmann::json;

const char* UnitOf(int p) { return kScmsParamInfo[static_cast<std::size_t>(p)].quantity == Quantity::kAngle ? "deg" : "mm"; }

const json& Field(const json& obj, const char* key, const std::string& where, const std::string& path) {
  if (!obj.is_object() || !obj.contains(key)) throw Error(path + ": missing field '" + where + key + "'");
  return obj.at(key);
}

double Number(const json& obj, const char* key, const std::string& where, const std::string& path) {
  const json& v = Field(obj, key, where, path);
  if (!v.is_number()) throw Error(path + ": field '" + where + key + "' must be a number");
  return v.get<double>();
}

const char* EffectUnit(const EffectTerm& t) { return t.info().quantity == Quantity::kAngle ? "arcsec" : "um"; }
double EffectScale(const EffectTerm& t) { return t.info().quantity == Quantity::kAngle ? kRadPerArcsec : kMmPerUm; }

// The "effects" array and "effect_reference" of a calibration file.
void ParseEffects(const json& j, const std::string& path, CalibrationFile& cal) {
  const json& effects = Field(j, "effects", "", path);
  if (!effects.is_array()) throw Error(path + ": field 'effects' must be an array");
  for (std::size_t k = 0; k < effects.size(); ++k) {
    const std::string where = "effects[" + std::to_string(k) + "].";
    const json& id = Field(effects[k], "id", where, path);
    Effect e;
    if (!id.is_string() || !EffectFromId(id.get<std::string>(), &e)) {
      throw Error(path + ": field '" + where + "id': unknown effect " + id.dump());
    }
    if (e == Effect::kProbeDrift) {
      throw Error(path + ": field '" + where + "id': probe_drift belongs to the run it was measured in and cannot be "
                  "applied to other measurements");
    }
    if (cal.effects.Find(e) >= 0) throw Error(path + ": field '" + where + "id': " + InfoOf(e).id + " is listed twice");
    EffectTerm term{e, {}};
    std::vector<double> values;
    const json& params = Field(effects[k], "parameters", where, path);
    if (!params.is_array() || params.empty()) throw Error(path + ": field '" + where + "parameters' must be a non-empty array");
    for (std::size_t i = 0; i < params.size(); ++i) {
      const std::string pw = where + "parameters[" + std::to_string(i) + "].";
      const json& name = Field(params[i], "name", pw, path);
      EffectComponent c;
      if (!name.is_string() || !FindComponent(e, name.get<std::string>(), &c)) {
        throw Error(path + ": field '" + pw + "name': " + name.dump() + " is no parameter of " + InfoOf(e).id);
      }
      for (std::size_t q = 0; q < term.components.size(); ++q) {
        if (term.ParamName(q) == name.get<std::string>()) throw Error(path + ": field '" + pw + "name': " + name.dump() + " is listed twice");
      }
      term.components.push_back(c);
      if (Field(params[i], "unit", pw, path) != EffectUnit(term)) {
        throw Error(path + ": field '" + pw + "unit' must be \"" + EffectUnit(term) + "\"");
      }
      const double v = Number(params[i], "value", pw, path);
      const double max_abs = term.info().quantity == Quantity::kAngle ? kMaxEffectArcsec : kMaxEffectUm;
      if (!(std::abs(v) <= max_abs)) {
        throw Error(path + ": field '" + pw + "value' is " + Format("%g", v) + " " + EffectUnit(term) +
                    ": an effect of the machine lies within " + Format("%g", max_abs) + " " + EffectUnit(term));
      }
      values.push_back(v * EffectScale(term));
    }
    if (e == Effect::kPhiWobble && effects[k].contains("pivot_mm")) {
      const double pivot = Number(effects[k], "pivot_mm", where, path);
      if (!(std::abs(pivot) <= kMaxPivotMm)) {
        throw Error(path + ": field '" + where + "pivot_mm' is " + Format("%g", pivot) +
                    " mm: the Phi axis' pivot lies within " + Format("%g", kMaxPivotMm) + " mm of its frame's origin");
      }
      cal.effects.phi_wobble_pivot_mm = pivot;
    }
    cal.effects.terms.push_back(term);
    cal.effect_values.push_back(values);
  }
  if (cal.effects.Empty()) return;
  const json& ref = Field(j, "effect_reference", "", path);
  EffectReference& r = cal.effects.reference;
  r.r_ref_mm = Number(ref, "r_ref_mm", "effect_reference.", path);
  r.r_half_range_mm = Number(ref, "r_half_range_mm", "effect_reference.", path);
  r.t_start_s = Number(ref, "t_start_s", "effect_reference.", path);
  r.t_span_s = Number(ref, "t_span_s", "effect_reference.", path);
  if (ref.contains("r_fit_min_mm") || ref.contains("r_fit_max_mm")) {
    r.r_fit_min_mm = Number(ref, "r_fit_min_mm", "effect_reference.", path);
    r.r_fit_max_mm = Number(ref, "r_fit_max_mm", "effect_reference.", path);
    if (!(r.r_fit_min_mm <= r.r_fit_max_mm) || !std::isfinite(r.r_fit_min_mm) || !std::isfinite(r.r_fit_max_mm)) {
      throw Error(path +
                  ": field 'effect_reference': r_fit_min_mm and r_fit_max_mm must be finite, the first not "
                  "above the second");
    }
  }
  if (!(r.r_half_range_mm >= kMinProbeHalfRangeMm) || !(r.t_span_s > 0.0) || !std::isfinite(r.r_ref_mm) ||
      !std::isfinite(r.t_start_s)) {
    throw Error(path + ": field 'effect_reference': r_half_range_mm must be at least " +
                std::to_string(kMinProbeHalfRangeMm) + " mm and t_span_s positive, all finite");
  }
}

// The optional "sphere_form" object (see the header).
void ParseSphereForm(const json& j, const std::string& path, CalibrationFile& cal) {
  if (!j.contains("sphere_form")) return;
  const json& f = j["sphere_form"];
  if (!f.is_object()) throw Error(path + ": field 'sphere_form' must be an object");
  if (Field(f, "normalisation", "sphere_form.", path) != "schmidt_semi_normalised") {
    throw Error(path + ": field 'sphere_form.normalisation' must be \"schmidt_semi_normalised\"");
  }
  if (Field(f, "frame", "sphere_form.", path) != "body")
    throw Error(path + ": field 'sphere_form.frame' must be \"body\"");
  if (Field(f, "unit", "sphere_form.", path) != "um") throw Error(path + ": field 'sphere_form.unit' must be \"um\"");
  const json& terms = Field(f, "terms", "sphere_form.", path);
  if (!terms.is_array()) throw Error(path + ": field 'sphere_form.terms' must be an array");
  bool with_std = true;
  for (std::size_t i = 0; i < terms.size(); ++i) {
    const std::string where = "sphere_form.terms[" + std::to_string(i) + "].";
    const json& t = terms[i];
    const json& l = Field(t, "l", where, path);
    const json& m = Field(t, "m", where, path);
    if (!l.is_number_integer() || !m.is_number_integer()) {
      throw Error(path + ": field '" + where + "l' and 'm' must be integers");
    }
    const FormTerm term{l.get<int>(), m.get<int>()};
    if (term.l < 2 || term.l > kMaxHarmonicDegree || std::abs(term.m) > term.l) {
      throw Error(path + ": field '" + where + "': degree " + std::to_string(term.l) + " and order " +
                  std::to_string(term.m) + ": a form term has 2 <= l <= " + std::to_string(kMaxHarmonicDegree) +
                  " and |m| <= l");
    }
    for (const FormTerm& seen : cal.form_terms) {
      if (seen == term) {
        throw Error(path + ": field '" + where + "': the term l = " + std::to_string(term.l) +
                    ", m = " + std::to_string(term.m) + " is listed twice");
      }
    }
    const double v = Number(t, "value_um", where, path);
    if (!(std::abs(v) <= kMaxEffectUm)) {
      throw Error(path + ": field '" + where + "value_um' is " + Format("%g", v) + " um: a form term lies within " +
                  Format("%g", kMaxEffectUm) + " um");
    }
    cal.form_terms.push_back(term);
    cal.form_values_mm.push_back(v * kMmPerUm);
    if (t.contains("std_um") && t["std_um"].is_number() && std::isfinite(t["std_um"].get<double>()) &&
        t["std_um"].get<double>() >= 0.0) {
      cal.form_std_mm.push_back(t["std_um"].get<double>() * kMmPerUm);
    } else {
      with_std = false;
    }
  }
  if (!with_std) cal.form_std_mm.clear();
}

// A covariance matrix must be one: symmetric, with variances >= 0, positive semi-definite (to
// rounding). Else the draws of sph_measure's uncertainty would be nonsense, or NaN.
void CheckCovariance(const ScmsCovariance& c, const std::string& path) {
  for (int p = 0; p < kNumScmsParams; ++p) {
    if (!(c(p, p) >= 0.0) || !std::isfinite(c(p, p))) {
      throw Error(path + ": covariance.matrix: the variance of " + kScmsParamInfo[static_cast<std::size_t>(p)].name +
                  " is " + Format("%g", ToReportUnits(p, ToReportUnits(p, c(p, p)))) +
                  ": a variance is finite and >= 0");
    }
  }
  for (int p = 0; p < kNumScmsParams; ++p) {
    for (int q = p + 1; q < kNumScmsParams; ++q) {
      const double scale = std::sqrt(c(p, p) * c(q, q));
      if (!std::isfinite(c(p, q)) || std::abs(c(p, q) - c(q, p)) > 1e-9 * scale + 1e-300) {
        throw Error(path + ": covariance.matrix is not symmetric: the entries of " +
                    kScmsParamInfo[static_cast<std::size_t>(p)].name + " and " +
                    kScmsParamInfo[static_cast<std::size_t>(q)].name + " differ");
      }
    }
  }
  // Positive semi-definite, judged on the correlation matrix so that units do not matter.
  const Eigen::VectorXd s = c.diagonal().cwiseSqrt().cwiseMax(1e-300);
  const Eigen::MatrixXd corr = s.cwiseInverse().asDiagonal() * c * s.cwiseInverse().asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(corr);
  if (eig.eigenvalues().minCoeff() < -1e-8) {
    throw Error(path + ": covariance.matrix is not positive semi-definite (its correlation matrix has the eigenvalue " +
                Format("%.3g", eig.eigenvalues().minCoeff()) + "): it is not the covariance of any estimate");
  }
}

}  // namespace

void WriteCalibrationFile(const std::string& path, const CalibrationFile& cal) {
  WriteFileAtomically(path, [&](std::ostream& out) { WriteCalibration(out, cal); });
}

void WriteCalibration(std::ostream& out, const CalibrationFile& cal) {
  json j;
  j["format"] = "sph-calibration";
  j["format_version"] = kCalibrationFormatVersion;
  j["created_by"] = cal.created_by;
  j["probe_offset_mm"] = cal.probe_offset_mm;
  if (cal.sphere_radius_mm) j["sphere_radius_mm"] = *cal.sphere_radius_mm;
  json geometry = json::object();
  for (int p = 0; p < kNumScmsParams; ++p) {
    geometry[kScmsParamInfo[static_cast<std::size_t>(p)].name] = {
        {"value", ToReportUnits(p, cal.geometry[static_cast<std::size_t>(p)])}, {"unit", UnitOf(p)}};
  }
  j["geometry"] = geometry;
  if (cal.covariance) {
    json names = json::array(), units = json::array(), rows = json::array();
    for (int p = 0; p < kNumScmsParams; ++p) {
      names.push_back(kScmsParamInfo[static_cast<std::size_t>(p)].name);
      units.push_back(UnitOf(p));
      json row = json::array();
      for (int q = 0; q < kNumScmsParams; ++q) row.push_back(ToReportUnits(q, ToReportUnits(p, (*cal.covariance)(p, q))));
      rows.push_back(row);
    }
    j["covariance"] = {{"parameters", names}, {"units", units}, {"matrix", rows}};
  }
  json effects = json::array();
  for (std::size_t t = 0; t < cal.effects.terms.size(); ++t) {
    const EffectTerm& term = cal.effects.terms[t];
    json params = json::array();
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      params.push_back({{"name", term.ParamName(i)},
                        {"value", cal.effect_values[t][i] / EffectScale(term)},
                        {"unit", EffectUnit(term)}});
    }
    json entry = {{"id", term.info().id}, {"iso_name", term.info().iso_name}, {"parameters", params}};
    if (term.effect == Effect::kPhiWobble) entry["pivot_mm"] = cal.effects.phi_wobble_pivot_mm;
    effects.push_back(entry);
  }
  j["effects"] = effects;
  if (!cal.form_terms.empty()) {
    json terms = json::array();
    for (std::size_t k = 0; k < cal.form_terms.size(); ++k) {
      json t = {{"l", cal.form_terms[k].l}, {"m", cal.form_terms[k].m}, {"value_um", cal.form_values_mm[k] * kUmPerMm}};
      if (k < cal.form_std_mm.size()) t["std_um"] = cal.form_std_mm[k] * kUmPerMm;
      terms.push_back(t);
    }
    j["sphere_form"] = {
        {"normalisation", "schmidt_semi_normalised"}, {"frame", "body"}, {"unit", "um"}, {"terms", terms}};
  }
  if (!cal.effects.Empty()) {
    const EffectReference& r = cal.effects.reference;
    j["effect_reference"] = {{"r_ref_mm", r.r_ref_mm},     {"r_half_range_mm", r.r_half_range_mm},
                             {"t_start_s", r.t_start_s},   {"t_span_s", r.t_span_s},
                             {"r_fit_min_mm", r.FitMin()}, {"r_fit_max_mm", r.FitMax()}};
  }
  json source = json::object();
  for (const auto& [k, v] : cal.source) source[k] = v;
  j["source"] = source;
  out << j.dump(2) << "\n";
}

CalibrationFile ReadCalibrationFile(const std::string& path) {
  std::ifstream in = OpenInputFile(path);
  return ParseCalibration(in, path);
}

CalibrationFile ParseCalibration(std::istream& in, const std::string& path) {
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error(path + ": read error");
  json j;
  try {
    j = json::parse(text.str());  // the whole text: one JSON value and nothing after it
  } catch (const json::exception& e) {
    throw Error(path + ": not valid JSON: " + e.what());
  }
  if (!j.is_object() || !j.contains("format") || j["format"] != "sph-calibration") {
    throw Error(path + ": not an sph calibration file (field \"format\" must be \"sph-calibration\")");
  }
  const json& version = Field(j, "format_version", "", path);
  if (!version.is_number_integer() || version.get<int>() != kCalibrationFormatVersion) {
    throw Error(path + ": calibration format version " + version.dump() + " is not supported (this program reads " +
                std::to_string(kCalibrationFormatVersion) + ")");
  }
  CalibrationFile cal;
  cal.probe_offset_mm = Number(j, "probe_offset_mm", "", path);
  if (!(cal.probe_offset_mm > 0.0)) throw Error(path + ": probe_offset_mm must be positive");
  if (j.contains("sphere_radius_mm")) cal.sphere_radius_mm = Number(j, "sphere_radius_mm", "", path);
  if (j.contains("created_by") && j["created_by"].is_string()) cal.created_by = j["created_by"].get<std::string>();
  const json& geometry = Field(j, "geometry", "", path);
  for (int p = 0; p < kNumScmsParams; ++p) {
    const char* name = kScmsParamInfo[static_cast<std::size_t>(p)].name;
    const json& entry = Field(geometry, name, "geometry.", path);
    const std::string where = std::string("geometry.") + name + ".";
    const json& unit = Field(entry, "unit", where, path);
    if (unit != UnitOf(p)) throw Error(path + ": field '" + where + "unit' must be \"" + UnitOf(p) + "\"");
    const double value = Number(entry, "value", where, path);
    const double max_abs = p == kDPrime ? std::min(kScmsParamInfo[kDPrime].max_abs_report, cal.probe_offset_mm)
                                        : kScmsParamInfo[static_cast<std::size_t>(p)].max_abs_report;
    if (!(std::abs(value) < max_abs || (p != kDPrime && std::abs(value) == max_abs))) {
      throw Error(path + ": field '" + where + "value' is " + Format("%g", value) + " " + UnitOf(p) +
                  ": a geometric error of the machine lies within " + Format("%g", max_abs) + " " + UnitOf(p) +
                  (p == kDPrime ? " (and below probe_offset_mm)" : "") + " in size");
    }
    cal.geometry[static_cast<std::size_t>(p)] = FromReportUnits(p, value);
  }
  if (j.contains("covariance")) {
    // The matrix is only meaningful in the order and units it names: they must be the writer's.
    for (const char* key : {"parameters", "units"}) {
      json expected = json::array();
      for (int p = 0; p < kNumScmsParams; ++p) {
        expected.push_back(std::string(key) == "units" ? UnitOf(p) : kScmsParamInfo[static_cast<std::size_t>(p)].name);
      }
      if (Field(j["covariance"], key, "covariance.", path) != expected) {
        throw Error(path + ": field 'covariance." + key + "' must be " + expected.dump());
      }
    }
    const json& rows = Field(j["covariance"], "matrix", "covariance.", path);
    if (!rows.is_array() || rows.size() != kNumScmsParams) throw Error(path + ": covariance.matrix must be 7 x 7");
    Eigen::Matrix<double, kNumScmsParams, kNumScmsParams> c;
    for (int p = 0; p < kNumScmsParams; ++p) {
      const json& row = rows[static_cast<std::size_t>(p)];
      if (!row.is_array() || row.size() != kNumScmsParams) throw Error(path + ": covariance.matrix must be 7 x 7");
      for (int q = 0; q < kNumScmsParams; ++q) {
        const json& v = row[static_cast<std::size_t>(q)];
        if (!v.is_number()) throw Error(path + ": covariance.matrix has a non-number");
        c(p, q) = FromReportUnits(q, FromReportUnits(p, v.get<double>()));
      }
    }
    CheckCovariance(c, path);
    cal.covariance = c;
  }
  ParseEffects(j, path, cal);
  ParseSphereForm(j, path, cal);
  if (j.contains("source") && j["source"].is_object()) {
    for (const auto& [k, v] : j["source"].items()) cal.source.emplace_back(k, v.is_string() ? v.get<std::string>() : v.dump());
  }
  return cal;
}

Calibration ToCalibration(const CalibrationFile& file) {
  Calibration cal;
  cal.geometry = file.geometry;
  cal.probe_offset_mm = file.probe_offset_mm;
  cal.covariance = file.covariance;
  cal.effects = file.effects;
  cal.effect_values = file.effect_values;
  return cal;
}

Calibration LoadCalibration(const std::string& path) { return ToCalibration(ReadCalibrationFile(path)); }

}  // namespace sph
