#include "sph/io/calibration_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <utility>

#include <Eigen/Eigenvalues>

#include <nlohmann/json.hpp>

#include "json_input.hpp"
#include "sph/core/error.hpp"
#include "sph/io/output_files.hpp"
#include "sph/io/points_file.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using internal::Format;
using internal::JsonExcerpt;
using nlohmann::json;

const char* UnitOf(int p) { return ReportUnitsOf(p).coarse; }

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
      throw Error(path + ": field '" + where + "id': unknown effect " + JsonExcerpt(id));
    }
    if (e == Effect::kProbeDrift) {
      throw Error(path + ": field '" + where +
                  "id': probe_drift belongs to the run it was measured in and cannot be "
                  "applied to other measurements");
    }
    if (cal.effects.Find(e) >= 0) throw Error(path + ": field '" + where + "id': " + InfoOf(e).id + " is listed twice");
    EffectTerm term{e, {}};
    std::vector<double> values;
    const json& params = Field(effects[k], "parameters", where, path);
    if (!params.is_array() || params.empty())
      throw Error(path + ": field '" + where + "parameters' must be a non-empty array");
    for (std::size_t i = 0; i < params.size(); ++i) {
      const std::string pw = where + "parameters[" + std::to_string(i) + "].";
      const json& name = Field(params[i], "name", pw, path);
      EffectComponent c;
      if (!name.is_string() || !FindComponent(e, name.get<std::string>(), &c)) {
        throw Error(path + ": field '" + pw + "name': " + JsonExcerpt(name) + " is no parameter of " + InfoOf(e).id);
      }
      for (std::size_t q = 0; q < term.components.size(); ++q) {
        if (term.ParamName(q) == name.get<std::string>())
          throw Error(path + ": field '" + pw + "name': " + JsonExcerpt(name) + " is listed twice");
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
    if (t.contains("std_um")) {
      const double u = Number(t, "std_um", where, path);
      if (!(u >= 0.0 && u <= kMaxEffectUm)) {
        throw Error(path + ": field '" + where + "std_um' is " + Format("%g", u) +
                    " um: a standard uncertainty is >= 0, and one of a form term within " + Format("%g", kMaxEffectUm) +
                    " um");
      }
      cal.form_std_mm.push_back(u * kMmPerUm);
    } else {
      with_std = false;
    }
  }
  if (!with_std) cal.form_std_mm.clear();
}

// One parameter of the file's covariance: its name, the unit it is stored in, the internal
// units per stored unit, and the largest magnitude its value may have (stored units).
struct StoredParameter {
  std::string name;
  std::string unit;
  double scale;
  double max_abs;
};

std::vector<StoredParameter> StoredParameters(const CalibrationFile& cal) {
  std::vector<StoredParameter> v;
  for (int p = 0; p < kNumScmsParams; ++p) {
    const ScmsParamInfo& info = kScmsParamInfo[static_cast<std::size_t>(p)];
    v.push_back({info.name, UnitOf(p), FromReportUnits(p, 1.0),
                 p == kDPrime ? std::min(info.max_abs_report, cal.probe_offset_mm) : info.max_abs_report});
  }
  for (const EffectTerm& term : cal.effects.terms) {
    const double max_abs = term.info().quantity == Quantity::kAngle ? kMaxEffectArcsec : kMaxEffectUm;
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      v.push_back({term.ParamName(i), EffectUnit(term), EffectScale(term), max_abs});
    }
  }
  for (const FormTerm& t : cal.form_terms) {
    v.push_back(
        {"sphere_form.S(" + std::to_string(t.l) + "," + std::to_string(t.m) + ")", "um", kMmPerUm, kMaxEffectUm});
  }
  return v;
}

// The smallest eigenvalue of D^-1 m D^-1, D = diag(sd): of m's correlation matrix when sd are
// its own standard deviations; judged so, a matrix is semi-definite or not whatever its units.
double MinCorrelationEigenvalue(const Eigen::MatrixXd& m, const Eigen::VectorXd& sd) {
  const Eigen::VectorXd inv = sd.cwiseMax(1e-300).cwiseInverse();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(inv.asDiagonal() * m * inv.asDiagonal(),
                                                           Eigen::EigenvaluesOnly);
  return eig.eigenvalues().minCoeff();
}

