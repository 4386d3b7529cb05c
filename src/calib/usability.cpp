#include "sph/calib/usability.hpp"

#include <algorithm>
#include <cmath>

#include "sph/internal/format.hpp"
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

}  // namespace

Usability JudgeUsability(const CalibrationResult& result, const ReportContext& ctx) {
  Usability u;
  JudgeFit(result, ctx, u);
  JudgeBudget(result, ctx, u);
  JudgeZeroError(result, ctx, u);
  JudgeBounds(result, ctx, u);
  if (!u.reasons.empty() && !ctx.likely_cause.empty()) u.reasons.push_back(ctx.likely_cause);
  u.usable = u.reasons.empty();
  return u;
}

}  // namespace sph
