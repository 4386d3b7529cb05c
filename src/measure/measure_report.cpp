// The text and JSON reports of a measurement (every key: docs/formats/reports.md).
#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

#include "sph/internal/format.hpp"
#include "sph/internal/header_json.hpp"
#include "sph/measure/measure_workflow.hpp"
#include "sph/model/units.hpp"
#include "sph/stats/rounding.hpp"

namespace sph {
namespace {

using nlohmann::json;

using gum::BudgetInput;
using gum::EvaluationType;
using internal::Format;

std::string Vec3Text(const Eigen::Vector3d& v, const char* fmt, double scale = 1.0) {
  return Format(fmt, v.x() * scale) + " " + Format(fmt, v.y() * scale) + " " + Format(fmt, v.z() * scale);
}

json Vec3Json(const Eigen::Vector3d& v, double scale = 1.0) {
  return json::array({v.x() * scale, v.y() * scale, v.z() * scale});
}

void WriteNoiseFloorText(std::ostream& out, const SphereEvaluation& ev, const MeasurementNoiseFloor& r) {
  out << "noise floor of the form values\n";
  if (!r.floor) {
    out << "  " << r.note << "\n\n";
    return;
  }
  const FormNoiseFloor& f = *r.floor;
  out << Format("  sigma_um           %.4f   (%s; %d simulated measurements of pure noise at these directions)\n",
                f.sigma_mm * kUmPerMm, r.sigma_source.c_str(), f.draws);
  auto line = [&](const char* name, double value, double mean, double std) {
    const bool within = FormNoiseFloor::Within(value, mean, std);
    out << Format("  %-18s %.4f +- %.4f   measured %.4f: %s\n", name, mean * kUmPerMm, std * kUmPerMm, value * kUmPerMm,
                  within ? "within the noise (pure noise gives as much)" : "above the noise: a form error");
  };
  line("sphericity_ls_um", ev.sphericity_ls_mm, f.ls_pv_mean_mm, f.ls_pv_std_mm);
  if (std::isfinite(f.mz_mean_mm)) {
    line("sphericity_mz_um", ev.mz.width, f.mz_mean_mm, f.mz_std_mm);
  } else {
    out << "  sphericity_mz_um   not simulated for this many points\n";
  }
  out << Format("  rms_form_um        %.4f   (the residual rms %.4f with the noise's share taken out)\n\n",
                f.rms_form_mm * kUmPerMm, ev.ls.rms * kUmPerMm);
}

json NoiseFloorJson(const SphereEvaluation& ev, const MeasurementNoiseFloor& r) {
  if (!r.floor) return {{"computed", false}, {"note", r.note}};
  const FormNoiseFloor& f = *r.floor;
  auto stat = [&](double value, double mean, double std) -> json {
    if (!std::isfinite(mean)) return nullptr;
    return {{"mean_um", mean * kUmPerMm},
            {"std_um", std * kUmPerMm},
            {"within_noise", FormNoiseFloor::Within(value, mean, std)}};
  };
  return {{"computed", true},
          {"sigma_um", f.sigma_mm * kUmPerMm},
          {"sigma_source", r.sigma_source},
          {"draws", f.draws},
          {"sphericity_ls_um", stat(ev.sphericity_ls_mm, f.ls_pv_mean_mm, f.ls_pv_std_mm)},
          {"sphericity_mz_um", stat(ev.mz.width, f.mz_mean_mm, f.mz_std_mm)},
          {"rms_form_um", f.rms_form_mm * kUmPerMm}};
}

double ReportScale(const BudgetInput& in) { return in.unit.empty() ? kUmPerMm : 1.0; }

void WriteBudgetText(std::ostream& out, const MeasurementBudgets& b, int mc_digits) {
  out << "uncertainty (GUM): each input's contribution |c_i| u(x_i), the combined u, effective degrees of freedom "
         "nu_eff and U = k u, in um\n";
  for (const MeasuredResultBudget& r : b.results) {
    const gum::UncertaintyStatement& st = r.statement;
    const std::string dof = !std::isfinite(st.dof) ? "inf" : st.dof > 1e6 ? ">1e6" : Format("%.0f", st.dof);
    // GUM 7.2.6: U to two significant digits, the value to the same place (the radius in mm, the
    // sphericities in um; u and U in um).
    const bool radius = r.which == MeasuredResult::kRadius;
    const double to_value = radius ? 1.0 : kUmPerMm;
    const gum::RoundedResult stated = gum::RoundResult(r.value_mm * to_value, st.U * to_value);
    out << Format("  %-18s %s   u %s   nu_eff %s   k %.2f   U %s\n", r.name, stated.value_text.c_str(),
                  gum::SignificantText(st.u * kUmPerMm).c_str(), dof.c_str(), st.k,
                  gum::SignificantText(st.U * kUmPerMm).c_str());
    std::string not_stated;
    for (const BudgetInput& in : st.inputs) {
      if (in.type == EvaluationType::kB && in.standard_uncertainty == 0.0) {
        not_stated += (not_stated.empty() ? "" : ", ") + in.name;
        continue;
      }
      std::string detail = in.type == EvaluationType::kA
                               ? (std::isfinite(in.dof) ? Format("A, %.0f degrees of freedom", in.dof) : "A")
                               : "B";
      if (!in.unit.empty()) {
        detail += Format(", u %.4g ", in.standard_uncertainty) + in.unit +
                  Format(", sensitivity %.4g um/", in.sensitivity * kUmPerMm) + in.unit;
      }
      out << Format("    %-44s %-8s (%s)\n", in.name.c_str(),
                    gum::SignificantText(in.Contribution() * kUmPerMm).c_str(), detail.c_str());
    }
    if (!not_stated.empty()) out << "    not stated, taken as exact: " << not_stated << "\n";
    if (r.mc) {
      const gum::PropagationResult& mc = *r.mc;
      const double lo = r.value_mm - st.U, hi = r.value_mm + st.U;
      out << Format(
          "    Monte Carlo check (JCGM 101, adaptive): %ld trials, mean %.4f, u %.4f, %.2f %% interval "
          "[%.4f, %.4f]; tolerance %.4f (%d significant digit%s of u)\n",
          mc.trials, mc.y * kUmPerMm, mc.u * kUmPerMm, 100.0 * st.coverage_probability, mc.low * kUmPerMm,
          mc.high * kUmPerMm, mc.tolerance * kUmPerMm, mc_digits, mc_digits == 1 ? "" : "s");
      if (!mc.converged) {
        out << "    not converged to that tolerance within --mc-max-trials: the comparison is not conclusive\n";
      } else if (gum::GufValidated(r.value_mm, st.U, mc)) {
        out << Format(
            "    the GUM interval [%.4f, %.4f] agrees with it within the tolerance: the linear budget holds\n",
            lo * kUmPerMm, hi * kUmPerMm);
      } else {
        out << Format(
            "    the GUM interval [%.4f, %.4f] does not agree: the statistic is not linear enough; the Monte "
            "Carlo interval is the statement\n",
            lo * kUmPerMm, hi * kUmPerMm);
      }
    } else if (!r.mc_note.empty()) {
      out << "    Monte Carlo check: " << r.mc_note << "\n";
    }
  }
  out << "  sphericities' Type A: " << b.type_a_form_note << "\n";
  out << "  " << gum::CoverageSentence(b.coverage, "result") << "\n\n";
}

json BudgetsJson(const MeasurementBudgets& b, int mc_digits) {
  json j = json::object();
  for (const MeasuredResultBudget& r : b.results) {
    const gum::UncertaintyStatement& st = r.statement;
    json items = json::array();
    for (const BudgetInput& in : st.inputs) {
      items.push_back({{"input", in.name},
                       {"type", in.type == EvaluationType::kA ? "A" : "B"},
                       {"u_input", in.standard_uncertainty * ReportScale(in)},
                       {"input_unit", in.unit.empty() ? std::string("um") : in.unit},
                       {"sensitivity", in.unit.empty() ? in.sensitivity : in.sensitivity * kUmPerMm},
                       {"u_contribution", in.Contribution() * kUmPerMm},
                       {"dof", std::isfinite(in.dof) ? json(in.dof) : json(nullptr)}});
    }
    json e = {{"value", r.which == MeasuredResult::kRadius ? r.value_mm : r.value_mm * kUmPerMm},
              {"value_unit", r.which == MeasuredResult::kRadius ? "mm" : "um"},
              {"unit", "um"},
              {"std", st.inputs.front().standard_uncertainty * kUmPerMm},
              {"u", st.u * kUmPerMm},
              {"U", st.U * kUmPerMm},
              {"k", st.k},
              {"dof", std::isfinite(st.dof) ? json(st.dof) : json(nullptr)},
              {"coverage_probability", st.coverage_probability},
              {"budget", items}};
    if (r.mc) {
      const gum::PropagationResult& mc = *r.mc;
      e["monte_carlo"] = {{"method", "JCGM 101 adaptive"},
                          {"trials", mc.trials},
                          {"mean_um", mc.y * kUmPerMm},
                          {"u_um", mc.u * kUmPerMm},
                          {"low_um", mc.low * kUmPerMm},
                          {"high_um", mc.high * kUmPerMm},
                          {"shortest_low_um", mc.shortest_low * kUmPerMm},
                          {"shortest_high_um", mc.shortest_high * kUmPerMm},
                          {"tolerance_um", mc.tolerance * kUmPerMm},
                          {"significant_digits", mc_digits},
                          {"converged", mc.converged},
                          {"gum_validated", mc.converged && gum::GufValidated(r.value_mm, st.U, mc)}};
    } else if (r.which != MeasuredResult::kRadius) {
      e["monte_carlo"] = {{"note", r.mc_note}};
    }
    j[r.key] = e;
  }
  j["type_a_sphericity"] = b.type_a_form_note;
  j["coverage"] =
      b.coverage.probability > 0.0 ? json{{"probability", b.coverage.probability}} : json{{"k", b.coverage.k}};
  return j;
}

// --- the minimum zone's certificate and starts -----------------------------------------------------

// What the bounds of sph/sphere/sphere_form.hpp say of the zone found, to the evaluation's slack.
void WriteMinimumZoneCheck(std::ostream& out, const MinimumZoneSphere& mz) {
  const double slack_mm = SphereEvaluationOptions().mz_slack_mm;
  const double certified_mm = mz.CertifiedRadius(slack_mm);
  out << (std::isfinite(certified_mm) ? Format("  mz_certified_um    %.4g", certified_mm * kUmPerMm)
                                      : std::string("  mz_certified_um    any"))
      << Format("   (no centre within this distance narrows the zone by more than %.4f um)\n", slack_mm * kUmPerMm);
  if (std::isfinite(mz.near_radius)) {
    out << Format(
        "  mz_near_um         %.4g   (a narrower zone has its centre within this distance, and is then at most "
        "%.4f um narrower, or beyond %.4g mm)\n",
        mz.near_radius * kUmPerMm, mz.MaxDecreaseWithin(mz.near_radius) * kUmPerMm, mz.far_radius);
  } else {
    out << "  mz_near_um         none   (the coverage does not bound where a narrower zone's centre can be)\n";
  }
  if (mz.starts.empty()) return;
  if (mz.StartsAgree()) {
    out << Format(
        "  mz_starts          %.0f searches (the least-squares centre, and displaced along and across the "
        "points' principal directions) all reach it\n",
        static_cast<double>(mz.starts.size()));
    return;
  }
  out << Format(
      "  mz_starts          %.0f searches reach widths from %.4f to %.4f um, centres up to %.4g um apart "
      "(the narrowest is reported):\n",
      static_cast<double>(mz.starts.size()), mz.width * kUmPerMm, (mz.width + mz.StartWidthSpread()) * kUmPerMm,
      mz.StartCenterSpread() * kUmPerMm);
  for (const MinimumZoneStart& s : mz.starts) {
    out << "    from " << Vec3Text(s.start, "%.6f") << "  to " << Vec3Text(s.center, "%.6f")
        << Format("  width_um %.4f", s.width * kUmPerMm) << (s.converged ? "" : "  (not converged)") << "\n";
  }
}

json MinimumZoneCheckJson(const MinimumZoneSphere& mz) {
  const double slack_mm = SphereEvaluationOptions().mz_slack_mm;
  auto finite_or_null = [](double v, double scale) { return std::isfinite(v) ? json(v * scale) : json(nullptr); };
  json check = {{"slack_um", slack_mm * kUmPerMm},
                {"certified_radius_um", finite_or_null(mz.CertifiedRadius(slack_mm), kUmPerMm)},
                {"near_radius_um", finite_or_null(mz.near_radius, kUmPerMm)},
                {"far_radius_mm", finite_or_null(mz.far_radius, 1.0)},
                {"max_decrease_near_um", mz.MaxDecreaseWithin(mz.near_radius) * kUmPerMm},
                {"starts", nullptr}};
  if (!mz.starts.empty()) {
    json runs = json::array();
    for (const MinimumZoneStart& s : mz.starts) {
      runs.push_back({{"start_mm", Vec3Json(s.start)},
                      {"center_mm", Vec3Json(s.center)},
                      {"width_um", s.width * kUmPerMm},
                      {"converged", s.converged}});
    }
    check["starts"] = {{"agree", mz.StartsAgree()},
                       {"width_spread_um", mz.StartWidthSpread() * kUmPerMm},
                       {"center_spread_um", mz.StartCenterSpread() * kUmPerMm},
                       {"runs", runs}};
  }
  return check;
}

// --- reports ------------------------------------------------------------------------------------

}  // namespace

void MeasurementWorkflowResult::WriteTextReport(std::ostream& out) const {
  const MeasurementWorkflowOptions& o = options;
  const MeasuredPoints& in = input;
  const SphereEvaluation& ev = evaluation;
  const std::optional<CalibrationUncertainty>& u = uncertainty;
  const double r = ev.ls.sphere.radius;
  out << Program() << ": " << points_path << "\n  " << in.description << "\n\n";
  if (!in.form_note.empty()) out << "  " << in.form_note << "\n";
  out << "least-squares sphere\n";
  out << "  center_mm          " << Vec3Text(ev.ls.sphere.center, "%.9f") << "\n";
  out << Format("  radius_mm          %.9f   (diameter_mm %.9f)\n", r, 2.0 * r);
  if (in.header_radius) {
    out << Format("  radius_deviation_um %.4f   (from the file's %s %.9g)\n",
                  (r - in.header_radius->radius_mm) * kUmPerMm, in.header_radius->key.c_str(),
                  in.header_radius->radius_mm);
  }
  out << Format("  rms_um             %.4f\n", ev.ls.rms * kUmPerMm);
  out << Format("  sphericity_ls_um   %.4f   (peak to valley of the radial residuals)\n",
                ev.sphericity_ls_mm * kUmPerMm)
      << "\nminimum-zone sphere\n";
  out << Format("  sphericity_mz_um   %.4f   (radial separation of the two enclosing spheres)\n",
                ev.mz.width * kUmPerMm);
  out << "  mz_center_mm       " << Vec3Text(ev.mz.center, "%.9f") << "\n";
  out << Format("  mz_radii_mm        %.9f %.9f   (inner, outer)\n", ev.mz.inner_radius, ev.mz.outer_radius);
  WriteMinimumZoneCheck(out, ev.mz);
  out << "\n";
  WriteNoiseFloorText(out, ev, noise_floor);
  out << "coverage\n";
  out << Format("  cap_half_angle_deg %.1f   (90: a hemisphere, near 180: the whole sphere)\n",
                ev.coverage.cap_half_angle_deg);
  out << Format("  radius_dilution    %.3g   center_dilution %.3g   (1: points over the whole sphere; limit %g)\n",
                ev.radius_dilution, ev.center_dilution, o.max_dilution);
  out << Format("  radius_fit_std_um  %.4f   (from the scatter of the points, form counted as noise)\n",
                ev.radius_fit_std_mm * kUmPerMm);
  out << "  center_fit_std_um  " << Vec3Text(ev.center_fit_std_mm, "%.4f", kUmPerMm) << "\n\n";
  if (u) {
    out << "uncertainty from the calibration's covariance (sampling: " << u->samples << " draws, seed " << u->seed
        << ")\n";
    out << Format("  radius_std_um            %.4f\n", u->radius_std_mm * kUmPerMm);
    out << "  center_std_um            " << Vec3Text(u->center_std_mm, "%.4f", kUmPerMm) << "\n";
    out << Format("  sphericity_ls_std_um     %.4f\n  sphericity_mz_std_um     %.4f\n",
                  u->sphericity_ls_std_mm * kUmPerMm, u->sphericity_mz_std_mm * kUmPerMm);
    out << Format(
        "  calibration_form_p95_um  %.4f   (form error the calibration's uncertainty alone produces in 95 %% "
        "of draws)\n",
        u->calibration_form_p95_mm * kUmPerMm);
    out << Format(u->form_exceeds_calibration
                      ? "  the form error (sphericity_ls %.4f um) exceeds it: it is in the measurement (the part's "
                        "form or "
                        "the probe's noise, which the noise floor tells apart), not an artefact of the calibration\n"
                      : "  the form error (sphericity_ls %.4f um) is within it: it may be an artefact of the "
                        "calibration's uncertainty\n",
                  ev.sphericity_ls_mm * kUmPerMm)
        << "\n";
  } else {
    out << "uncertainty from the calibration: " << uncertainty_note << "\n\n";
  }
  if (!in.covariance_note.empty()) out << "  note: " << in.covariance_note << "\n\n";
  WriteBudgetText(out, budgets, o.mc_digits);
  if (ev.warnings.empty()) {
    out << "warnings: none\n";
  } else {
    out << "warnings:\n";
    for (const auto& w : ev.warnings) out << "  - " << w << "\n";
  }
}

std::string MeasurementWorkflowResult::JsonReport() const {
  const MeasurementWorkflowOptions& o = options;
  const MeasuredPoints& in = input;
  const SphereEvaluation& ev = evaluation;
  const std::optional<CalibrationUncertainty>& u = uncertainty;
  json j;
  j["created_by"] = Program();
  j["input"] = {{"points_file", points_path},
                {"format", o.xyz ? "xyz" : "sph-points 1"},
                {"calibration_file", o.calibration_path.empty() ? json(nullptr) : json(o.calibration_path)},
                {"setup", in.setup ? json(*in.setup) : json(nullptr)},
                {"n_points", ev.n_points}};
  j["metadata"] = internal::MetadataJson(in.metadata);
  j["devices"] = internal::DevicesJson(in.metadata);
  j["center_mm"] = Vec3Json(ev.ls.sphere.center);
  j["radius_mm"] = ev.ls.sphere.radius;
  j["diameter_mm"] = 2.0 * ev.ls.sphere.radius;
  if (in.header_radius) {
    j["header_sphere_radius_mm"] = in.header_radius->radius_mm;
    j["header_sphere_radius_key"] = in.header_radius->key;
    j["radius_deviation_um"] = (ev.ls.sphere.radius - in.header_radius->radius_mm) * kUmPerMm;
  }
  j["rms_um"] = ev.ls.rms * kUmPerMm;
  j["sphericity_ls_um"] = ev.sphericity_ls_mm * kUmPerMm;
  j["sphericity_mz_um"] = ev.mz.width * kUmPerMm;
  j["noise_floor"] = NoiseFloorJson(ev, noise_floor);
  j["mz_center_mm"] = Vec3Json(ev.mz.center);
  j["mz_inner_radius_mm"] = ev.mz.inner_radius;
  j["mz_outer_radius_mm"] = ev.mz.outer_radius;
  j["mz_check"] = MinimumZoneCheckJson(ev.mz);
  j["fit"] = {{"ls_iterations", ev.ls.iterations},
              {"ls_converged", ev.ls.converged},
              {"mz_iterations", ev.mz.iterations},
              {"mz_converged", ev.mz.converged}};
  j["coverage"] = {{"cap_half_angle_deg", ev.coverage.cap_half_angle_deg},
                   {"mean_direction", Vec3Json(ev.coverage.mean_direction)},
                   {"radius_dilution", ev.radius_dilution},
                   {"center_dilution", ev.center_dilution},
                   {"max_dilution", o.max_dilution},
                   {"radius_fit_std_um", ev.radius_fit_std_mm * kUmPerMm},
                   {"center_fit_std_um", Vec3Json(ev.center_fit_std_mm, kUmPerMm)},
                   {"ill_posed", ev.poorly_determined}};
  if (u) {
    j["uncertainty"] = {{"method", "sampling"},
                        {"samples", u->samples},
                        {"seed", u->seed},
                        {"radius_std_um", u->radius_std_mm * kUmPerMm},
                        {"center_std_um", Vec3Json(u->center_std_mm, kUmPerMm)},
                        {"sphericity_ls_std_um", u->sphericity_ls_std_mm * kUmPerMm},
                        {"sphericity_mz_std_um", u->sphericity_mz_std_mm * kUmPerMm},
                        {"calibration_form_p95_um", u->calibration_form_p95_mm * kUmPerMm},
                        {"form_exceeds_calibration", u->form_exceeds_calibration}};
  } else {
    j["uncertainty"] = nullptr;
    j["uncertainty_note"] = uncertainty_note;
  }
  j["budget"] = BudgetsJson(budgets, o.mc_digits);
  if (u) {
    j["uncertainty"]["parameters"] = in.applied->names;
    j["uncertainty"]["note"] = in.covariance_note;
  }
  j["sphere_form"] =
      in.form_note.empty() ? json(nullptr) : json{{"note", in.form_note}, {"subtracted", o.subtract_sphere_form}};
  j["warnings"] = ev.warnings;
  return j.dump(2) + "\n";
}

}  // namespace sph