// How far below zero an eigenvalue of a correlation matrix may lie from rounding.
constexpr double kSemiDefiniteTolerance = 1e-8;

// A covariance matrix must be one: symmetric, with variances >= 0, positive semi-definite (to
// rounding), and of a calibration: no parameter's standard uncertainty larger than any value the
// parameter may take (a file's bound on it), which says the calibration did not determine it.
// Else the draws of sph_measure's uncertainty would be nonsense, or NaN, and a linearised
// budget would step outside the model. `c` in stored units.
void CheckCovariance(const Eigen::MatrixXd& c, const std::vector<StoredParameter>& params, const std::string& path) {
  const Eigen::Index n = c.rows();
  for (Eigen::Index p = 0; p < n; ++p) {
    const StoredParameter& param = params[static_cast<std::size_t>(p)];
    if (!(c(p, p) >= 0.0) || !std::isfinite(c(p, p))) {
      throw Error(path + ": covariance.matrix: the variance of " + param.name + " is " + Format("%g", c(p, p)) +
                  ": a variance is finite and >= 0");
    }
    if (std::sqrt(c(p, p)) > param.max_abs) {
      throw Error(path + ": covariance.matrix: the standard uncertainty of " + param.name + " is " +
                  Format("%g", std::sqrt(c(p, p))) + " " + param.unit + ", more than any value of it (within " +
                  Format("%g", param.max_abs) + " " + param.unit + "): not the covariance of a calibration");
    }
  }
  for (Eigen::Index p = 0; p < n; ++p) {
    for (Eigen::Index q = p + 1; q < n; ++q) {
      const double scale = std::sqrt(c(p, p) * c(q, q));
      if (!std::isfinite(c(p, q)) || std::abs(c(p, q) - c(q, p)) > 1e-9 * scale + 1e-300) {
        throw Error(path + ": covariance.matrix is not symmetric: the entries of " +
                    params[static_cast<std::size_t>(p)].name + " and " + params[static_cast<std::size_t>(q)].name +
                    " differ");
      }
    }
  }
  const double min_eigenvalue = MinCorrelationEigenvalue(c, c.diagonal().cwiseSqrt());
  if (min_eigenvalue < -kSemiDefiniteTolerance) {
    throw Error(path + ": covariance.matrix is not positive semi-definite (its correlation matrix has the eigenvalue " +
                Format("%.3g", min_eigenvalue) + "): it is not the covariance of any estimate");
  }
}

// The largest standard uncertainty of a budget's input, by its unit: what a points file's header
// accepts for the same input (kConditionFields: R0's in um, the temperature's in K, the probe
// scale's relative).
std::optional<double> MaxInputU(const std::string& unit) {
  constexpr std::pair<const char*, const char*> kFieldOfUnit[] = {
      {"um", "sphere_radius_u_um"}, {"K", "sphere_temperature_u_c"}, {"relative", "probe_scale_u"}};
  for (const auto& [u, key] : kFieldOfUnit) {
    if (unit != u) continue;
    for (const ConditionField& f : kConditionFields) {
      if (std::string(f.key) == key) return f.max;
    }
  }
  return std::nullopt;
}

