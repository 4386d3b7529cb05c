#include "sph/calib/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "sph/calib/known_form.hpp"
#include "sph/calib/statements.hpp"
#include "sph/calib/usability.hpp"
#include "sph/internal/format.hpp"
#include "sph/internal/header_json.hpp"
#include "sph/io/points_file.hpp"
#include "sph/model/units.hpp"
#include "sph/select/trace_report.hpp"
#include "sph/stats/rounding.hpp"
#include "trace_json.hpp"

namespace sph {
namespace {

using gum::BudgetInput;
using gum::EvaluationType;
using gum::UncertaintyStatement;
using internal::Format;
using nlohmann::json;

// The known form's section of the text report.
void WriteKnownFormText(std::ostream& out, const KnownFormCheck& k) {
  std::string sphere;
  for (const int setup : k.setups)
    sphere += (sphere.empty() ? " of the sphere of setups " : ",") + std::to_string(setup);
  out << "\nknown sphere form" << sphere << " (" << k.source << "), " << k.terms << " coefficients as a prior:\n";
  out << Format("  known %.4g um RMS over the sphere, fitted %.4g um RMS\n", k.known_rms_um, k.fitted_rms_um);
  out << Format("  explains %.4g um RMS of the readings (residual RMS %.4g um with it, %.4g um without a form)\n",
                k.explained_rms_um, k.rms_with_um, k.rms_without_um);
  out << Format("  prior's chi-square %.4g for %d coefficients, p = %.3g\n", k.chi_square, k.terms, k.p_value);
  if (k.bound_rms_um) out << Format("  certificate's bound %.4g um RMS (k = 1)\n", *k.bound_rms_um);
  out << Format("  prior against the readings: chi-square %.4g for %d directions they determine, p = %.3g%s\n",
                k.conflict_chi_square, k.conflict_dof, k.conflict_p_value,
                k.exceeds_bound ? ": the sphere's form exceeds its certificate's bound" : "");
  out << "  verdict: " << (k.agrees ? "agrees" : "DISAGREES") << ": " << k.verdict << "\n";
}

json KnownFormJson(const KnownFormCheck& k) {
  return {{"source", k.source},
          {"terms", k.terms},
          {"known_rms_um", k.known_rms_um},
          {"fitted_rms_um", k.fitted_rms_um},
          {"explained_rms_um", k.explained_rms_um},
          {"rms_with_um", k.rms_with_um},
          {"rms_without_um", k.rms_without_um},
          {"chi_square", k.chi_square},
          {"p_value", k.p_value},
          {"bound_rms_um", k.bound_rms_um ? json(*k.bound_rms_um) : json(nullptr)},
          {"conflict_chi_square", k.conflict_chi_square},
          {"conflict_degrees_of_freedom", k.conflict_dof},
          {"conflict_p_value", k.conflict_p_value},
          {"difference_rms_um", k.difference_rms_um},
          {"difference_expected_um", k.difference_expected_um},
          {"exceeds_bound", k.exceeds_bound},
          {"agrees", k.agrees},
          {"verdict", k.verdict},
          {"warnings", k.warnings}};
}

// The statements of the lab and their tests, in the text report.
void WriteStatementsText(std::ostream& out, const ReportContext& ctx) {
  if (ctx.statements == nullptr || ctx.statements->empty()) return;
  out << "\nstatements of the lab, tested against the readings (each rejected when p < " << Format("%g", kStatementP)
      << "):\n";
  for (const StatementCheck& s : *ctx.statements) {
    const char* verdict = s.dof == 0    ? "not tested"
                          : !s.rejected ? "agrees"
                          : s.accepted  ? "REJECTED, accepted"
                                        : "REJECTED";
    out << "  " << verdict << ": " << s.statement << "\n";
    out << "    stated: " << s.stated << "\n";
    out << "    the readings without it: " << s.readings << "\n";
    if (s.dof > 0) {
      out << Format("    chi-square %.4g for %d degree%s of freedom, p %s\n", s.chi_square, s.dof,
                    s.dof == 1 ? "" : "s", PValueText(s.p_value).c_str());
    }
    if (s.orientation) out << "    " << s.orientation->text << "\n";
  }
  if (ctx.withheld != nullptr && !ctx.withheld->empty()) {
    std::string ids;
    for (const Effect e : *ctx.withheld) ids += (ids.empty() ? "" : ", ") + std::string(InfoOf(e).id);
    out << "  the trace adds nothing on top of a rejected statement: " << ids << " not applied\n";
  }
}

json StatementsJson(const ReportContext& ctx) {
  json tests = json::array();
  for (const StatementCheck& s : *ctx.statements) {
    json t = {{"kind", StatementKindId(s.kind)},
              {"statement", s.statement},
              {"parameter", s.parameter.empty() ? json(nullptr) : json(s.parameter)},
              {"stated", s.stated},
              {"readings", s.readings},
              {"chi_square", s.chi_square},
              {"degrees_of_freedom", s.dof},
              {"p_value", s.p_value},
              {"rejected", s.rejected},
              {"accepted", s.accepted},
              {"verdict", s.verdict}};
    if (s.orientation) {
      const SupportedOrientation& o = *s.orientation;
      const auto vec = [](const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); };
      t["supported_orientation"] = {{"setup", o.setup},
                                    {"stated_deg", vec(o.stated_deg)},
                                    {"right_angle_deg", vec(o.right_angle_deg)},
                                    {"fitted_deg", vec(o.fitted_deg)},
                                    {"u_deg", std::isfinite(o.u_deg) ? json(o.u_deg) : json(nullptr)},
                                    {"offset_deg", o.offset_deg},
                                    {"p_value", o.p_value},
                                    {"agrees", o.agrees},
                                    {"text", o.text}};
    }
    tests.push_back(std::move(t));
  }
  json withheld = json::array();
  if (ctx.withheld != nullptr) {
    for (const Effect e : *ctx.withheld) withheld.push_back(InfoOf(e).id);
  }
  return {{"p_level", kStatementP}, {"tests", tests}, {"withheld_effects", withheld}};
}

// The fit's warnings, then the run's that are not among them.
std::vector<std::string> AllWarnings(const CalibrationResult& r, const ReportContext& ctx) {
  std::vector<std::string> all = r.warnings;
  if (ctx.run_warnings == nullptr) return all;
  for (const std::string& w : *ctx.run_warnings) {
    if (std::find(all.begin(), all.end(), w) == all.end()) all.push_back(w);
  }
  return all;
}

double ParamValue(const CalibrationResult& r, std::size_t i) {
  if (i < kNumScmsParams) return r.geometry[i];
  const std::size_t k = (i - kNumScmsParams) / 3;
  return r.centers_mm[k](static_cast<Eigen::Index>((i - kNumScmsParams) % 3));
}

// How parameter i was held, in words ("fixed", "at bound"), or empty when fitted.
std::string HeldText(const ObservabilityReport& rep, std::size_t i) {
  if (!rep.IsHeld(static_cast<int>(i))) return "";
  return rep.held[i] == Held::kFixed ? "fixed" : "at bound";
}

// Parameter i of the results' table as GUM 7.2.6 states it: U (u when there is no budget) to two
// significant digits and the value to the same decimal place, angles in urad and lengths in um, a
// centre's value in mm beside its uncertainty in um; a held parameter's value in full.
std::string ResultRowText(const CalibrationResult& r, const ReportContext& ctx, std::size_t i,
                          const std::string& name) {
  const ObservabilityReport& rep = r.analysis;
  const bool centre = i >= kNumScmsParams;
  const ReportUnits units = ReportUnitsOf(centre ? Quantity::kLength : kScmsParamInfo[i].quantity);
  const double to_value = centre ? 1.0 : units.to_fine;
  const char* value_unit = centre ? "mm" : units.fine;
  const double value = ParamValue(r, i);
  const std::string held = rep.Empty() ? "" : HeldText(rep, i);
  if (!held.empty()) {
    return Format("%-12s %14s %-4s %9s %9s %5s %-4s", name.c_str(),
                  gum::RoundResult(value * to_value, 0.0).value_text.c_str(), value_unit, held.c_str(), "", "", "");
  }
  const gum::UncertaintyStatement* st =
      ctx.budget != nullptr && i < ctx.budget->statements.size() && !ctx.budget->statements[i].inputs.empty()
          ? &ctx.budget->statements[i]
          : nullptr;
  const double u = st != nullptr ? st->u : rep.Empty() ? std::nan("") : rep.std(static_cast<Eigen::Index>(i));
  // The value rounded where its U (or u) is, in the value's unit; the uncertainties in urad or um.
  const gum::RoundedResult stated = gum::RoundResult(value * to_value, (st != nullptr ? st->U : u) * to_value);
  return Format("%-12s %14s %-4s %9s %9s %5s %-4s", name.c_str(), stated.value_text.c_str(), value_unit,
                gum::SignificantText(u * units.to_fine).c_str(),
                st != nullptr ? gum::SignificantText(st->U * units.to_fine).c_str() : "-",
                st != nullptr ? Format("%.2f", st->k).c_str() : "-", units.fine);
}

std::string WeakText(const ObservabilityReport& rep, const WeakCombination& w) {
  std::string s;
  for (const auto& [j, c] : w.terms) {
    const ParameterDescription& p = rep.parameters[static_cast<std::size_t>(j)];
    s += (s.empty() ? "" : ", ") + p.name + (p.quantity == Quantity::kAngle ? "*R0" : "") + " " + Format("%+.2f", c);
  }
  return s;
}

// Where a Type B input that is not stated would be given: the key in its note's last parentheses
// ("not stated: R0 taken as exact (sphere_radius_u_um)").
std::string StatedBy(const std::string& note) {
  const std::size_t close = note.rfind(')'), open = note.rfind('(', close);
  if (close == std::string::npos || open == std::string::npos) return "";
  return note.substr(open + 1, close - open - 1);
}

// The seven errors' budgets: each stated input's contribution |c_i| u(x_i), u, nu_eff, k and U,
// in urad or um, two significant digits; the inputs not stated (u = 0) in one line; then what
// each stated input is and where its value comes from.
void WriteBudgetText(std::ostream& out, const CalibrationResult& r, const CalibrationBudget& b) {
  std::vector<std::size_t> stated;
  std::string not_stated;
  for (std::size_t c = 0; c < b.inputs.size(); ++c) {
    if (b.inputs[c].u > 0.0) {
      stated.push_back(c);
    } else {
      const std::string key = StatedBy(b.inputs[c].note);
      not_stated += (not_stated.empty() ? "" : ", ") + b.inputs[c].input + (key.empty() ? "" : " (" + key + ")");
    }
  }
  out << "uncertainty (GUM): contributions |c_i| u(x_i), combined u, effective degrees of freedom, U = k u\n";
  out << Format("%-12s %9s", "parameter", "fit (A)");
  for (const std::size_t c : stated) out << Format(" %11s", b.inputs[c].column.c_str());
  out << Format(" %9s %8s %5s %9s %-4s\n", "u", "nu_eff", "k", "U", "unit");
  for (std::size_t i = 0; i < kNumScmsParams && i < b.statements.size(); ++i) {
    const UncertaintyStatement& st = b.statements[i];
    const ReportUnits u = ReportUnitsOf(kScmsParamInfo[i].quantity);
    const std::string name = r.analysis.Empty() ? kScmsParamInfo[i].name : r.analysis.parameters[i].name;
    const std::string held = r.analysis.Empty() ? "" : HeldText(r.analysis, i);
    if (!held.empty() || st.inputs.empty()) {
      out << Format("%-12s %9s\n", name.c_str(), held.empty() ? "undetermined" : held.c_str());
      continue;
    }
    // The statement's inputs: the fit's first, then the Type B inputs in the budget's order.
    out << Format("%-12s %9s", name.c_str(), gum::SignificantText(st.inputs[0].Contribution() * u.to_fine).c_str());
    for (const std::size_t c : stated) {
      const double contribution = c + 1 < st.inputs.size() ? st.inputs[c + 1].Contribution() : 0.0;
      out << Format(" %11s", gum::SignificantText(contribution * u.to_fine).c_str());
    }
    const std::string dof = !std::isfinite(st.dof) ? "inf" : st.dof > 1e6 ? ">1e6" : Format("%.0f", st.dof);
    out << Format(" %9s %8s %5.2f %9s %-4s\n", gum::SignificantText(st.u * u.to_fine).c_str(), dof.c_str(), st.k,
                  gum::SignificantText(st.U * u.to_fine).c_str(), u.fine);
  }
  out << "  fit (A): the fit's covariance, " << Format("%.0f", b.type_a_dof) << " degrees of freedom\n";
  for (const std::size_t c : stated) {
    const BudgetSensitivity& s = b.inputs[c];
    out << "  " << s.input << ": u = " << Format("%.6g", s.u) << " " << s.unit << " (" << s.note << ")\n";
  }
  if (!not_stated.empty()) out << "  not stated, taken as exact: " << not_stated << "\n";
  out << gum::CoverageSentence(b.coverage, "parameter") << "\n\n";
}

json BudgetJson(const UncertaintyStatement& st, double to_report, const char* report_unit) {
  json j;
  j["u"] = st.u * to_report;
  j["U"] = st.U * to_report;
  j["k"] = st.k;
  j["dof"] = std::isfinite(st.dof) ? json(st.dof) : json(nullptr);
  j["coverage_probability"] = st.coverage_probability;
  json items = json::array();
  for (const BudgetInput& in : st.inputs) {
    items.push_back(
        {{"input", in.name},
         {"type", in.type == EvaluationType::kA ? "A" : "B"},
         // The Type A input is the parameter's own scatter, in its unit.
         {"u_input", in.type == EvaluationType::kA ? in.standard_uncertainty * to_report : in.standard_uncertainty},
         {"input_unit", in.type == EvaluationType::kA ? std::string(report_unit) : in.unit},
         {"sensitivity", in.type == EvaluationType::kA ? in.sensitivity : in.sensitivity * to_report},
         {"u_contribution", in.Contribution() * to_report}});
  }
  j["budget"] = items;
  return j;
}

const char* FoundText(ComparedParameter::Found f) {
  return f == ComparedParameter::Found::kBoth ? "both" : f == ComparedParameter::Found::kNowOnly ? "now" : "previous";
}

// The comparison with an earlier calibration: a row per parameter (the verdict's, then today's own
// model's when the two models differ), how the inputs were counted, the models, the verdict.
void WriteComparisonText(std::ostream& out, const CalibrationComparison& cmp) {
  out << "\ncomparison with " << cmp.previous_source
      << " (difference = now - previous, U of the difference with k = " << Format("%g", cmp.k)
      << ", En = difference / U):\n";
  auto number = [](double v, const char* format) { return std::isfinite(v) ? Format(format, v) : std::string("-"); };
  auto table = [&](const std::vector<ComparedParameter>& rows) {
    out << Format("%-26s %13s %13s %12s %10s %7s %s\n", "parameter", "previous", "now", "difference", "U", "En",
                  "unit");
    for (const ComparedParameter& c : rows) {
      // GUM 7.2.6: the difference's U to two significant digits, the values to the same place.
      const auto at_u = [&](double v) {
        return std::isfinite(v) ? gum::RoundResult(v, std::isfinite(c.U) ? c.U : std::nan("")).value_text
                                : std::string("-");
      };
      std::string previous = at_u(c.previous), now = at_u(c.now), difference = at_u(c.difference);
      if (std::isfinite(c.difference) && c.difference >= 0.0) difference = "+" + difference;
      if (c.found == ComparedParameter::Found::kNowOnly) previous = "(now only)";
      if (c.found == ComparedParameter::Found::kPreviousOnly) now = "(previous only)";
      out << Format("%-26s %13s %13s %12s %10s %7s %s\n", c.parameter.c_str(), previous.c_str(), now.c_str(),
                    difference.c_str(), std::isfinite(c.U) ? gum::SignificantText(c.U).c_str() : "-",
                    number(c.En, "%+.2f").c_str(), c.unit.c_str());
      if (!c.note.empty()) out << "  " << c.parameter << ": " << c.note << "\n";
    }
  };
  if (cmp.model == kPreviousModel) out << "today's readings refitted with the earlier calibration's model:\n";
  table(cmp.parameters);
  if (!cmp.todays_model.empty()) {
    out << "today's own model, for information:\n";
    table(cmp.todays_model);
  }
  out << "  counted fully correlated (the same source in both, cancelling where it acts alike): "
      << (cmp.correlated_inputs.empty() ? std::string("none") : "");
  for (std::size_t i = 0; i < cmp.correlated_inputs.size(); ++i) out << (i ? ", " : "") << cmp.correlated_inputs[i];
  out << "\n";
  for (const std::string& note : cmp.notes) out << "  " << note << "\n";
  if (!cmp.models.empty()) out << "models: " << cmp.models << "\n";
  out << "verdict: " << cmp.verdict << "\n";
}

json NumberOrNull(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

void AddComparisonJson(json& j, const CalibrationComparison& cmp) {
  json rows = json::array();
  for (const auto* list : {&cmp.parameters, &cmp.todays_model}) {
    for (const ComparedParameter& c : *list) {
      json row = {{"parameter", c.parameter},       {"unit", c.unit},
                  {"model", c.model},               {"found_in", FoundText(c.found)},
                  {"previous", NumberOrNull(c.previous)}, {"now", NumberOrNull(c.now)},
                  {"difference", NumberOrNull(c.difference)}, {"U", NumberOrNull(c.U)},
                  {"En", NumberOrNull(c.En)}};
      if (!c.note.empty()) row["note"] = c.note;
      rows.push_back(row);
    }
  }
  j["comparison"] = rows;
  j["comparison_summary"] = {{"previous_file", cmp.previous_source},
                             {"k", cmp.k},
                             {"model", cmp.model},
                             {"models", cmp.models},
                             {"unchanged", cmp.Unchanged()},
                             {"verdict", cmp.verdict},
                             {"correlated_inputs", cmp.correlated_inputs},
                             {"notes", cmp.notes}};
}

}  // namespace

void WriteTextReport(std::ostream& out, const CalibrationResult& r, const ReportContext& ctx) {
  const ObservabilityReport& rep = r.analysis;
  out << ctx.program << ": " << ctx.points_path << "\n";
  out << "  " << r.n_points << " points, " << r.setup_ids.size() << (r.setup_ids.size() == 1 ? " setup" : " setups")
      << ", R0 = " << Format("%.6g", ctx.sphere_radius_mm) << " mm";
  for (const auto& [setup, radius_mm] : ctx.sphere_radii_mm) {
    out << " (setup " << setup << ": another sphere, R = " << Format("%.6g", radius_mm) << " mm)";
  }
  out << ", d = " << Format("%.6g", ctx.probe_offset_mm) << " mm\n";
  for (const auto& [k, v] : ctx.metadata) out << "  " << k << ": " << v << "\n";
  out << "\n";
  const bool budget = ctx.budget != nullptr;
  out << (budget ? "results (GUM 7.2.6: U to two significant digits, the value to the same place; the JSON report and "
                   "the calibration file hold every digit):\n"
                 : "results (GUM 7.2.6: u to two significant digits, the value to the same place; the JSON report and "
                   "the calibration file hold every digit):\n");
  out << Format("%-12s %14s %-4s %9s %9s %5s %-4s\n", "parameter", "value", "unit", "u", "U", "k", "unit");
  const std::size_t n = kNumScmsParams + 3 * r.centers_mm.size();
  for (std::size_t i = 0; i < n; ++i) {
    const bool analysed = !rep.Empty();
    const std::string name =
        analysed ? rep.parameters[i].name : (i < kNumScmsParams ? kScmsParamInfo[i].name : "center");
    if (analysed && !rep.determined[i]) {
      const double disp = rep.StdAsDisplacementUm(static_cast<int>(i));
      out << Format("%-12s %14s  (std %s um as a displacement: not determined by these data)\n", name.c_str(),
                    "undetermined", std::isfinite(disp) ? Format("%.3g", disp).c_str() : "infinite");
      continue;
    }
    out << ResultRowText(r, ctx, i, name) << "\n";
  }
  out << "\n";
  if (ctx.budget != nullptr) WriteBudgetText(out, r, *ctx.budget);
  out << "fit: rms " << Format("%.4f", r.rms_um) << " um, peak-to-valley " << Format("%.4f", r.pv_um) << " um, "
      << r.n_points << " points, " << r.iterations << " iterations, " << (r.converged ? "converged" : "NOT converged")
      << "\n";
  if (!rep.Empty()) {
    out << "residual sigma " << Format("%.4f", rep.residual_sigma_mm * kUmPerMm)
        << " um; condition number of the column-equilibrated Jacobian " << Format("%.3g", rep.condition_number) << "\n";
    for (const WeakCombination& w : rep.weak) {
      out << "nearly dependent (relative singular value " << Format("%.2g", w.relative_singular_value)
          << "): " << WeakText(rep, w) << "\n";
    }
    out << "\ncorrelation matrix:\n";
    out << Format("%-12s", "");
    for (std::size_t j = 0; j < n; ++j) {
      out << Format(" %6.6s", rep.parameters[j].name.c_str());
    }
    out << "\n";
    for (std::size_t i = 0; i < n; ++i) {
      out << Format("%-12s", rep.parameters[i].name.c_str());
      for (std::size_t j = 0; j < n; ++j) {
        const double c = rep.correlation(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
        out << (std::isfinite(c) ? Format(" %6.3f", c) : Format(" %6s", "-"));
      }
      out << "\n";
    }
  }
  const std::vector<std::string> warnings = AllWarnings(r, ctx);
  if (!warnings.empty()) {
    out << "\nwarnings:\n";
    for (const auto& w : warnings) out << "  - " << w << "\n";
  }
  const Usability usability = JudgeUsability(r, ctx);
  out << "\nresult: " << (usability.usable ? "usable calibration" : "NOT a usable calibration") << "\n";
  out << "  judged against " << usability.requirement << "\n";
  for (const std::string& why : usability.reasons) out << "  why: " << why << "\n";
  WriteStatementsText(out, ctx);
  if (ctx.known_form != nullptr) WriteKnownFormText(out, *ctx.known_form);
  if (ctx.other_known_forms != nullptr) {
    for (const KnownFormCheck& k : *ctx.other_known_forms) WriteKnownFormText(out, k);
  }
  if (ctx.trace != nullptr) WriteTraceText(out, *ctx.trace, ctx.validation);
  if (ctx.comparison != nullptr) WriteComparisonText(out, *ctx.comparison);
}

std::string JsonReport(const CalibrationResult& r, const ReportContext& ctx) {
  const ObservabilityReport& rep = r.analysis;
  json j;
  j["program"] = ctx.program;
  j["points_file"] = ctx.points_path;
  j["sphere_radius_mm"] = ctx.sphere_radius_mm;
  if (!ctx.sphere_radii_mm.empty()) {
    json radii = json::object();
    for (const auto& [setup, radius_mm] : ctx.sphere_radii_mm) radii[std::to_string(setup)] = radius_mm;
    j["sphere_radii_mm"] = radii;
  }
  j["probe_offset_mm"] = ctx.probe_offset_mm;
  j["metadata"] = internal::MetadataJson(ctx.metadata);
  j["devices"] = internal::DevicesJson(ctx.metadata);
  json params = json::object();
  json order = json::array();
  json undetermined = json::array();
  const std::size_t n = kNumScmsParams + 3 * r.centers_mm.size();
  for (std::size_t i = 0; i < n; ++i) {
    const std::string name =
        rep.Empty() ? std::string(i < kNumScmsParams ? kScmsParamInfo[i].name : "center") : rep.parameters[i].name;
    const Quantity q = i < kNumScmsParams ? kScmsParamInfo[i].quantity : Quantity::kLength;
    const ReportUnits u = ReportUnitsOf(q);
    json p;
    p["value"] = ParamValue(r, i) * u.to_coarse;
    p["unit"] = u.coarse;
    if (i < kNumScmsParams) p["iso_name"] = kScmsParamInfo[i].iso_name;
    if (!rep.Empty()) {
      const double sd = rep.std(static_cast<Eigen::Index>(i));
      p["std"] = std::isfinite(sd) ? json(sd * u.to_coarse) : json(nullptr);
      p["determined"] = static_cast<bool>(rep.determined[i]);
      if (rep.IsHeld(static_cast<int>(i))) {
        p["held"] = rep.held[i] == Held::kFixed          ? "fixed"
                    : rep.held[i] == Held::kAtLowerBound ? "lower bound"
                                                         : "upper bound";
      }
    }
    if (ctx.budget != nullptr && i < ctx.budget->statements.size() && !ctx.budget->statements[i].inputs.empty()) {
      p.update(BudgetJson(ctx.budget->statements[i], u.to_coarse, u.coarse));
    }
    params[name] = p;
    order.push_back(name);
  }
  j["parameters"] = params;
  j["parameter_order"] = order;
  json fit;
  fit["rms_um"] = r.rms_um;
  fit["pv_um"] = r.pv_um;
  fit["n_points"] = r.n_points;
  fit["n_setups"] = r.setup_ids.size();
  fit["converged"] = r.converged;
  fit["iterations"] = r.iterations;
  fit["solver_message"] = r.solver_message;
  if (!rep.Empty()) {
    fit["residual_sigma_um"] = rep.residual_sigma_mm * kUmPerMm;
    fit["condition_number"] = std::isfinite(rep.condition_number) ? json(rep.condition_number) : json(nullptr);
    // The rows and columns of "parameter_order" (the seven errors and the centres; a fit with
    // further effects reports those in its own section).
    json corr = json::array();
    for (Eigen::Index a = 0; a < static_cast<Eigen::Index>(n); ++a) {
      json row = json::array();
      for (Eigen::Index b = 0; b < static_cast<Eigen::Index>(n); ++b) {
        const double c = rep.correlation(a, b);
        row.push_back(std::isfinite(c) ? json(c) : json(nullptr));
      }
      corr.push_back(row);
    }
    j["correlation"] = corr;
    json weak = json::array();
    for (const WeakCombination& w : rep.weak) {
      json terms = json::object();
      for (const auto& [idx, c] : w.terms) terms[rep.parameters[static_cast<std::size_t>(idx)].name] = c;
      weak.push_back({{"relative_singular_value", w.relative_singular_value}, {"terms", terms}});
    }
    j["nearly_dependent"] = weak;
  }
  j["fit"] = fit;
  if (ctx.budget != nullptr) {
    json inputs = json::array();
    inputs.push_back({{"input", "fit (scatter of the points)"}, {"type", "A"}, {"dof", ctx.budget->type_a_dof}});
    for (const BudgetSensitivity& s : ctx.budget->inputs) {
      inputs.push_back({{"input", s.input}, {"type", "B"}, {"u", s.u}, {"unit", s.unit}, {"note", s.note}});
    }
    j["uncertainty_inputs"] = inputs;
    j["coverage"] = ctx.budget->coverage.probability > 0.0 ? json{{"probability", ctx.budget->coverage.probability}}
                                                           : json{{"k", ctx.budget->coverage.k}};
  }
  for (std::size_t i = 0; i < rep.parameters.size(); ++i) {
    if (!rep.determined[i]) undetermined.push_back(rep.parameters[i].name);
  }
  j["undetermined"] = undetermined;
  const Usability usability = JudgeUsability(r, ctx);
  j["usable"] = usability.usable;
  j["why_not_usable"] = usability.reasons;
  j["usable_against"] = usability.requirement;
  json outliers = json::array();
  for (const Outlier& o : r.outliers) outliers.push_back({{"sample", o.sample + 1}, {"residual_um", o.residual_um}});
  j["outliers"] = outliers;
  if (r.robust_loss != RobustLoss::kNone) {
    json weighted = json::array();
    for (const WeightedReading& w : r.weighted) {
      weighted.push_back({{"sample", w.sample + 1}, {"weight", w.weight}, {"residual_um", w.residual_um}});
    }
    j["robust_loss"] = {{"loss", r.robust_loss == RobustLoss::kHuber ? "huber" : "cauchy"},
                        {"noise_um", r.robust_sigma_mm * kUmPerMm},
                        {"scale_um", r.robust_scale_mm * kUmPerMm},
                        {"weighted_readings", weighted}};
  }
  if (r.prior_sigma_mm > 0.0) j["prior_noise_um"] = r.prior_sigma_mm * kUmPerMm;
  j["warnings"] = AllWarnings(r, ctx);
  if (ctx.statements != nullptr && !ctx.statements->empty()) j["statements"] = StatementsJson(ctx);
  if (ctx.known_form != nullptr) j["known_form"] = KnownFormJson(*ctx.known_form);
  if (ctx.other_known_forms != nullptr && !ctx.other_known_forms->empty()) {
    json others = json::array();
    for (const KnownFormCheck& k : *ctx.other_known_forms) {
      json o = KnownFormJson(k);
      o["setups"] = k.setups;
      others.push_back(std::move(o));
    }
    j["known_forms_of_other_spheres"] = std::move(others);
  }
  if (ctx.trace != nullptr) internal::AddTraceJson(j, *ctx.trace, ctx.validation);
  if (ctx.comparison != nullptr) AddComparisonJson(j, *ctx.comparison);
  return j.dump(2) + "\n";
}

CalibrationFile MakeCalibrationFile(const CalibrationResult& r, const ReportContext& ctx) {
  CalibrationFile cal;
  cal.geometry = r.geometry;
  cal.probe_offset_mm = ctx.probe_offset_mm;
  cal.sphere_radius_mm = ctx.sphere_radius_mm;
  cal.created_by = ctx.program;
  // The combined covariance when the budget is made (Type B inputs such as R0 included), so that
  // measurements with the file carry them; otherwise the fit's.
  const bool combined = ctx.budget != nullptr && ctx.budget->covariance.rows() >= kNumScmsParams;
  if (!r.analysis.Empty()) {
    cal.covariance =
        (combined ? ctx.budget->covariance : r.analysis.covariance).topLeftCorner<kNumScmsParams, kNumScmsParams>();
  }
  cal.source.emplace_back("points_file", ctx.points_path);
  cal.source.emplace_back("fit_rms_um", Format("%.6g", r.rms_um));
  if (combined) {
    std::string inputs;
    for (const BudgetSensitivity& s : ctx.budget->inputs)
      inputs += ", " + s.input + " " + Format("%.6g", s.u) + " " + s.unit;
    cal.source.emplace_back("covariance", "combined: the fit's (Type A)" + inputs);
  }
  for (const auto& kv : ctx.metadata) cal.source.push_back(kv);
  return cal;
}

bool AddEffectsToCalibrationFile(const EffectFit& fit, CalibrationFile& file) {
  bool drift = false;
  file.effects.reference = fit.model.reference;
  file.effects.phi_wobble_pivot_mm = fit.model.phi_wobble_pivot_mm;
  for (std::size_t t = 0; t < fit.model.terms.size(); ++t) {
    if (fit.model.terms[t].effect == Effect::kProbeDrift) {
      drift = true;
      file.probe_drift_powers.clear();
      for (const EffectComponent& c : fit.model.terms[t].components) file.probe_drift_powers.push_back(c.order);
      continue;
    }
    file.effects.terms.push_back(fit.model.terms[t]);
    file.effect_values.push_back(fit.values[t]);
  }
  // The form of the setups of known orientation: the calibration sphere's, on its body frame.
  if (!fit.model.form.Empty()) {
    const ObservabilityReport& rep = fit.calibration.analysis;
    file.form_terms = fit.model.form.terms;
    file.form_values_mm = fit.form_values[0];
    file.form_std_mm.clear();
    for (std::size_t k = 0; k < file.form_terms.size() && !rep.Empty(); ++k) {
      file.form_std_mm.push_back(rep.std(fit.FormOffset(0) + static_cast<int>(k)));
    }
    bool finite = true;
    for (const double v : file.form_std_mm) finite &= std::isfinite(v);
    if (!finite) file.form_std_mm.clear();
  }
  return drift;
}

std::vector<int> AppliedColumns(const EffectFit& fit) {
  std::vector<int> columns;
  for (int p = 0; p < kNumScmsParams; ++p) columns.push_back(p);
  for (std::size_t t = 0; t < fit.model.terms.size(); ++t) {
    if (fit.model.terms[t].effect == Effect::kProbeDrift) continue;
    for (int i = 0; i < fit.model.terms[t].size(); ++i) columns.push_back(fit.TermOffset(t) + i);
  }
  if (!fit.model.form.Empty()) {
    for (std::size_t k = 0; k < fit.model.form.terms.size(); ++k)
      columns.push_back(fit.FormOffset(0) + static_cast<int>(k));
  }
  return columns;
}

void AddCovarianceToCalibrationFile(const std::vector<int>& columns, const CalibrationResult& result,
                                    const CalibrationBudget* budget, CalibrationFile& file) {
  if (result.analysis.Empty()) return;
  const Eigen::MatrixXd& all = budget != nullptr ? budget->covariance : result.analysis.covariance;
  const auto n = static_cast<Eigen::Index>(columns.size());
  Eigen::MatrixXd c(n, n);
  for (Eigen::Index p = 0; p < n; ++p) {
    for (Eigen::Index q = 0; q < n; ++q)
      c(p, q) = all(columns[static_cast<std::size_t>(p)], columns[static_cast<std::size_t>(q)]);
  }
  if (!c.allFinite()) return;  // a parameter the data do not determine: the seven errors' block alone
  file.covariance = c.topLeftCorner<kNumScmsParams, kNumScmsParams>();
  if (n > kNumScmsParams) file.parameter_covariance = c;
  file.covariance_type_a_dof =
      budget != nullptr ? budget->type_a_dof
                        : static_cast<double>(result.n_points) - static_cast<double>(result.analysis.parameters.size());
  if (budget == nullptr) return;
  for (const BudgetSensitivity& s : budget->inputs) {
    CalibrationFile::CovarianceInput in{s.input, s.unit, s.u, Eigen::VectorXd(n)};
    for (Eigen::Index p = 0; p < n; ++p) in.per_unit(p) = s.per_unit(columns[static_cast<std::size_t>(p)]);
    file.covariance_inputs.push_back(in);
  }
}

Calibration CompensationOf(const EffectFit& fit, double probe_offset_mm) {
  CalibrationFile file;
  file.geometry = fit.calibration.geometry;
  file.probe_offset_mm = probe_offset_mm;
  AddEffectsToCalibrationFile(fit, file);
  return ToCalibration(file);
}

}  // namespace sph
