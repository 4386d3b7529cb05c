#include "calibrate_trace.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>
#include <utility>

#include "gnuplot.hpp"
#include "sph/calib/form_report.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"
#include "sph/sphere/sphere_fit.hpp"
#include "sph/sphere/sphere_form.hpp"

namespace sph::apps {
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

json FitJson(const TracedFit& f) {
  json structure = json::object();
  for (const StructureGroup& g : f.structure.groups) structure[g.variable] = GroupJson(g);
  structure["all"] = GroupJson(f.structure.all);
  return {{"rms_um", f.fit.calibration.rms_um},
          {"pv_um", f.fit.calibration.pv_um},
          {"cv_rms_um", f.cv_rms_um},
          {"loso_rms_um", NumberOrNull(f.loso_rms_um)},
          {"structure_p_value", f.structure.all.p_value},
          {"structure", structure},
          {"theta_harmonics_um", f.structure.theta_harmonics_um},
          {"n_params", f.fit.n_params},
          {"bic", f.fit.Bic()}};
}

json SphereFormJson(const SphereFormResult& f) {
  json terms = json::array();
  for (const FormTermValue& t : f.terms) {
    terms.push_back({{"l", t.l}, {"m", t.m}, {"value_um", t.value_um}, {"std_um", NumberOrNull(t.std_um)}});
  }
  return {{"degree_max", f.degree_max}, {"rms_um", f.rms_um}, {"rms_std_um", NumberOrNull(f.rms_std_um)},
          {"pv_um", f.pv_um},           {"terms", terms},     {"confounded", f.confounded}};
}

void WriteSphereFormText(std::ostream& out, const SphereFormResult& f) {
  const std::string which = f.setups.empty() ? "" : " of setup " + f.setups.substr(1) + " (unknown orientation)";
  out << Format("  sphere form%s: degrees 2..%d, rms %.4f +- %.4f um, peak to valley %.4f um over the whole sphere\n",
                which.c_str(), f.degree_max, f.rms_um, f.rms_std_um, f.pv_um);
  out << "    (Schmidt semi-normalised harmonics S(l,m) of the sphere's body frame, |S| <= 1, mean square 1/(2l+1); "
         "radial displacement of the surface)\n";
  std::string line;
  int on_line = 0;
  for (const FormTermValue& t : f.terms) {
    line += Format("    S(%d,%d) %+.4f +- %.4f", t.l, t.m, t.value_um, t.std_um);
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

bool AddEffectsToCalibrationFile(const EffectFit& fit, CalibrationFile& file) {
  bool drift = false;
  file.effects.reference = fit.model.reference;
  file.effects.phi_wobble_pivot_mm = fit.model.phi_wobble_pivot_mm;
  for (std::size_t t = 0; t < fit.model.terms.size(); ++t) {
    if (fit.model.terms[t].effect == Effect::kProbeDrift) {
      drift = true;
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

Validation Validate(const std::string& path, double probe_offset_mm, const TraceResult& trace) {
  const PointsData data = ReadPointsFile(path);
  Validation v;
  v.path = path;
  v.n_points = static_cast<int>(data.samples.size());
  // The machine's model without probe_drift, which belongs to the calibration run.
  const EffectFit& after = trace.after.fit;
  EffectModel model;
  model.reference = after.model.reference;
  model.phi_wobble_pivot_mm = after.model.phi_wobble_pivot_mm;
  std::vector<std::vector<double>> values;
  for (std::size_t t = 0; t < after.model.terms.size(); ++t) {
    if (after.model.terms[t].effect == Effect::kProbeDrift) {
      v.note = "probe_drift is not applied: a drift belongs to the run it was measured in";
      continue;
    }
    model.terms.push_back(after.model.terms[t]);
    values.push_back(after.values[t]);
  }
  // Each setup is a sphere position of its own: one least-squares sphere each.
  std::map<int, std::pair<std::vector<Eigen::Vector3d>, std::vector<Eigen::Vector3d>>> points;
  std::map<int, std::vector<EffectReading>> readings;
  const ScmsGeometry& g0 = trace.before.fit.calibration.geometry;
  for (const Sample& s : data.samples) {
    const EffectReading x(s.theta_deg, s.phi_deg, s.r_mm, s.t_s);
    auto& [before_pts, after_pts] = points[s.setup];
    before_pts.push_back(ScmsPoint(g0, x.theta_rad, x.phi_rad, s.r_mm, probe_offset_mm));
    after_pts.push_back(EffectScmsPoint(after.calibration.geometry, model, values, x, probe_offset_mm));
    readings[s.setup].push_back(x);
  }
  // A probe_incidence term needs the sphere's centre: that of the points without it, then again.
  for (int pass = 0; pass < 2 && model.Find(Effect::kProbeIncidence) >= 0; ++pass) {
    for (auto& [setup, pts] : points) {
      const LeastSquaresSphere fit = FitSphereLeastSquares(pts.second);
      if (!fit.sphere.ok) break;
      const std::vector<EffectReading>& xs = readings[setup];
      for (std::size_t i = 0; i < xs.size(); ++i) {
        pts.second[i] =
            EffectScmsPoint(after.calibration.geometry, model, values, xs[i], probe_offset_mm, &fit.sphere.center);
      }
    }
  }
  for (const auto& [setup, pts] : points) {
    ValidationSetup vs;
    vs.setup = setup;
    vs.n_points = static_cast<int>(pts.first.size());
    try {
      std::tie(vs.before_um, vs.before_rms_um) = LsSphericityUm(pts.first);
      std::tie(vs.after_um, vs.after_rms_um) = LsSphericityUm(pts.second);
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
  out << "\nclosing the loop (residual traced to effects the seven-error model lacks)\n";
  out << Format("  %-34s %10s %10s %10s %12s\n", "", "rms um", "p-v um", "cv rms um", "structure p");
  out << Format("  %-34s %10.4f %10.4f %10.4f %12.2g\n", "before (seven errors)", b.fit.calibration.rms_um,
                b.fit.calibration.pv_um, b.cv_rms_um, b.structure.all.p_value);
  std::string added;
  for (Effect e : r.added) added += (added.empty() ? "" : " + ") + std::string(InfoOf(e).id);
  out << Format("  %-34s %10.4f %10.4f %10.4f %12.2g\n",
                ("after" + (added.empty() ? "" : " (+ " + added + ")")).c_str(), a.fit.calibration.rms_um,
                a.fit.calibration.pv_um, a.cv_rms_um, a.structure.all.p_value);
  if (std::isfinite(b.loso_rms_um) && std::isfinite(a.loso_rms_um)) {
    out << Format(
        "  leave one setup out (each setup of known orientation predicted from the others, its centre "
        "refitted): rms %.4f um before, %.4f um after\n",
        b.loso_rms_um, a.loso_rms_um);
  }
}

// The structure of the residual before the trace, by variable and in harmonics of theta.
void WriteStructure(std::ostream& out, const TraceResult& r) {
  const TracedFit& b = r.before;
  out << "  structure before, by variable (F test against white noise):\n";
  for (const StructureGroup& g : b.structure.groups) {
    out << Format("    %-7s explains %.4f um rms, p = %.2g, strongest %s (%.4f um rms alone)\n", g.variable.c_str(),
                  g.explained_rms_um, g.p_value, g.strongest.c_str(), g.strongest_rms_um);
  }
  out << "  harmonics of theta before, amplitude fitted alone [um]:";
  for (std::size_t k = 0; k < b.structure.theta_harmonics_um.size(); ++k) {
    out << Format(" %zu: %.4f", k + 1, b.structure.theta_harmonics_um[k]);
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
      out << Format("    %-30s %12.5f +- %.5f %s\n", term.ParamName(i).c_str(), a.fit.values[t][i] * u.per_internal,
                    rep.Empty() ? std::nan("") : rep.std(col) * u.per_internal, u.name);
    }
  }
  for (const auto& [e, cost] : r.removed) {
    out << Format("  removed in the backward step: %s (the final model without it: delta BIC %+.1f)\n", InfoOf(e).id,
                  cost);
  }
}

// The sphere form: what the design separates, the degree chosen, the form found, the reference of
// the probe and time terms.
void WriteForm(std::ostream& out, const TraceResult& r) {
  const TracedFit& a = r.after;
  out << "  sphere form: " << r.form.design << "\n";
  for (const std::string& c : r.form.confounded) out << "    confounded by the design: " << c << "\n";
  if (r.form.separable) {
    std::string scores;
    for (const auto& [l, d] : r.form.delta_ebic) scores += Format(" %d: %.1f", l, d);
    out << "    extended BIC of the form of degrees 2..L against none, L =" << scores << "; chosen: "
        << (r.form.degree_max > 0 ? "degrees 2.." + std::to_string(r.form.degree_max) : std::string("no form")) << "\n";
  }
  for (const SphereFormResult& f : SphereFormOf(a.fit)) WriteSphereFormText(out, f);
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
      out << "  two explanations, neither added: a pattern fixed on the sphere, the sphere's own form"
          << Format(" (%.4f um rms), or %s (%.4f um rms), which its own variable shows but no more than a form would; ",
                    x.chosen_rms_um, x.other.c_str(), x.other_rms_um)
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
    } else {
      out << "  ambiguous: " << x.other << " explains the residual about as well as " << x.chosen
          << Format(" (delta BIC %.1f against %.1f); to separate them: ", x.delta_bic_other, x.delta_bic_chosen)
          << x.separate_by << "\n";
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
    }
    effects.push_back({{"id", term.info().id},
                       {"iso_name", term.info().iso_name},
                       {"description", term.info().description},
                       {"parameters", params}});
  }
  return effects;
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
                         {"checked", x.checked}});
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
// the extended BIC of each degree, and the form of each setup of unknown orientation.
json TraceFormJson(const TraceResult& r) {
  const std::vector<SphereFormResult> forms = SphereFormOf(r.after.fit);
  json form = forms.empty() ? json{{"degree_max", 0}, {"terms", json::array()}, {"confounded", json::array()}}
                            : SphereFormJson(forms.front());
  json scores = json::array();
  for (const auto& [l, d] : r.form.delta_ebic) scores.push_back({{"degree_max", l}, {"delta_ebic", d}});
  form["separable"] = r.form.separable;
  form["design"] = r.form.design;
  for (const std::string& c : r.form.confounded) form["confounded"].push_back(c);
  form["delta_ebic"] = scores;
  json unknown = json::array();
  for (std::size_t k = 1; k < forms.size(); ++k) {
    json f = SphereFormJson(forms[k]);
    f["setup"] = std::stoi(forms[k].setups.substr(1));
    unknown.push_back(f);
  }
  form["unknown_orientation"] = unknown;
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

void AddTraceJson(json& report, const TraceResult& r, const Validation* validation) {
  json added = json::array();
  for (Effect e : r.added) added.push_back(InfoOf(e).id);
  report["effects_added"] = added;
  json removed = json::array();
  for (const auto& [e, cost] : r.removed) removed.push_back({{"id", InfoOf(e).id}, {"delta_bic", cost}});
  report["effects_removed"] = removed;
  report["before"] = FitJson(r.before);
  report["after"] = FitJson(r.after);
  report["effects"] = EffectsJson(r.after.fit);
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

void PlotTrace(const std::string& dir, const PointsData& points, const CalibrationOptions& options,
               const TraceResult& r, OutputFiles& files) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw Error(dir + ": cannot create the folder: " + ec.message());
  const std::string folder = dir + "/";
  // Every reading under each model (outliers too: they show at the end of the colour scale).
  const std::vector<double> before = EffectResiduals(points, options, r.before.fit);
  const std::vector<double> after = EffectResiduals(points, options, r.after.fit);
  files.Stage(folder + "residuals.dat", [&](std::ostream& f) {
    f << "# theta_deg phi_deg t_s residual_before_um residual_after_um\n";
    for (std::size_t i = 0; i < points.samples.size(); ++i) {
      const Sample& s = points.samples[i];
      f << Format("%.6f %.6f %.6f %.6f %.6f\n", s.theta_deg, s.phi_deg, s.t_s, before[i] * kUmPerMm,
                  after[i] * kUmPerMm);
    }
  });
  // The colour scale of the readings the seven-error fit used (at least 1 nm).
  double lim = 1e-3;
  for (double e : r.before.fit.calibration.residuals_mm) lim = std::max(lim, std::abs(e) * kUmPerMm);
  std::string added;
  for (Effect e : r.added) added += (added.empty() ? " + " : ", ") + std::string(InfoOf(e).id);
  std::ostringstream script;
  script << "# Residual plots of sph_calibrate; rerun with: gnuplot residuals.gp (in this folder)\n"
         << "if (!exists(\"data\")) data = 'residuals.dat'\n"
         << "if (!exists(\"map_png\")) map_png = 'residual_map.png'\n"
         << "if (!exists(\"time_png\")) time_png = 'residual_time.png'\n"
         << "set terminal pngcairo size 1400,560 noenhanced font ',11'\n"
         << "set output map_png\n"
         << "set multiplot layout 1,2 title 'Residual |p - O| - R0 [um] over theta and phi'\n"
         << "set xlabel 'theta [deg]'\nset ylabel 'phi [deg]'\nset xrange [0:360]\nset yrange [180:0]\n"
         << "set palette defined (-1 'blue', 0 'white', 1 'red')\n"
         << Format("set cbrange [%.6f:%.6f]\n", -lim, lim) << "set cblabel 'um'\n"
         << Format("set title 'before: seven errors, rms %.4f um'\n", r.before.fit.calibration.rms_um)
         << "plot data using 1:2:4 with points pt 5 ps 2.2 lc palette notitle\n"
         << "set title "
         << GnuplotQuoted(Format("after: seven errors%s, rms %.4f um", added.c_str(), r.after.fit.calibration.rms_um))
         << "\n"
         << "plot data using 1:2:5 with points pt 5 ps 2.2 lc palette notitle\n"
         << "unset multiplot\n"
         << "set output time_png\nset size 1,1\nset autoscale\nset yrange [*:*]\n"
         << "set title 'Residual against acquisition time'\nset xlabel 't [s]'\nset ylabel 'residual [um]'\n"
         << "set key top left\n"
         << "plot data using 3:4 with points pt 7 ps 0.6 lc rgb '#c03030' title 'before', "
            "data using 3:5 with points pt 7 ps 0.6 lc rgb '#3050c0' title 'after'\n";
  files.Stage(folder + "residuals.gp", [&](std::ostream& f) { f << script.str(); });
  // gnuplot reads the staged data and draws into the staged images, by their names in the folder.
  const auto name_in_folder = [](const std::string& path) { return path.substr(path.find_last_of('/') + 1); };
  GnuplotRun run;
  run.folder = dir;
  run.script = script.str();
  run.description = "the residual plots";
  run.variables = {{"data", name_in_folder(files.StagedName(folder + "residuals.dat"))},
                   {"map_png", name_in_folder(files.StageProduced(folder + "residual_map.png"))},
                   {"time_png", name_in_folder(files.StageProduced(folder + "residual_time.png"))}};
  RunGnuplot(run, "--plot-dir " + dir);
  // The sphere's form, when the trace separated it: a map over its body frame.
  const std::vector<SphereFormResult> forms = SphereFormOf(r.after.fit);
  if (forms.empty()) return;
  const SphereFormResult& form = forms.front();
  const std::vector<std::array<double, 3>> map = FormMap(r.after.fit, 0, 1.0);
  double form_lim = 1e-6;
  for (const auto& row : map) form_lim = std::max(form_lim, std::abs(row[2]));
  files.Stage(folder + "sphere_form.dat", [&](std::ostream& f) {
    f << "# the calibration sphere's form on its body frame: longitude_deg polar_deg form_um\n";
    for (const auto& row : map) f << Format("%.1f %.1f %.6f\n", row[1], row[0], row[2]);
  });
  std::ostringstream form_script;
  form_script << "# The sphere's form map of sph_calibrate; rerun with: gnuplot sphere_form.gp (in this folder)\n"
              << "if (!exists(\"data\")) data = 'sphere_form.dat'\n"
              << "if (!exists(\"png\")) png = 'sphere_form_map.png'\n"
              << "set terminal pngcairo size 1100,600 noenhanced font ',11'\nset output png\n"
              << "set title "
              << GnuplotQuoted(Format("Form of the calibration sphere on its body frame, degrees 2..%d: rms %.4f +- "
                                      "%.4f um, peak to valley %.4f um",
                                      form.degree_max, form.rms_um, form.rms_std_um, form.pv_um))
              << "\n"
              << "set xlabel 'longitude [deg] (from the body x axis)'\nset ylabel 'polar angle [deg] (from the body z "
                 "axis)'\n"
              << "set xrange [0:360]\nset yrange [180:0]\nset palette defined (-1 'blue', 0 'white', 1 'red')\n"
              << Format("set cbrange [%.6f:%.6f]\n", -form_lim, form_lim)
              << "set cblabel 'radial form [um]'\nplot data using 1:2:3 with image notitle\n";
  files.Stage(folder + "sphere_form.gp", [&](std::ostream& f) { f << form_script.str(); });
  GnuplotRun form_run;
  form_run.folder = dir;
  form_run.script = form_script.str();
  form_run.description = "the sphere's form map";
  form_run.variables = {{"data", name_in_folder(files.StagedName(folder + "sphere_form.dat"))},
                        {"png", name_in_folder(files.StageProduced(folder + "sphere_form_map.png"))}};
  RunGnuplot(form_run, "--plot-dir " + dir);
}

}  // namespace sph::apps