// The covariance holds its inputs (matrix = A + sum_j s_j s_j^T u_j^2): what is left without
// them, the Type A part A, is a covariance too. `c` and the sensitivities `s` in stored units.
void CheckTypeA(const Eigen::MatrixXd& c, const std::vector<Eigen::VectorXd>& s,
                const std::vector<CalibrationFile::CovarianceInput>& inputs, const std::vector<StoredParameter>& params,
                const std::string& path) {
  if (inputs.empty()) return;
  const Eigen::VectorXd sd = c.diagonal().cwiseSqrt();
  auto without = [&](std::size_t only) {  // c less input `only`'s part, or all inputs' (npos)
    Eigen::MatrixXd a = c;
    for (std::size_t k = 0; k < inputs.size(); ++k) {
      if (only != std::string::npos && k != only) continue;
      const Eigen::VectorXd su = s[k] * inputs[k].u;
      a -= su * su.transpose();
    }
    return a;
  };
  const Eigen::MatrixXd a = without(std::string::npos);
  for (Eigen::Index p = 0; p < c.rows(); ++p) {
    if (a(p, p) >= -kSemiDefiniteTolerance * c(p, p)) continue;
    std::size_t largest = 0;
    for (std::size_t k = 1; k < inputs.size(); ++k) {
      if (std::abs(s[k](p) * inputs[k].u) > std::abs(s[largest](p) * inputs[largest].u)) largest = k;
    }
    const StoredParameter& param = params[static_cast<std::size_t>(p)];
    throw Error(path + ": covariance.inputs: the inputs give " + param.name + " a variance of " +
                Format("%g", c(p, p) - a(p, p)) + " " + param.unit + "^2, more than covariance.matrix holds (" +
                Format("%g", c(p, p)) + " " + param.unit + "^2; the largest part from covariance.inputs[" +
                std::to_string(largest) + "], " + internal::Quoted(inputs[largest].input) +
                "): the matrix is not the sum of a Type A part and these inputs");
  }
  const double min_eigenvalue = MinCorrelationEigenvalue(a, sd);
  if (min_eigenvalue >= -kSemiDefiniteTolerance) return;
  std::string which = "together";
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    if (MinCorrelationEigenvalue(without(k), sd) < -kSemiDefiniteTolerance) {
      which = "covariance.inputs[" + std::to_string(k) + "], " + internal::Quoted(inputs[k].input) + ", alone";
      break;
    }
  }
  throw Error(path + ": covariance.inputs: the matrix less its inputs (" + which +
              ") is not positive semi-definite (eigenvalue " + Format("%.3g", min_eigenvalue) +
              " of the correlation): the matrix is not the sum of a Type A part and these inputs");
}

json NamesOf(const std::vector<StoredParameter>& params, std::size_t n, bool units) {
  json a = json::array();
  for (std::size_t i = 0; i < n; ++i) a.push_back(units ? params[i].unit : params[i].name);
  return a;
}

