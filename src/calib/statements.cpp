#include "sph/calib/statements.hpp"

#include <algorithm>
#include <cmath>

#include "sph/internal/format.hpp"
#include "sph/io/parameter_settings.hpp"
#include "sph/model/units.hpp"
#include "sph/stats/gum.hpp"

namespace sph {
namespace {

using internal::Format;

// The column of parameter `name` in `fit`'s analysis and its value (rad, mm); -1 when the fit's
// model does not have it.
int ColumnOf(const EffectFit& fit, const std::string& name, double* value) {
  for (int k = 0; k < kNumScmsParams; ++k) {
    if (name != kScmsParamInfo[static_cast<std::size_t>(k)].name) continue;
    *value = fit.calibration.geometry[static_cast<std::size_t>(k)];
    return k;
  }
  for (std::size_t t = 0; t < fit.model.terms.size(); ++t) {
    const EffectTerm& term = fit.model.terms[t];
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      if (term.ParamName(i) != name) continue;
      *value = fit.values[t][i];
      return fit.TermOffset(t) + static_cast<int>(i);
    }
  }
  return -1;
}

// "alpha_deg=0.02022,0.00019": a value (rad or mm) and its standard uncertainty as a prior writes
// them (the seven errors in deg or mm, the effects in arcsec or um), the value to the second
// significant digit of u.
std::string ValueText(const std::string& name, double value, double u) {
  const bool error = name.find('.') == std::string::npos;
  const bool angle = ParameterQuantity(name) == Quantity::kAngle;
  const char* unit = angle ? (error ? "deg" : "arcsec") : (error ? "mm" : "um");
  const double scale = angle ? (error ? 1.0 / kRadPerDeg : 1.0 / kRadPerArcsec) : (error ? 1.0 : kUmPerMm);
  const double v = value * scale, uu = u * scale;
  const int decimals = uu > 0.0 ? std::clamp(1 - static_cast<int>(std::floor(std::log10(uu))), 0, 15) : 6;
  return name + "_" + unit + "=" + Format("%.*f", decimals, v) + "," + Format("%.2g", uu);
}

// One prior (`prior` set) or held value of `options`, tested as the file comment of
// CheckParameterStatements() says.
StatementCheck CheckOne(const PointsData& kept, const CalibrationOptions& options, const EffectFit& fit,
                        const std::string& name, const std::optional<ParameterPrior>& prior,
                        const std::optional<double>& held, const std::string& origin) {
  StatementCheck s;
  s.kind = prior ? StatementKind::kPrior : StatementKind::kFixed;
  s.parameter = name;
  const bool from_option = origin.rfind("--", 0) == 0;
  const std::string text = prior ? ParameterPriorText(*prior) : FixedParameterText({name, held});
  s.statement = from_option ? origin + " " + text : std::string(prior ? "prior " : "fix ") + text + " (" + origin + ")";
  double stated = 0.0;
  if (prior) {
    stated = prior->value;
    s.stated = text;
  }
  CalibrationOptions without = options;
  if (prior) {
    without.priors.erase(std::remove_if(without.priors.begin(), without.priors.end(),
                                        [&](const ParameterPrior& p) { return p.name == name; }),
                         without.priors.end());
  } else {
    without.fixed.erase(std::remove_if(without.fixed.begin(), without.fixed.end(),
                                       [&](const FixedParameter& f) { return f.name == name; }),
                        without.fixed.end());
  }
  without.analyse = true;
  without.prior_sigma_mm = 0.0;
  double fitted = 0.0;
  if (ColumnOf(fit, name, &fitted) < 0) {
    s.verdict = "not tested: the calibration's model has no parameter " + name;
    return s;
  }
  if (!prior) {
    stated = held ? *held : fitted;  // held where the fit started: where it is
    s.stated = FixedParameterText({name, stated}) + " (held)";
  }
  const EffectFit free = FitEffects(kept, without, fit.model, EffectFitStart::From(fit));
  double estimate = 0.0;
  const int column = ColumnOf(free, name, &estimate);
  const ObservabilityReport& a = free.calibration.analysis;
  const double u_x = a.Empty() ? std::nan("") : a.std(column);
  if (!free.calibration.converged || a.Empty() || !a.determined[static_cast<std::size_t>(column)] ||
      !std::isfinite(u_x)) {
    s.readings = "not determined";
    s.verdict = "not tested: without it the readings do not determine " + name;
    return s;
  }
  const double u = prior ? prior->u : 0.0;
  s.readings = ValueText(name, estimate, u_x);
  s.dof = 1;
  s.chi_square = (estimate - stated) * (estimate - stated) / (u_x * u_x + u * u);
  s.p_value = gum::ChiSquareSf(s.chi_square, 1.0);
  s.rejected = s.p_value < kStatementP;
  s.verdict = Format(
      "the readings %s %s: without it they give %s, stated %s; chi-square %.3g for 1 degree of "
      "freedom, p %s",
      s.rejected ? "reject" : "agree with", s.statement.c_str(), s.readings.c_str(), s.stated.c_str(), s.chi_square,
      PValueText(s.p_value).c_str());
  return s;
}

}  // namespace

std::string PValueText(double p) { return p > 0.0 ? Format("= %.2g", p) : std::string("< 1e-300"); }

const char* StatementKindId(StatementKind kind) {
  switch (kind) {
    case StatementKind::kPrior:
      return "prior";
    case StatementKind::kFixed:
      return "fixed";
    case StatementKind::kKnownForm:
      return "known_form";
    case StatementKind::kOtherForm:
      return "other_sphere_form";
    case StatementKind::kFormBound:
      return "form_bound";
    case StatementKind::kEarlierModel:
      return "earlier_model";
  }
  return "";
}

std::vector<StatementCheck> CheckParameterStatements(const PointsData& points, const CalibrationOptions& options,
                                                     const EffectFit& fit,
                                                     const std::map<std::string, std::string>& origin) {
  std::vector<StatementCheck> out;
  if (options.priors.empty() && options.fixed.empty()) return out;
  const PointsData kept = WithoutOutliers(points, fit.calibration);
  const auto from = [&](const std::string& name) {
    const auto it = origin.find(name);
    return it == origin.end() ? std::string("the options") : it->second;
  };
  for (const ParameterPrior& p : options.priors) {
    out.push_back(CheckOne(kept, options, fit, p.name, p, std::nullopt, from(p.name)));
  }
  for (const FixedParameter& f : options.fixed) {
    out.push_back(CheckOne(kept, options, fit, f.name, std::nullopt, f.value, from(f.name)));
  }
  return out;
}

bool AnyRejected(const std::vector<StatementCheck>& statements) {
  return std::any_of(statements.begin(), statements.end(),
                     [](const StatementCheck& s) { return s.rejected && !s.accepted; });
}

}  // namespace sph
