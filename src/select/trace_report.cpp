#include "sph/select/trace_report.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>
#include <utility>

#include <nlohmann/json.hpp>

#include "sph/calib/report.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/io/setup_checks.hpp"
#include "sph/model/compensation.hpp"
#include "sph/model/units.hpp"
#include "sph/select/form_report.hpp"
#include "sph/sphere/sphere_fit.hpp"
#include "sph/sphere/sphere_form.hpp"
#include "sph/stats/rounding.hpp"
#include "trace_json.hpp"

namespace sph {
namespace {

using internal::Format;
using nlohmann::json;

// Effect parameters are reported in arcsec (angles) or um (lengths).
struct EffectUnit {
  const char* name;
  double per_internal;
};
EffectUnit UnitOf(const EffectTerm& term) {
  return term.info().quantity == Quantity::kAngle ? EffectUnit{"arcsec", 1.0 / kRadPerArcsec}
                                                  : EffectUnit{"um", kUmPerMm};
}

// Peak to valley and rms [um] of the radial residuals about the points' least-squares sphere.
std::pair<double, double> LsSphericityUm(const std::vector<Eigen::Vector3d>& points) {
  const LeastSquaresSphere fit = FitSphereLeastSquares(points);
  if (!fit.sphere.ok) throw Error("the validation points do not determine a sphere");
  return {RadialPeakToValley(points, fit.sphere.center) * kUmPerMm, fit.rms * kUmPerMm};
}

json GroupJson(const StructureGroup& g) {
  return {{"functions", g.description},
          {"rank", g.rank},
          {"explained_rms_um", g.explained_rms_um},
          {"f", g.f},
          {"p_value", g.p_value},
          {"strongest", g.strongest},
          {"strongest_rms_um", g.strongest_rms_um},
          {"delta_bic", g.delta_bic}};
}

json NumberOrNull(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json NumbersOrNulls(const std::vector<double>& values) {
  json out = json::array();
  for (const double v : values) out.push_back(NumberOrNull(v));
  return out;
}

json FitJson(const TracedFit& f) {
  json structure = json::object();
  for (const StructureGroup& g : f.structure.groups) structure[g.variable] = GroupJson(g);
  structure["all"] = GroupJson(f.structure.all);
  return {{"rms_um", f.fit.calibration.rms_um},
          {"pv_um", f.fit.calibration.pv_um},
          {"cv_rms_um", f.cv_rms_um},
          {"loso_rms_um", NumberOrNull(f.loso_rms_um)},
          {"loso_not_judged_setups", f.loso_not_judged},
          {"structure_p_value", f.structure.all.p_value},
          {"structure", structure},
          {"theta_harmonics_um", NumbersOrNulls(f.structure.theta_harmonics_um)},
          {"n_params", f.fit.n_params},
          {"bic", f.fit.Bic()}};
}

json SphereFormJson(const SphereFormResult& f) {
  json terms = json::array();
  for (const FormTermValue& t : f.terms) {
    terms.push_back({{"l", t.l}, {"m", t.m}, {"value_um", t.value_um}, {"std_um", NumberOrNull(t.std_um)}});
  }
  json out = {{"degree_max", f.degree_max},
              {"rms_um", f.rms_um},
              {"rms_std_um", NumberOrNull(f.rms_std_um)},
              {"rms_fitted_um", f.rms_fitted_um},
              {"rms_noise_um", NumberOrNull(f.rms_noise_um)},
              {"rms_noise_std_um", NumberOrNull(f.rms_noise_std_um)},
              {"pv_um", f.pv_um},
              {"terms", terms},
              {"confounded", f.confounded}};
  if (f.higher_degree_limit > 0) {
    out["higher_degrees"] = {
        {"degree_min", f.degree_max + 1}, {"degree_max", f.higher_degree_limit}, {"rms_max_um", f.higher_rms_max_um}};
  }
  return out;
}

void WriteSphereFormText(std::ostream& out, const SphereFormResult& f) {
  const std::string which =
      f.setups.empty() ? "" : " of setup(s) " + f.setups.substr(1) + " (unknown orientation or another sphere)";
  const gum::RoundedResult rms = gum::RoundResult(f.rms_um, f.rms_std_um);
  out << Format("  sphere form%s: degrees 2..%d, rms %s +- %s um, peak to valley %.4f um over the whole sphere\n",
                which.c_str(), f.degree_max, rms.value_text.c_str(), rms.uncertainty_text.c_str(), f.pv_um);
  out << Format(
      "    (rms: the coefficients' %.4f um with their noise's share %.4f um taken out in quadrature, +- %.4f "
      "from the noise",
      f.rms_fitted_um, f.rms_noise_um, f.rms_noise_std_um);
  if (f.higher_degree_limit > 0) {
    out << Format(
        "; degrees %d..%d, which the pattern also resolves, could add up to %.4f um rms (95 %%), "
        "included in the +-",
        f.degree_max + 1, f.higher_degree_limit, f.higher_rms_max_um);
  }
  out << ")\n";
  out << "    (Schmidt semi-normalised harmonics S(l,m) of the sphere's body frame, |S| <= 1, mean square 1/(2l+1); "
         "radial displacement of the surface)\n";
  std::string line;
  int on_line = 0;
  for (const FormTermValue& t : f.terms) {
    const gum::RoundedResult v = gum::RoundResult(t.value_um, t.std_um);
    line += Format("    S(%d,%d) %s%s +- %s", t.l, t.m, v.value < 0 || v.value_text[0] == '-' ? "" : "+",
                   v.value_text.c_str(), v.uncertainty_text.c_str());
    if (++on_line == 4) {
      out << line << "\n";
      line.clear();
      on_line = 0;
    }
  }
  if (!line.empty()) out << line << "\n";
  for (const std::string& c : f.confounded) out << "    confounded: " << c << "\n";
}

}  // namespace

Validation Validate(const std::string& path, double probe_offset_mm, const TraceResult& trace) {
  const PointsData data = ReadPointsFile(path);
  CheckProbeOffsetMatches(data, probe_offset_mm, "");
  if (const auto range = ConditionsOf(data.header).probe_range_mm)
    CheckReadingsInProbeRange(data, *range, "probe_range_mm");
  Validation v;
  v.path = path;
  v.n_points = static_cast<int>(data.samples.size());
  if (trace.after.fit.model.Find(Effect::kProbeDrift) >= 0) {
    v.note = "probe_drift is not applied: a drift belongs to the run it was measured in";
  }
  const Calibration before = CompensationOf(trace.before.fit, probe_offset_mm);
  const Calibration after = CompensationOf(trace.after.fit, probe_offset_mm);
  // Each setup is a sphere position of its own: one least-squares sphere each.
  std::map<int, std::vector<Sample>> setups;
  for (const Sample& s : data.samples) setups[s.setup].push_back(s);
  for (const auto& [setup, samples] : setups) {
    const std::vector<Eigen::Vector3d> before_pts = CompensateAll(before, samples);
    std::vector<Eigen::Vector3d> after_pts = CompensateAll(after, samples);
    // A probe_incidence term needs the sphere's centre: that of the points without it, then again.
    for (int pass = 0; pass < 2 && after.effects.Find(Effect::kProbeIncidence) >= 0; ++pass) {
      const LeastSquaresSphere fit = FitSphereLeastSquares(after_pts);
      if (!fit.sphere.ok) break;
      after_pts = CompensateAll(after, samples, fit.sphere.center);
    }
    ValidationSetup vs;
    vs.setup = setup;
    vs.n_points = static_cast<int>(samples.size());
    try {
      std::tie(vs.before_um, vs.before_rms_um) = LsSphericityUm(before_pts);
      std::tie(vs.after_um, vs.after_rms_um) = LsSphericityUm(after_pts);
    } catch (const Error& e) {
      throw Error(path + ": setup " + std::to_string(setup) + ": " + e.what());
    }
    v.before_um = std::max(v.before_um, vs.before_um);
    v.after_um = std::max(v.after_um, vs.after_um);
    v.setups.push_back(vs);
  }
  // The rms pooled over the setups, each about its own sphere: nu = sum (n_s - 4).
  double ss_before = 0.0, ss_after = 0.0, n = 0.0, dof = 0.0;
  for (const ValidationSetup& vs : v.setups) {
    ss_before += vs.before_rms_um * vs.before_rms_um * vs.n_points;
    ss_after += vs.after_rms_um * vs.after_rms_um * vs.n_points;
    n += vs.n_points;
    dof += std::max(1, vs.n_points - 4);
  }
  RmsComparison& c = v.rms;
  c.before_um = std::sqrt(ss_before / n);
  c.after_um = std::sqrt(ss_after / n);
  c.before_u_um = c.before_um / std::sqrt(2.0 * dof);
  c.after_u_um = c.after_um / std::sqrt(2.0 * dof);
  c.difference_um = c.before_um - c.after_um;
  c.difference_u_um = std::hypot(c.before_u_um, c.after_u_um);
  c.inside_noise = std::abs(c.difference_um) <= 2.0 * c.difference_u_um;
  return v;
}
namespace {

// The rms, peak to valley, cross-validated rms and structure p before and after, and the
// leave-one-setup-out rms.
void WriteTraceSummary(std::ostream& out, const TraceResult& r) {
  const TracedFit& b = r.before;
  const TracedFit& a = r.after;
  out << "\ntracing the residual (to the effects the seven-error model lacks)\n";
  out << Format("  %-34s %10s %10s %10s %12s\n", "", "rms um", "p-v um", "cv rms um", "structure p");
  out << Format("  %-34s %10.4f %10.4f %10.4f %12.2g\n", "before (seven errors)", b.fit.calibration.rms_um,
                b.fit.calibration.pv_um, b.cv_rms_um, b.structure.all.p_value);
  std::string added;
  for (Effect e : r.added) added += (added.empty() ? "" : " + ") + std::string(InfoOf(e).id);
  out << Format("  %-34s %10.4f %10.4f %10.4f %12.2g\n",
                ("after" + (added.empty() ? "" : " (+ " + added + ")")).c_str(), a.fit.calibration.rms_um,
                a.fit.calibration.pv_um, a.cv_rms_um, a.structure.all.p_value);
  std::string not_judged;
  for (const int s : a.loso_not_judged) not_judged += (not_judged.empty() ? "" : ", ") + std::to_string(s);
  if (std::isfinite(b.loso_rms_um) && std::isfinite(a.loso_rms_um)) {
    out << Format(
        "  leave one setup out (each setup of known orientation predicted from the others, its centre "
        "and a drift over its own time refitted): rms %.4f um before, %.4f um after\n",
        b.loso_rms_um, a.loso_rms_um);
    if (!not_judged.empty()) {
      out << "    not judged: setup(s) " << not_judged
          << ", whose others do not determine the final model (its effects or form) without it\n";
    }
  } else if (!not_judged.empty()) {
    out << "  leave one setup out: cannot be judged on this design (setup(s) " << not_judged
        << ": without it, the others do not determine the final model, its effects or form)\n";
  }
}

// The structure of the residual before the trace, by variable and in harmonics of theta.
void WriteStructure(std::ostream& out, const TraceResult& r) {
  const TracedFit& b = r.before;
  out << "  structure before, by variable (F test against white noise):\n";
  for (const StructureGroup& g : b.structure.groups) {
    out << Format("    %-9s explains %.4f um rms, p = %.2g, strongest %s (%.4f um rms alone)\n", g.variable.c_str(),
                  g.explained_rms_um, g.p_value, g.strongest.c_str(), g.strongest_rms_um);
  }
  out << "  harmonics of theta before, amplitude fitted alone [um]:";
  for (std::size_t k = 0; k < b.structure.theta_harmonics_um.size(); ++k) {
    const double a = b.structure.theta_harmonics_um[k];
    out << " " << k + 1 << ": " << (std::isfinite(a) ? Format("%.4f", a) : "unresolved");
  }
  out << "\n";
}

// Each candidate of each round, its score and what became of it.
void WriteCandidates(std::ostream& out, const TraceResult& r) {
  out << "  candidates (delta BIC < 0 is better; added when <= -10 with a lower cv rms):\n";
  out << Format("    harmonic effects searched up to order %d of theta and %d of phi\n", r.harmonics.theta,
                r.harmonics.phi);
  for (const CandidateScore& c : r.candidates) {
    const std::string bic = std::isfinite(c.delta_bic) ? Format("%9.1f", c.delta_bic) : "        -";
    const std::string cv = std::isfinite(c.cv_rms_um) ? Format("%.4f um", c.cv_rms_um) : "      -   ";
    out << Format("    round %d %-20s delta BIC %s  cv rms %s  %s%s\n", c.round, c.Id().c_str(), bic.c_str(),
                  cv.c_str(), c.added ? "ADDED" : "", c.note.empty() ? "" : ("  (" + c.note + ")").c_str());
  }
}

// The effects of the final model with their values and standard uncertainties, and those the
// backward step removed.
void WriteEffectValues(std::ostream& out, const TraceResult& r) {
  const TracedFit& a = r.after;
  const ObservabilityReport& rep = a.fit.calibration.analysis;
  for (std::size_t t = 0; t < a.fit.model.terms.size(); ++t) {
    const EffectTerm& term = a.fit.model.terms[t];
    const EffectUnit u = UnitOf(term);
    const std::string iso = *term.info().iso_name ? std::string(" (ISO 230: ") + term.info().iso_name + ")" : "";
    out << "  " << term.info().id << ": " << term.info().description << iso << "\n";
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      const int col = a.fit.TermOffset(t) + static_cast<int>(i);
      if (!rep.Empty() && rep.IsHeld(col)) {
        out << Format("    %-30s %12.5f %s (%s)\n", term.ParamName(i).c_str(), a.fit.values[t][i] * u.per_internal,
                      u.name, rep.held[static_cast<std::size_t>(col)] == Held::kFixed ? "fixed" : "at bound");
        continue;
      }
      if (!rep.Empty() && !rep.determined[static_cast<std::size_t>(col)]) {
        const double disp = rep.StdAsDisplacementUm(col);
        out << Format("    %-30s %12s  (std %s um as a displacement: not determined by these data)\n",
                      term.ParamName(i).c_str(), "undetermined",
                      std::isfinite(disp) ? Format("%.3g", disp).c_str() : "infinite");
        continue;
      }
      // GUM 7.2.6: u to two significant digits, the value to the same place (the JSON has every digit).
      const gum::RoundedResult v = gum::RoundResult(a.fit.values[t][i] * u.per_internal,
                                                    rep.Empty() ? std::nan("") : rep.std(col) * u.per_internal);
      out << Format("    %-30s %12s +- %s %s\n", term.ParamName(i).c_str(), v.value_text.c_str(),
                    v.uncertainty_text.c_str(), u.name);
    }
  }
  for (const auto& [e, cost] : r.removed) {
    out << Format("  removed in the backward step: %s (the final model without it: delta BIC %+.1f)\n", InfoOf(e).id,
                  cost);
  }
  if (!r.held.empty()) {
    out << "  held back, not added (each cannot be told from another; --hold-confounded):";
    for (const Effect e : r.held) out << " " << InfoOf(e).id;
    out << "\n";
  }
}

// The components searched but not fitted, with how much of each the fitted ones represent over the
// range: "c1 (97 %), s1 (88 %)".
std::string LeftOutText(const ErrorCurve& c) {
  std::string s;
  for (const LeftOutComponent& l : c.left_out) {
    s += Format("%s%s (%.0f %%)", s.empty() ? "" : ", ", l.name.substr(l.name.rfind('.') + 1).c_str(),
                100.0 * l.represented);
  }
  return s;
}

// Each error curve: its range, what determines it, its certificate value and a compact table.
void WriteErrorCurves(std::ostream& out, const TraceResult& r) {
  if (r.curves.empty()) return;
  out << Format(
      "  error curves, each about its mean over the measured angles (a constant is a zero of the axis or a "
      "centre, not determined); U95: %.0f %% band of the curve, the models the choice of its components "
      "could have given averaged, k = %.2f\n",
      100.0 * r.curves.front().coverage_probability, r.curves.front().coverage_factor);
  for (const ErrorCurve& c : r.curves) {
    out << "  " << c.name << " (" << c.iso_name << "): " << c.convention << "\n";
    std::string fitted;
    for (const std::string& f : c.fitted) fitted += (fitted.empty() ? "" : " ") + f.substr(f.rfind('.') + 1);
    out << Format("    measured range %s %.6g..%.6g deg%s; fitted %s", c.variable.c_str(), c.range_lo_deg,
                  c.range_hi_deg, c.full_turn ? " (a full turn)" : " (not a full turn: the curve over it is determined, "
                                                                   "not each harmonic)",
                  fitted.c_str());
    if (!c.left_out.empty()) {
      out << "; searched, not fitted (the share of each that those fitted represent over the range): "
          << LeftOutText(c);
    }
    out << "\n";
    std::string averaged;
    for (const std::string& f : c.averaged) averaged += (averaged.empty() ? "" : " ") + f.substr(f.rfind('.') + 1);
    if (c.models_averaged > 1) {
      out << Format(
          "    band: %d models of %s averaged (each within two components of those fitted, weighted by its "
          "extended BIC); the one fitted has weight %.2f\n",
          c.models_averaged, averaged.c_str(), c.chosen_weight);
    } else {
      out << "    band: the noise of the components fitted alone (the models about them could not be fitted)\n";
    }
    const gum::RoundedResult pv = gum::RoundResult(c.pv, c.pv_u95);
    out << Format("    %s %s +- %s %s (U95; max at %.6g deg, min at %.6g deg)\n",
                  c.encoder ? "range of the positional deviation" : "error motion value (peak to valley)",
                  pv.value_text.c_str(), pv.uncertainty_text.c_str(), c.unit.c_str(), c.max_angle_deg, c.min_angle_deg);
    constexpr std::size_t kPerLine = 12;
    for (std::size_t i0 = 0; i0 < c.angle_deg.size(); i0 += kPerLine) {
      std::string a = Format("    %-10s", (c.variable + " deg").c_str());
      std::string v = Format("    %-10s", c.unit.c_str()), u = Format("    %-10s", "U95");
      for (std::size_t i = i0; i < std::min(c.angle_deg.size(), i0 + kPerLine); ++i) {
        a += Format(" %7.6g", c.angle_deg[i]);
        v += Format(" %+7.3f", c.value[i]);
        u += Format(" %7.3f", c.u95[i]);
      }
      out << a << "\n" << v << "\n" << u << "\n";
    }
  }
}

// The sphere form: what the design separates, the degree chosen, the form found, the reference of
// the probe and time terms.
void WriteForm(std::ostream& out, const TraceResult& r) {
  const TracedFit& a = r.after;
  out << "  sphere form: " << r.form.design << "\n";
  for (const std::string& c : r.form.confounded) out << "    confounded by the design: " << c << "\n";
  if (r.form.separable && !r.form.known) {
    std::string scores;
    for (const auto& [l, d] : r.form.delta_ebic) scores += Format(" %d: %.1f", l, d);
    out << "    extended BIC of the form of degrees 2..L against none, L =" << scores << "; chosen: "
        << (r.form.degree_max > 0 ? "degrees 2.." + std::to_string(r.form.degree_max) : std::string("no form")) << "\n";
  }
  for (const SphereFormResult& f : SphereFormOf(r)) WriteSphereFormText(out, f);
  if (!a.fit.model.Empty()) {
    const EffectReference& ref = a.fit.model.reference;
    out << Format("  reference: u = (r - %.6f mm) / %.6f mm, tau = (t - %.6g s) / %.6g s\n", ref.r_ref_mm,
                  ref.r_half_range_mm, ref.t_start_s, ref.t_span_s);
  }
}

// The explanations the data cannot tell apart, and the structure nothing explains.
void WriteAmbiguities(std::ostream& out, const TraceResult& r) {
  for (const Ambiguity& x : r.ambiguous) {
    if (x.chosen == "sphere_form" && x.form_turns_with_sphere) {
      out << "  two explanations, neither added: the sphere's own form, turning with it, of a higher degree"
          << Format(" (%.4f um rms), or %s (%.4f um rms), which this design cannot tell from such a form; ",
                    x.chosen_rms_um, x.other.c_str(), x.other_rms_um)
          << "to separate them: " << x.separate_by << "\n";
    } else if (x.chosen == "sphere_form") {
      Effect e{};
      const bool machine = EffectFromId(x.other, &e) && IsAxisError(e);  // an error of the machine's axes
      out << "  two explanations, neither added: a pattern fixed on the sphere, the sphere's own form"
          << Format(" (%.4f um rms), or %s (%.4f um rms), ", x.chosen_rms_um, x.other.c_str(), x.other_rms_um)
          << (machine ? "an error of the machine that, with the sphere in one placement, is such a pattern as well; "
                      : "which its own variable shows but no more than a form would; ")
          << "to separate them: " << x.separate_by << "\n";
    } else if (x.other == "sphere_form" && std::isfinite(x.other_rms_um)) {
      out << "  two explanations: " << x.chosen
          << Format(" (%.4f um rms, added: its own variable shows it)", x.chosen_rms_um)
          << Format(" or a pattern fixed on the sphere, the sphere's own form (%.4f um rms); ", x.other_rms_um)
          << "to separate them: " << x.separate_by << "\n";
    } else if (x.other == "sphere_form") {
      out << "  ambiguous: " << Format("%.0f %%", 100 * x.sphere_fraction) << " of what " << x.chosen
          << " explains is a pattern fixed on the sphere, which the reference sphere's own form error would give as "
             "well; to separate them: "
          << x.separate_by << "\n";
    } else if (!x.chosen_set.empty() || !x.other_set.empty()) {
      out << "  ambiguous: " << x.other << " explains the residual about as well as " << x.chosen
          << Format(" (delta BIC %.1f against %.1f, %d components against %d; ", x.delta_bic_other, x.delta_bic_chosen,
                    x.other_components, x.chosen_components)
          << (x.chosen_set.empty() ? "the set keeps more" : "the set keeps fewer")
          << "); to separate them: " << x.separate_by << "\n";
    } else if (x.neither_added) {
      out << "  two explanations, neither added: " << x.chosen << " or " << x.other
          << Format(" (delta BIC %.1f and %.1f), which ", x.delta_bic_chosen, x.delta_bic_other)
          << (x.by_design ? "this design cannot tell apart (their terms fitted together have a variance inflation "
                            "above 100)"
                          : "explain the residual about as well")
          << "; to separate them: " << x.separate_by << "\n";
      if (!x.checked.empty()) out << "    checked on this design: " << x.checked << "\n";
    } else {
      if (x.by_design) {
        out << "  ambiguous: " << x.other << " cannot be told from " << x.chosen
            << " by this design (their terms fitted together have a variance inflation above 100), though it "
               "explains less"
            << Format(" (delta BIC %.1f against %.1f); to separate them: ", x.delta_bic_other, x.delta_bic_chosen)
            << x.separate_by << "\n";
      } else {
        out << "  ambiguous: " << x.other << " explains the residual about as well as " << x.chosen
            << Format(" (delta BIC %.1f against %.1f); to separate them: ", x.delta_bic_other, x.delta_bic_chosen)
            << x.separate_by << "\n";
      }
      if (!x.checked.empty()) out << "    checked on this design: " << x.checked << "\n";
    }
  }
  for (const Unexplained& u : r.unexplained) {
    out << "  unexplained: " << u.description << Format(" (p = %.2g)", u.p_value) << "\n";
  }
  if (r.unexplained.empty()) out << "  no significant structure remains\n";
}

// The validation on another points file.
void WriteValidation(std::ostream& out, const Validation* validation) {
  const RmsComparison& c = validation->rms;
  out << Format("  validation on %s (%d points): least-squares sphericity %.4f um before, %.4f um after%s\n",
                validation->path.c_str(), validation->n_points, validation->before_um, validation->after_um,
                validation->setups.size() > 1 ? " (worst setup)" : "");
  out << Format(
      "    rms about the least-squares sphere %.4f +- %.4f um before, %.4f +- %.4f um after (standard "
      "uncertainties): the difference %.4f +- %.4f um is %s\n",
      c.before_um, c.before_u_um, c.after_um, c.after_u_um, c.difference_um, c.difference_u_um,
      c.inside_noise ? "inside the noise (within twice its uncertainty): the validation shows no change"
                     : "beyond the noise (more than twice its uncertainty)");
  out << "    (a peak to valley is an extreme of the noise: compare before and after by the rms)\n";
  if (validation->setups.size() > 1) {
    for (const ValidationSetup& s : validation->setups) {
      out << Format("    setup %d (%d points): %.4f um before, %.4f um after; rms %.4f um before, %.4f um after\n",
                    s.setup, s.n_points, s.before_um, s.after_um, s.before_rms_um, s.after_rms_um);
    }
  }
  if (!validation->note.empty()) out << "    " << validation->note << "\n";
}

}  // namespace

void WriteTraceText(std::ostream& out, const TraceResult& r, const Validation* validation) {
  WriteTraceSummary(out, r);
  WriteStructure(out, r);
  WriteCandidates(out, r);
  WriteEffectValues(out, r);
  WriteErrorCurves(out, r);
  WriteForm(out, r);
  WriteAmbiguities(out, r);
  if (validation) WriteValidation(out, validation);
}
namespace {

// The effects of the final model with their values and standard uncertainties.
json EffectsJson(const EffectFit& a) {
  json effects = json::array();
  const ObservabilityReport& rep = a.calibration.analysis;
  for (std::size_t t = 0; t < a.model.terms.size(); ++t) {
    const EffectTerm& term = a.model.terms[t];
    const EffectUnit u = UnitOf(term);
    json params = json::array();
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      const int col = a.TermOffset(t) + static_cast<int>(i);
      params.push_back({{"name", term.ParamName(i)},
                        {"value", a.values[t][i] * u.per_internal},
                        {"std", rep.Empty() ? json(nullptr) : json(rep.std(col) * u.per_internal)},
                        {"unit", u.name}});
      if (!rep.Empty() && rep.IsHeld(col)) {
        params.back()["held"] = rep.held[static_cast<std::size_t>(col)] == Held::kFixed ? "fixed" : "at bound";
      }
    }
    effects.push_back({{"id", term.info().id},
                       {"iso_name", term.info().iso_name},
                       {"description", term.info().description},
                       {"parameters", params}});
  }
  return effects;
}

// The error curves: the keys of the values carry the curve's unit ("value_arcsec", "u95_um").
json ErrorCurvesJson(const TraceResult& r) {
  json curves = json::array();
  for (const ErrorCurve& c : r.curves) {
    json left_out = json::array();
    for (const LeftOutComponent& l : c.left_out) left_out.push_back({{"name", l.name}, {"represented", l.represented}});
    curves.push_back({{"id", c.name},
                      {"effect", InfoOf(c.effect).id},
                      {"iso_name", c.iso_name},
                      {"convention", c.convention},
                      {"variable", c.variable},
                      {"unit", c.unit},
                      {"range_lo_deg", c.range_lo_deg},
                      {"range_hi_deg", c.range_hi_deg},
                      {"full_turn", c.full_turn},
                      {"coverage_probability", c.coverage_probability},
                      {"coverage_factor", c.coverage_factor},
                      {"angle_deg", c.angle_deg},
                      {"value_" + c.unit, c.value},
                      {"u95_" + c.unit, c.u95},
                      {"pv_" + c.unit, c.pv},
                      {"pv_u95_" + c.unit, c.pv_u95},
                      {"max_angle_deg", c.max_angle_deg},
                      {"min_angle_deg", c.min_angle_deg},
                      {"fitted", c.fitted},
                      {"left_out", left_out},
                      {"averaged", c.averaged},
                      {"models_averaged", c.models_averaged},
                      {"chosen_weight", c.chosen_weight}});
  }
  return curves;
}

json CandidatesJson(const TraceResult& r) {
  json candidates = json::array();
  for (const CandidateScore& c : r.candidates) {
    json kept = json::array();
    for (std::size_t i = 0; i < c.term.components.size(); ++i) kept.push_back(c.term.ParamName(i));
    candidates.push_back({{"id", c.Id()},
                          {"round", c.round},
                          {"delta_bic", NumberOrNull(c.delta_bic)},
                          {"rms_um", c.rms_um},
                          {"cv_rms_um", NumberOrNull(c.cv_rms_um)},
                          {"loso_rms_um", NumberOrNull(c.loso_rms_um)},
                          {"loso_t", NumberOrNull(c.loso_t)},
                          {"components", kept},
                          {"sphere_fraction", c.sphere_fraction},
                          {"added", c.added},
                          {"held", c.held},
                          {"set", c.set},
                          {"set_delta_bic", NumberOrNull(c.set_delta_bic)},
                          {"set_over", c.set_over},
                          {"set_over_delta_bic", NumberOrNull(c.set_over_delta_bic)},
                          {"note", c.note}});
  }
  return candidates;
}

json AmbiguousJson(const TraceResult& r) {
  json ambiguous = json::array();
  for (const Ambiguity& x : r.ambiguous) {
    ambiguous.push_back({{"chosen", x.chosen},
                         {"other", x.other},
                         {"delta_bic_chosen", NumberOrNull(x.delta_bic_chosen)},
                         {"delta_bic_other", NumberOrNull(x.delta_bic_other)},
                         {"sphere_fraction", x.sphere_fraction},
                         {"chosen_rms_um", NumberOrNull(x.chosen_rms_um)},
                         {"other_rms_um", NumberOrNull(x.other_rms_um)},
                         {"form_turns_with_sphere", x.form_turns_with_sphere},
                         {"separate_by", x.separate_by},
                         {"checked", x.checked},
                         {"by_design", x.by_design},
                         {"neither_added", x.neither_added},
                         {"chosen_set", x.chosen_set},
                         {"other_set", x.other_set}});
  }
  return ambiguous;
}

json UnexplainedJson(const TraceResult& r) {
  json unexplained = json::array();
  for (const Unexplained& u : r.unexplained) {
    unexplained.push_back(
        {{"follows", u.variable}, {"rms_um", u.rms_um}, {"p_value", u.p_value}, {"description", u.description}});
  }
  return unexplained;
}

// "sphere_form": the form found (of the setups of known orientation), what the design separates,
// the extended BIC of each degree, and the form of its own of each setup of unknown orientation or on
// another sphere.
json TraceFormJson(const TraceResult& r) {
  const std::vector<SphereFormResult> forms = SphereFormOf(r);
  json form = forms.empty() ? json{{"degree_max", 0}, {"terms", json::array()}, {"confounded", json::array()}}
                            : SphereFormJson(forms.front());
  json scores = json::array();
  for (const auto& [l, d] : r.form.delta_ebic) scores.push_back({{"degree_max", l}, {"delta_ebic", d}});
  form["separable"] = r.form.separable;
  form["known"] = r.form.known;
  form["design"] = r.form.design;
  for (const std::string& c : r.form.confounded) form["confounded"].push_back(c);
  form["delta_ebic"] = scores;
  json unknown = json::array();
  for (std::size_t k = 1; k < forms.size(); ++k) {
    json f = SphereFormJson(forms[k]);
    f["setups"] = forms[k].setup_ids;
    unknown.push_back(f);
  }
  form["own_form"] = unknown;
  return form;
}

json ValidationJson(const Validation& validation) {
  json setups = json::array();
  for (const ValidationSetup& s : validation.setups) {
    setups.push_back({{"setup", s.setup},
                      {"n_points", s.n_points},
                      {"before_ls_sphericity_um", s.before_um},
                      {"after_ls_sphericity_um", s.after_um},
                      {"before_rms_um", s.before_rms_um},
                      {"after_rms_um", s.after_rms_um}});
  }
  const RmsComparison& c = validation.rms;
  return {{"points_file", validation.path},
          {"n_points", validation.n_points},
          {"before_ls_sphericity_um", validation.before_um},
          {"after_ls_sphericity_um", validation.after_um},
          {"before_rms_um", c.before_um},
          {"before_rms_u_um", c.before_u_um},
          {"after_rms_um", c.after_um},
          {"after_rms_u_um", c.after_u_um},
          {"rms_difference_um", c.difference_um},
          {"rms_difference_u_um", c.difference_u_um},
          {"rms_difference_inside_noise", c.inside_noise},
          {"setups", setups},
          {"note", validation.note}};
}

}  // namespace