// The "covariance" object, read after the effects and the form that name its parameters.
void ParseCovariance(const json& cov, const std::string& path, CalibrationFile& cal) {
  const std::vector<StoredParameter> all = StoredParameters(cal);
  // The matrix is only meaningful in the order and units it names: they must be the writer's, of
  // the seven errors alone (older files) or of every parameter.
  const json& names = Field(cov, "parameters", "covariance.", path);
  std::size_t n = kNumScmsParams;
  if (all.size() > kNumScmsParams && names == NamesOf(all, all.size(), false)) n = all.size();
  for (const bool units : {false, true}) {
    const json expected = NamesOf(all, n, units);
    if (Field(cov, units ? "units" : "parameters", "covariance.", path) != expected) {
      std::string also;
      if (!units && all.size() > kNumScmsParams)
        also = " (the seven errors') or " + NamesOf(all, all.size(), false).dump();
      throw Error(path + ": field 'covariance." + (units ? "units" : "parameters") + "' must be " + expected.dump() +
                  also);
    }
  }
  const std::string size = std::to_string(n) + " x " + std::to_string(n);
  const json& rows = Field(cov, "matrix", "covariance.", path);
  if (!rows.is_array() || rows.size() != n) throw Error(path + ": covariance.matrix must be " + size);
  Eigen::MatrixXd stored(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
  for (std::size_t p = 0; p < n; ++p) {
    const json& row = rows[p];
    if (!row.is_array() || row.size() != n) throw Error(path + ": covariance.matrix must be " + size);
    for (std::size_t q = 0; q < n; ++q) {
      const json& v = row[q];
      if (!v.is_number()) throw Error(path + ": covariance.matrix has a non-number");
      stored(static_cast<Eigen::Index>(p), static_cast<Eigen::Index>(q)) = v.get<double>();
    }
  }
  CheckCovariance(stored, all, path);
  Eigen::VectorXd scale(static_cast<Eigen::Index>(n));
  for (std::size_t p = 0; p < n; ++p) scale(static_cast<Eigen::Index>(p)) = all[p].scale;
  const Eigen::MatrixXd c = scale.asDiagonal() * stored * scale.asDiagonal();
  cal.covariance = c.topLeftCorner<kNumScmsParams, kNumScmsParams>();
  if (n > kNumScmsParams) cal.parameter_covariance = c;
  if (cov.contains("type_a_dof") && !cov["type_a_dof"].is_null()) {
    const double dof = Number(cov, "type_a_dof", "covariance.", path);
    if (!(dof >= 1.0))
      throw Error(path + ": field 'covariance.type_a_dof' must be at least 1, got " + Format("%g", dof));
    cal.covariance_type_a_dof = dof;
  }
  if (!cov.contains("inputs")) return;
  const json& inputs = cov["inputs"];
  if (!inputs.is_array()) throw Error(path + ": field 'covariance.inputs' must be an array");
  std::vector<Eigen::VectorXd> sensitivities;  // stored units
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    const std::string where = "covariance.inputs[" + std::to_string(k) + "].";
    CalibrationFile::CovarianceInput in;
    const json& name = Field(inputs[k], "input", where, path);
    const json& unit = Field(inputs[k], "unit", where, path);
    if (!name.is_string() || !unit.is_string()) {
      throw Error(path + ": field '" + where + "input' and 'unit' must be strings");
    }
    in.input = name.get<std::string>();
    in.unit = unit.get<std::string>();
    const std::optional<double> max_u = MaxInputU(in.unit);
    if (!max_u) {
      throw Error(path + ": field '" + where + "unit' is " + internal::Quoted(in.unit) +
                  ": an input of the budget is in um, K or relative");
    }
    in.u = Number(inputs[k], "u", where, path);
    if (!(in.u >= 0.0 && in.u <= *max_u)) {
      throw Error(path + ": field '" + where + "u' is " + Format("%g", in.u) + " " + in.unit +
                  ": the standard uncertainty of an input in " + in.unit + " lies within [0, " + Format("%g", *max_u) +
                  "]");
    }
    const json& s = Field(inputs[k], "sensitivity", where, path);
    if (!s.is_array() || s.size() != n) {
      throw Error(path + ": field '" + where + "sensitivity' must hold " + std::to_string(n) +
                  " numbers, one per covariance parameter");
    }
    in.per_unit.resize(static_cast<Eigen::Index>(n));
    Eigen::VectorXd s_stored(static_cast<Eigen::Index>(n));
    for (std::size_t p = 0; p < n; ++p) {
      if (!s[p].is_number() || !std::isfinite(s[p].get<double>())) {
        throw Error(path + ": field '" + where + "sensitivity' has a non-number");
      }
      s_stored(static_cast<Eigen::Index>(p)) = s[p].get<double>();
      in.per_unit(static_cast<Eigen::Index>(p)) = s[p].get<double>() * all[p].scale;
    }
    cal.covariance_inputs.push_back(in);
    sensitivities.push_back(s_stored);
  }
  CheckTypeA(stored, sensitivities, cal.covariance_inputs, all, path);
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
  const Eigen::MatrixXd c = AppliedCovariance(cal);
  if (c.size() > 0) {
    const std::vector<StoredParameter> all = StoredParameters(cal);
    const auto n = static_cast<std::size_t>(c.rows());
    json rows = json::array();
    for (std::size_t p = 0; p < n; ++p) {
      json row = json::array();
      for (std::size_t q = 0; q < n; ++q) {
        row.push_back(c(static_cast<Eigen::Index>(p), static_cast<Eigen::Index>(q)) / (all[p].scale * all[q].scale));
      }
      rows.push_back(row);
    }
    json cov = {{"parameters", NamesOf(all, n, false)}, {"units", NamesOf(all, n, true)}, {"matrix", rows}};
    if (std::isfinite(cal.covariance_type_a_dof)) cov["type_a_dof"] = cal.covariance_type_a_dof;
    json inputs = json::array();
    for (const CalibrationFile::CovarianceInput& in : cal.covariance_inputs) {
      if (in.per_unit.size() != c.rows()) continue;
      json s = json::array();
      for (std::size_t p = 0; p < n; ++p) s.push_back(in.per_unit(static_cast<Eigen::Index>(p)) / all[p].scale);
      inputs.push_back({{"input", in.input}, {"unit", in.unit}, {"u", in.u}, {"sensitivity", s}});
    }
    if (!inputs.empty()) cov["inputs"] = inputs;
    j["covariance"] = cov;
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
  if (!cal.probe_drift_powers.empty()) j["probe_drift_powers"] = cal.probe_drift_powers;
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
  json j = internal::ParseJsonInput(in, path, "a calibration file", kMaxCalibrationFileBytes);
  if (!j.is_object() || !j.contains("format") || j["format"] != "sph-calibration") {
    throw Error(path + ": not an sph calibration file (field \"format\" must be \"sph-calibration\")");
  }
  const json& version = Field(j, "format_version", "", path);
  if (!version.is_number_integer() || version.get<int>() != kCalibrationFormatVersion) {
    throw Error(path + ": calibration format version " + JsonExcerpt(version) +
                " is not supported (this program reads " + std::to_string(kCalibrationFormatVersion) + ")");
  }
  CalibrationFile cal;
  cal.probe_offset_mm = Number(j, "probe_offset_mm", "", path);
  if (!(cal.probe_offset_mm > 0.0)) throw Error(path + ": probe_offset_mm must be positive");
  if (j.contains("sphere_radius_mm")) cal.sphere_radius_mm = Number(j, "sphere_radius_mm", "", path);
  if (j.contains("created_by") && j["created_by"].is_string()) cal.created_by = j["created_by"].get<std::string>();
  const json& geometry = Field(j, "geometry", "", path);
  if (!geometry.is_object()) throw Error(path + ": field 'geometry' must be an object");
  for (const auto& item : geometry.items()) {
    bool known = false;
    for (const ScmsParamInfo& p : kScmsParamInfo) known |= item.key() == p.name;
    if (!known) {
      throw Error(path + ": field " + internal::Quoted("geometry." + item.key()) +
                  " is unknown (the seven errors: alpha a beta b epsilon c d_prime)");
    }
  }
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
  ParseEffects(j, path, cal);
  if (j.contains("probe_drift_powers")) {
    const json& powers = j["probe_drift_powers"];
    bool valid = powers.is_array();
    for (std::size_t i = 0; valid && i < powers.size(); ++i) {
      valid = powers[i].is_number_integer() && powers[i].get<int>() >= 1 && powers[i].get<int>() <= 3 &&
              (i == 0 || powers[i].get<int>() > powers[i - 1].get<int>());
      if (valid) cal.probe_drift_powers.push_back(powers[i].get<int>());
    }
    if (!valid) {
      throw Error(path + ": field 'probe_drift_powers' must list ascending powers of tau from 1 to 3, got " +
                  (powers.is_array() && powers.size() <= 3 ? powers.dump() : JsonExcerpt(powers)));
    }
  }
  ParseSphereForm(j, path, cal);
  if (j.contains("covariance")) ParseCovariance(j["covariance"], path, cal);
  if (j.contains("source") && j["source"].is_object()) {
    for (const auto& [k, v] : j["source"].items())
      cal.source.emplace_back(k, v.is_string() ? v.get<std::string>() : v.dump());
  }
  return cal;
}

std::vector<std::string> CalibrationParameterNames(const CalibrationFile& file) {
  std::vector<std::string> names;
  for (const StoredParameter& p : StoredParameters(file)) names.push_back(p.name);
  return names;
}

Eigen::MatrixXd AppliedCovariance(const CalibrationFile& file) {
  const auto n = static_cast<Eigen::Index>(StoredParameters(file).size());
  if (file.parameter_covariance.rows() == n && file.parameter_covariance.cols() == n && n > kNumScmsParams) {
    return file.parameter_covariance;
  }
  if (file.covariance) return *file.covariance;
  return {};
}

Eigen::MatrixXd FormCovariance(const CalibrationFile& file, bool* correlated) {
  if (correlated != nullptr) *correlated = false;
  const auto k = static_cast<Eigen::Index>(file.form_terms.size());
  const Eigen::MatrixXd all = AppliedCovariance(file);
  if (k > 0 && all.rows() > kNumScmsParams && all.rows() >= k &&
      all.rows() == static_cast<Eigen::Index>(StoredParameters(file).size())) {
    if (correlated != nullptr) *correlated = true;
    return all.bottomRightCorner(k, k);
  }
  if (k == 0 || file.form_std_mm.size() != file.form_terms.size()) return {};
  Eigen::VectorXd variance(k);
  for (Eigen::Index i = 0; i < k; ++i) {
    const double u = file.form_std_mm[static_cast<std::size_t>(i)];
    variance(i) = u * u;
  }
  const Eigen::MatrixXd diagonal = variance.asDiagonal();
  return diagonal;
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
