#include "sph/io/parameter_settings.hpp"

#include <array>
#include <cmath>

#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/core/valid_range.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/effect_terms.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using internal::Quoted;

struct UnitOf {
  const char* suffix;
  Quantity quantity;
  double to_internal;  // internal units (rad, mm) per unit
};
constexpr std::array<UnitOf, 5> kUnits{{{"deg", Quantity::kAngle, kRadPerDeg},
                                        {"arcsec", Quantity::kAngle, kRadPerArcsec},
                                        {"urad", Quantity::kAngle, 1.0 / kUradPerRad},
                                        {"mm", Quantity::kLength, 1.0},
                                        {"um", Quantity::kLength, kMmPerUm}}};

const char* kNames =
    "one of the seven errors (alpha, a, beta, b, epsilon, c, d_prime) or an effect's parameter (e.g. "
    "theta_encoder.c2, probe_drift.t1)";

// The largest magnitude of parameter `name`'s values (internal units): a seven error's
// kScmsParamInfo bound (its report unit deg or mm), an effect's kMaxEffectArcsec or kMaxEffectUm.
double MaxAbsInternal(const std::string& name) {
  for (const ScmsParamInfo& info : kScmsParamInfo) {
    if (name == info.name) return info.max_abs_report * (info.quantity == Quantity::kAngle ? kRadPerDeg : 1.0);
  }
  return ParameterQuantity(name) == Quantity::kAngle ? kMaxEffectArcsec * kRadPerArcsec : kMaxEffectUm * kMmPerUm;
}

// The smallest standard uncertainty a prior may state (internal units): 1e-12 rad (2e-5 nm at a
// 20 mm lever) or 1e-9 mm (1e-3 nm), far below what any reading resolves; smaller, the prior's
// weight against the readings overflows the fit's sums, and a value known that well is held (fix).
double MinPriorUInternal(const std::string& name) { return ParameterQuantity(name) == Quantity::kAngle ? 1e-12 : 1e-9; }

// The parameter and unit of "NAME_UNIT"; the unit's factor into internal units; `unit_out` gets the
// unit.
std::string NameAndUnit(const std::string& key, const std::string& what, double* to_internal,
                        const char** unit_out = nullptr) {
  for (const UnitOf& u : kUnits) {
    const std::string suffix = std::string("_") + u.suffix;
    if (key.size() <= suffix.size() || key.compare(key.size() - suffix.size(), suffix.size(), suffix) != 0) continue;
    const std::string name = key.substr(0, key.size() - suffix.size());
    const std::optional<Quantity> q = ParameterQuantity(name);
    if (!q) throw Error(what + ": unknown parameter " + Quoted(name) + "; a parameter is " + kNames);
    if (*q != u.quantity) {
      throw Error(
          what + ": " + name + " is " +
          (*q == Quantity::kAngle ? "an angle: give it in deg, arcsec or urad (" : "a length: give it in mm or um (") +
          name + (*q == Quantity::kAngle ? "_deg=...)" : "_mm=...)"));
    }
    *to_internal = u.to_internal;
    if (unit_out != nullptr) *unit_out = u.suffix;
    return name;
  }
  const std::optional<Quantity> q = ParameterQuantity(key);
  if (!q) throw Error(what + ": unknown parameter " + Quoted(key) + "; a parameter is " + kNames);
  throw Error(what + ": the value of " + key + " needs its unit in the name: " + key +
              (*q == Quantity::kAngle ? "_deg, _arcsec or _urad" : "_mm or _um") + " (e.g. " + key +
              (*q == Quantity::kAngle ? "_deg" : "_mm") + "=...)");
}

// The unit an entry writes a parameter's value in: as the reports give it.
const UnitOf& WrittenUnit(const std::string& name) {
  const bool error = name.find('.') == std::string::npos;  // one of the seven errors
  const bool angle = ParameterQuantity(name) == Quantity::kAngle;
  return kUnits[angle ? (error ? 0 : 1) : (error ? 3 : 4)];
}

std::vector<std::string> Entries(const std::string& value) {
  std::vector<std::string> out;
  std::string word;
  for (const char c : value + " ") {
    if (c == ' ' || c == '\t') {
      if (!word.empty()) out.push_back(word);
      word.clear();
    } else {
      word += c;
    }
  }
  return out;
}

