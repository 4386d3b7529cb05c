#include "sph/calib/usability.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "sph/calib/design.hpp"
#include "sph/calib/statements.hpp"
#include "sph/internal/format.hpp"
#include "sph/io/parameter_settings.hpp"
#include "sph/model/units.hpp"
#include "sph/select/trace.hpp"

namespace sph {
namespace {

using internal::Format;

// The centres' columns in the analysis' order (the seven errors, then x, y, z of each centre).
bool IsCentre(std::size_t i, const CalibrationResult& r) {
  return i >= kNumScmsParams && i < kNumScmsParams + 3 * r.centers_mm.size();
}

// A standard uncertainty [rad or mm] of parameter i as a displacement of the probed point [um].
double AsDisplacementUm(const ObservabilityReport& rep, std::size_t i, double u) {
  const ParameterDescription& p = rep.parameters[i];
  return u * (p.quantity == Quantity::kAngle ? p.lever_mm : 1.0) * kUmPerMm;
}

void JudgeFit(const CalibrationResult& r, const ReportContext& ctx, Usability& u) {
  if (!r.converged) u.reasons.push_back("the solver did not converge (" + r.solver_message + ")");
  const ObservabilityReport& rep = r.analysis;
  const std::string names = rep.UndeterminedText();
  if (!names.empty()) {
    u.reasons.push_back("the data do not determine " + names +
                        ": their standard uncertainty, as a displacement of the probed point (angles times R0), "
                        "exceeds " +
                        Format("%g", ctx.max_std_um) + " um (--max-std-um)");
  }
}

// Each determined parameter the calibration applies, by its combined standard uncertainty.
void JudgeBudget(const CalibrationResult& r, const ReportContext& ctx, Usability& u) {
  if (ctx.budget == nullptr || r.analysis.Empty()) return;
  const ObservabilityReport& rep = r.analysis;
  for (std::size_t i = 0; i < ctx.budget->statements.size() && i < rep.parameters.size(); ++i) {
    const gum::UncertaintyStatement& st = ctx.budget->statements[i];
    if (IsCentre(i, r) || !rep.determined[i] || st.inputs.empty()) continue;
    const double u_um = AsDisplacementUm(rep, i, st.u);
    if (u_um <= ctx.max_std_um) continue;
    const int largest = st.Largest();
    const std::string from =
        largest < 0 ? ""
                    : ", most of it from " + st.inputs[static_cast<std::size_t>(largest)].name + " (" +
                          Format("%.4g", AsDisplacementUm(
                                             rep, i, st.inputs[static_cast<std::size_t>(largest)].Contribution())) +
                          " um)";
    u.reasons.push_back(rep.parameters[i].name + " has a combined standard uncertainty of " + Format("%.4g", u_um) +
                        " um as a displacement (U = " + Format("%.4g", AsDisplacementUm(rep, i, st.U)) +
                        " um, k = " + Format("%.2f", st.k) + ")" + from + ": above " + Format("%g", ctx.max_std_um) +
                        " um (--max-std-um), the uncertainty budget, not the fit, leaves it undetermined");
  }
}

// d' against the spheres it was fitted on and the probe's range.
void JudgeZeroError(const CalibrationResult& r, const ReportContext& ctx, Usability& u) {
  const double d_prime = r.geometry[kDPrime];
  double radius = ctx.sphere_radius_mm;
  for (const auto& [setup, other_mm] : ctx.sphere_radii_mm) radius = std::min(radius, other_mm);
  if (radius > 0.0 && !(std::abs(d_prime) <= 0.1 * radius)) {
    u.reasons.push_back(
        Format("d' = %.6g mm is more than a tenth of the sphere's radius (%g mm): with the nominal d the points lie "
               "on a sphere of radius about R0 - d' = %.6g mm, so the stated R0 (sphere_radius_mm, "
               "--sphere-radius-mm) or d (probe_offset_mm, --probe-offset-mm) does not describe this set-up; a real "
               "zero error that large is taken into d before calibrating again",
               d_prime, radius, ctx.sphere_radius_mm - d_prime));
  }
  if (ctx.probe_range_mm && !(std::abs(d_prime) <= *ctx.probe_range_mm)) {
    u.reasons.push_back(
        Format("|d'| = %.6g mm exceeds the probe's measuring range (%g mm, probe_range_mm): the "
               "probe's zero cannot be that far from where d puts it",
               std::abs(d_prime), *ctx.probe_range_mm));
  }
}

// The errors, effects and form within what a calibration file holds.
void JudgeBounds(const CalibrationResult& r, const ReportContext& ctx, Usability& u) {
  for (int p = 0; p < kNumScmsParams; ++p) {
    const ScmsParamInfo& info = kScmsParamInfo[static_cast<std::size_t>(p)];
    const ReportUnits units = ReportUnitsOf(p);
    const double value = r.geometry[static_cast<std::size_t>(p)] * units.to_coarse;
    const double bound = p == kDPrime ? std::min(info.max_abs_report, ctx.probe_offset_mm) : info.max_abs_report;
    if (std::abs(value) < bound || (p != kDPrime && std::abs(value) == bound)) continue;
    u.reasons.push_back(
        Format("%s = %.6g %s: a geometric error of the machine lies within %g %s%s; a calibration "
               "file does not hold it",
               info.name, value, units.coarse, bound, units.coarse, p == kDPrime ? " (and below d)" : ""));
  }
  if (ctx.trace == nullptr) return;
  const EffectFit& fit = ctx.trace->after.fit;
  for (std::size_t t = 0; t < fit.model.terms.size(); ++t) {
    const EffectTerm& term = fit.model.terms[t];
    const bool angle = term.info().quantity == Quantity::kAngle;
    const double scale = angle ? 1.0 / kRadPerArcsec : kUmPerMm, bound = angle ? kMaxEffectArcsec : kMaxEffectUm;
    for (std::size_t i = 0; i < fit.values[t].size(); ++i) {
      const double v = fit.values[t][i] * scale;
      if (std::abs(v) <= bound) continue;
      u.reasons.push_back(
          Format("%s = %.6g %s: an effect of the machine lies within %g %s; a calibration file does "
                 "not hold it",
                 term.ParamName(i).c_str(), v, angle ? "arcsec" : "um", bound, angle ? "arcsec" : "um"));
    }
  }
  for (const std::vector<double>& group : fit.form_values) {
    for (std::size_t k = 0; k < group.size() && k < fit.model.form.terms.size(); ++k) {
      const double v_um = group[k] * kUmPerMm;
      if (std::abs(v_um) <= kMaxEffectUm) continue;
      const FormTerm& f = fit.model.form.terms[k];
      u.reasons.push_back(
          Format("the sphere's form term S(%d,%d) = %.6g um: a form term lies within %g um; a "
                 "calibration file does not hold it",
                 f.l, f.m, v_um, kMaxEffectUm));
    }
  }
}

// Each statement of the lab the readings reject, unless the user accepted it.
void JudgeStatements(const ReportContext& ctx, Usability& u) {
  if (ctx.statements == nullptr) return;
  for (const StatementCheck& s : *ctx.statements) {
    if (!s.rejected || s.accepted || s.kind == StatementKind::kEarlierModel) continue;  // the comparison informs
    std::string why = "the readings reject " + s.statement + ": stated " + s.stated + ", the readings without it " +
                      s.readings + "; " +
                      Format("chi-square %.3g for %d degree%s of freedom, p %s, below %g", s.chi_square, s.dof,
                             s.dof == 1 ? "" : "s", PValueText(s.p_value).c_str(), kStatementP);
    if (s.orientation) why += "; " + s.orientation->text;
    u.reasons.push_back(why +
                        ". The trace adds nothing on top of it; correct the statement, or accept it against the "
                        "readings (--accept-rejected)");
  }
}

// "beta_deg=0.0172": a value of parameter `name` (rad or mm) in the unit the reports give it in
// (the seven errors deg or mm, the effects arcsec or um), 3 significant digits.
std::string ShortValueText(const std::string& name, double value) {
  const bool error = name.find('.') == std::string::npos;
  const bool angle = ParameterQuantity(name) == Quantity::kAngle;
  const char* unit = angle ? (error ? "deg" : "arcsec") : (error ? "mm" : "um");
  const double scale = angle ? (error ? 1.0 / kRadPerDeg : 1.0 / kRadPerArcsec) : (error ? 1.0 : kUmPerMm);
  return name + "_" + unit + "=" + Format("%.3g", value * scale);
}

// "beta_urad=300": a target's text, as the lab wrote it.
std::string TargetText(const TargetUncertainty& t) { return t.text.empty() ? ShortValueText(t.name, t.U) : t.text; }

// `value` (rad or mm) in the unit target `t` was written in ("beta_urad=689" beside "beta_urad=5"),
// or as ShortValueText() when the target has no text.
std::string InTargetsUnit(const TargetUncertainty& t, double value) {
  const std::size_t eq = t.text.find('=');
  const std::string head = eq == std::string::npos ? std::string() : t.text.substr(0, eq);
  const double written = eq == std::string::npos ? 0.0 : std::strtod(t.text.c_str() + eq + 1, nullptr);
  if (head.empty() || !(written > 0.0) || !(t.U > 0.0)) return ShortValueText(t.name, value);
  return head + "=" + Format("%.3g", value / t.U * written);
}

// The column of parameter `name` in the reported calibration's analysis (the seven errors, then
// the effects' parameters of the trace's final fit); -1 when it has none.
int ColumnOfName(const CalibrationResult& r, const std::string& name) {
  for (std::size_t i = 0; i < r.analysis.parameters.size(); ++i) {
    if (r.analysis.parameters[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

// The requirement: the lab's targets, or the default's reference for the seven errors.
void JudgeRequirement(const CalibrationResult& r, const ReportContext& ctx, Usability& u) {
  if (ctx.requirement == nullptr) return;
  const UsabilityRequirement& q = *ctx.requirement;
  const ObservabilityReport& rep = r.analysis;
  if (rep.Empty()) return;
  for (const TargetUncertainty& t : q.target_u) {
    const int i = ColumnOfName(r, t.name);
    if (i < 0) {
      u.reasons.push_back("--target-u " + TargetText(t) + ": the calibration has no parameter " + t.name);
      continue;
    }
    const bool budget = ctx.budget != nullptr && static_cast<std::size_t>(i) < ctx.budget->statements.size() &&
                        !ctx.budget->statements[static_cast<std::size_t>(i)].inputs.empty();
    const double big_u = budget ? ctx.budget->statements[static_cast<std::size_t>(i)].U : 2.0 * rep.std(i);
    if (big_u <= t.U) continue;
    u.reasons.push_back(t.name + ": its expanded uncertainty " + InTargetsUnit(t, big_u) +
                        (budget ? "" : " (2 u from the fit: no budget)") + " is above the stated target --target-u " +
                        TargetText(t));
  }
  if (!q.target_u.empty() || q.max_std_stated) return;
  for (int p = 0;
       p < kNumScmsParams && p < static_cast<int>(q.reference_um.size()) && p < static_cast<int>(q.seven_um.size());
       ++p) {
    const double reference = q.reference_um[static_cast<std::size_t>(p)];
    const double u_um = q.seven_um[static_cast<std::size_t>(p)];
    if (!(reference > 0.0) || !std::isfinite(reference) || !std::isfinite(u_um) || rep.IsHeld(p)) continue;
    if (u_um <= kReferenceFactor * reference) continue;
    u.reasons.push_back(Format(
        "the readings determine %s to %.3g um as a displacement (the seven errors fitted alone), more than %g "
        "times the %.3g um the reference pattern (one placement at 2 mm, 24 x 12 readings) gives this set-up at "
        "their noise of %.3g um: the pattern does not determine the machine as this set-up can (too few readings, "
        "or too little of the sphere); state the requirement the use needs (--max-std-um, --target-u) if this is "
        "enough",
        kScmsParamInfo[static_cast<std::size_t>(p)].name, u_um, kReferenceFactor, reference, q.reference_noise_um));
  }
}

}  // namespace

std::string UsabilityRequirement::Text(double max_std_um) const {
  if (!target_u.empty()) {
    std::string targets;
    for (const TargetUncertainty& t : target_u) targets += (targets.empty() ? "" : ", ") + TargetText(t);
    return "the stated requirement: expanded uncertainties within --target-u " + targets +
           Format(", every standard uncertainty within %g um as a displacement", max_std_um);
  }
  if (max_std_stated) {
    return Format("the stated requirement: every standard uncertainty within %g um as a displacement (--max-std-um)",
                  max_std_um);
  }
  if (reference_um.empty()) return Format("every standard uncertainty within %g um as a displacement", max_std_um);
  return Format(
      "the default requirement: each of the seven errors within %g times what the reference pattern predicts for "
      "this set-up at the readings' noise (%.3g um), every standard uncertainty within %g um as a displacement",
      kReferenceFactor, reference_noise_um, max_std_um);
}

std::vector<double> ReferenceUncertaintyUm(double sphere_radius_mm, double probe_offset_mm,
                                           const ScmsGeometry& geometry, double noise_um) {
  SimulationSpec spec;
  spec.sphere_radius_mm = sphere_radius_mm;
  spec.probe_offset_mm = probe_offset_mm;
  spec.truth = geometry;
  spec.noise_r_um = noise_um;
  const PredictedUncertainty predicted = PredictUncertainty(spec);
  std::vector<double> out;
  for (int p = 0; p < kNumScmsParams; ++p) out.push_back(predicted.StdAsDisplacementUm(p));
  return out;
}

Usability JudgeUsability(const CalibrationResult& result, const ReportContext& ctx) {
  Usability u;
  JudgeFit(result, ctx, u);
  JudgeBudget(result, ctx, u);
  JudgeZeroError(result, ctx, u);
  JudgeBounds(result, ctx, u);
  JudgeStatements(ctx, u);
  JudgeRequirement(result, ctx, u);
  u.requirement = ctx.requirement != nullptr
                      ? ctx.requirement->Text(ctx.max_std_um)
                      : Format("every standard uncertainty within %g um as a displacement", ctx.max_std_um);
  if (!u.reasons.empty() && !ctx.likely_cause.empty()) u.reasons.push_back(ctx.likely_cause);
  u.usable = u.reasons.empty();
  return u;
}

}  // namespace sph