namespace internal {

void AddTraceJson(json& report, const TraceResult& r, const Validation* validation) {
  json added = json::array();
  for (Effect e : r.added) added.push_back(InfoOf(e).id);
  report["effects_added"] = added;
  json removed = json::array();
  for (const auto& [e, cost] : r.removed) removed.push_back({{"id", InfoOf(e).id}, {"delta_bic", cost}});
  report["effects_removed"] = removed;
  json held = json::array();
  for (Effect e : r.held) held.push_back(InfoOf(e).id);
  report["effects_held"] = held;
  report["before"] = FitJson(r.before);
  report["after"] = FitJson(r.after);
  report["effects"] = EffectsJson(r.after.fit);
  report["error_curves"] = ErrorCurvesJson(r);
  const EffectReference& ref = r.after.fit.model.reference;
  report["effect_reference"] = {{"r_ref_mm", ref.r_ref_mm},
                                {"r_half_range_mm", ref.r_half_range_mm},
                                {"t_start_s", ref.t_start_s},
                                {"t_span_s", ref.t_span_s}};
  report["harmonic_orders_searched"] = {{"theta", r.harmonics.theta}, {"phi", r.harmonics.phi}};
  report["candidates"] = CandidatesJson(r);
  report["ambiguous"] = AmbiguousJson(r);
  report["unexplained"] = UnexplainedJson(r);
  report["sphere_form"] = TraceFormJson(r);
  if (validation) report["validation"] = ValidationJson(*validation);
}

}  // namespace internal

}  // namespace sph