// A parameter named twice in one list of `what`.
template <typename Entry>
void RefuseTwice(const std::vector<Entry>& entries, const std::string& what, const char* twice) {
  for (std::size_t i = 0; i < entries.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (entries[i].name == entries[j].name) throw Error(what + ": " + entries[i].name + " " + twice);
    }
  }
}

}  // namespace

std::optional<Quantity> ParameterQuantity(const std::string& name) {
  for (const ScmsParamInfo& info : kScmsParamInfo) {
    if (name == info.name) return info.quantity;
  }
  const auto dot = name.find('.');
  Effect e;
  EffectComponent c;
  if (dot == std::string::npos || !EffectFromId(name.substr(0, dot), &e) || !FindComponent(e, name, &c)) {
    return std::nullopt;
  }
  return InfoOf(e).quantity;
}

FixedParameter ParseFixedParameter(const std::string& text, const std::string& what) {
  FixedParameter f;
  const auto eq = text.find('=');
  if (eq == std::string::npos) {
    if (!ParameterQuantity(text))
      throw Error(what + ": unknown parameter " + Quoted(text) + "; a parameter is " + kNames);
    f.name = text;
    return f;
  }
  double to_internal = 1.0;
  const char* unit = "";
  f.name = NameAndUnit(text.substr(0, eq), what, &to_internal, &unit);
  const std::string value = text.substr(eq + 1);
  const double max = MaxAbsInternal(f.name) / to_internal;
  f.value =
      CheckedValue(ParseNumber(value, f.name, what + ": "), ValidRange{-max, max, unit}, what + ": " + f.name, value) *
      to_internal;
  return f;
}

ParameterPrior ParseParameterPrior(const std::string& text, const std::string& what) {
  const auto eq = text.find('=');
  const auto comma = text.find(',', eq == std::string::npos ? 0 : eq);
  if (eq == std::string::npos || comma == std::string::npos) {
    throw Error(what +
                ": expected NAME_UNIT=VALUE,U (a value and its standard uncertainty, e.g. alpha_deg=0.02,0.0005)");
  }
  ParameterPrior p;
  double to_internal = 1.0;
  const char* unit = "";
  p.name = NameAndUnit(text.substr(0, eq), what, &to_internal, &unit);
  const std::string value = text.substr(eq + 1, comma - eq - 1);
  const double max = MaxAbsInternal(p.name) / to_internal;
  p.value =
      CheckedValue(ParseNumber(value, p.name, what + ": "), ValidRange{-max, max, unit}, what + ": " + p.name, value) *
      to_internal;
  const std::string u = text.substr(comma + 1);
  // As every number, in the range its parameter's values have: from what a reading resolves to
  // the parameter's largest magnitude.
  p.u = CheckedValue(ParseNumber(u, p.name + " standard uncertainty", what + ": "),
                     ValidRange{MinPriorUInternal(p.name) / to_internal, max, unit},
                     what + ": the standard uncertainty of " + p.name, u) *
        to_internal;
  return p;
}

std::vector<FixedParameter> ParseFixedParameters(const std::string& value, const std::string& what) {
  std::vector<FixedParameter> out;
  for (const std::string& entry : Entries(value)) out.push_back(ParseFixedParameter(entry, what));
  if (out.empty()) throw Error(what + ": names no parameter");
  RefuseTwice(out, what, "is held twice");
  return out;
}

std::vector<ParameterPrior> ParseParameterPriors(const std::string& value, const std::string& what) {
  std::vector<ParameterPrior> out;
  for (const std::string& entry : Entries(value)) out.push_back(ParseParameterPrior(entry, what));
  if (out.empty()) throw Error(what + ": names no parameter");
  RefuseTwice(out, what, "has two priors");
  return out;
}

std::string FixedParameterText(const FixedParameter& f) {
  if (!f.value) return f.name;
  const UnitOf& u = WrittenUnit(f.name);
  return f.name + "_" + u.suffix + "=" + internal::Format("%.10g", *f.value / u.to_internal);
}

std::string ParameterPriorText(const ParameterPrior& p) {
  const UnitOf& u = WrittenUnit(p.name);
  return p.name + "_" + u.suffix + "=" + internal::Format("%.10g", p.value / u.to_internal) + "," +
         internal::Format("%.10g", p.u / u.to_internal);
}

}  // namespace sph
