// The calibration's HTML report: rendered from the JSON report (the numbers are the JSON's, the
// form map drawn from its coefficients), with the residual map from the reported fit's residuals
// and the error curves' figures from the result's curves (their marked points the JSON's).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "sph/calib/calibrate_workflow.hpp"
#include "sph/internal/format.hpp"
#include "sph/internal/html_json.hpp"
#include "sph/io/html_report.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/units.hpp"
#include "sph/stats/rounding.hpp"

namespace sph {

namespace {

using nlohmann::json;
using html::Escape;
using html::Section;
std::string Cell(const json& v) { return html::JsonText(v); }

std::string At(const json& j, const char* key) { return html::JsonField(j, key); }
std::string List(const json& items) { return html::JsonList(items); }

std::string Identification(const json& j, const CalibrationWorkflowResult& run) {
  std::vector<std::vector<std::string>> rows = {
      {"points file", At(j, "points_file")},
      {"program", At(j, "program")},
      {"report made", Escape(html::UtcNow())},
      {"readings", internal::Format("%zu", run.points.samples.size())},
      {"R0 [mm]", At(j, "sphere_radius_mm")},
      {"d (nominal) [mm]", At(j, "probe_offset_mm")},
  };
  return html::Table({"item", "value"}, rows) + html::HeaderTables(j);
}

std::string Method(const json& j, const CalibrationWorkflowResult& run) {
  const json& fit = j.at("fit");
  std::string body = "<p>The seven geometric errors of the SCMS model fitted by least squares to the readings' "
                     "distances from the sphere";
  body += run.Extended() ? ", the residual traced to the effects the model lacks (selection by BIC and "
                           "cross-validation).</p>\n"
                         : ".</p>\n";
  std::vector<std::vector<std::string>> rows = {
      {"setups (placements)", At(fit, "n_setups")},
      {"readings fitted", At(fit, "n_points")},
      {"converged", At(fit, "converged")},
      {"iterations", At(fit, "iterations")},
      {"condition number", At(fit, "condition_number")},
  };
  if (j.contains("harmonic_orders_searched")) {
    const json& h = j.at("harmonic_orders_searched");
    rows.push_back({"harmonic orders searched (theta, phi)", At(h, "theta") + ", " + At(h, "phi")});
  }
  for (const auto& [setup, rotation] : run.points.header.mount_rotations) {
    std::string text = "unknown";
    if (rotation.known()) {
      text = html::Number((*rotation.rotation_deg)(0)) + " " + html::Number((*rotation.rotation_deg)(1)) + " " +
             html::Number((*rotation.rotation_deg)(2));
    }
    rows.push_back({internal::Format("mount rotation of setup %d [deg]", setup), text});
  }
  return body + html::Table({"item", "value"}, rows);
}

// Where an input not stated would be given: the key in its note's last parentheses ("not stated:
// R0 taken as exact (sphere_radius_u_um)").
std::string StatedBy(const json& in) {
  const std::string note = in.value("note", "");
  const std::size_t close = note.rfind(')'), open = note.rfind('(', close);
  return close == std::string::npos || open == std::string::npos ? "" : note.substr(open + 1, close - open - 1);
}

// Whether an uncertainty input was stated (a Type B input of u 0 was not: taken as exact).
bool Stated(const json& in) { return in.value("type", "") == "A" || in.value("u", 0.0) > 0.0; }

// The inputs not stated, in one line: "R0 (certificate) (sphere_radius_u_um), ...".
std::string NotStated(const json& j) {
  std::string names;
  for (const json& in : j.value("uncertainty_inputs", json::array())) {
    if (Stated(in)) continue;
    const std::string key = StatedBy(in);
    names += (names.empty() ? "" : ", ") + Cell(in.at("input")) +
             (key.empty() ? "" : " (<span class=\"nw\">" + Escape(key) + "</span>)");
  }
  return names.empty() ? "" : "<p>Not stated, taken as exact: " + names + ".</p>\n";
}

std::string Conditions(const json& j) {
  std::vector<std::vector<std::string>> rows;
  for (const json& in : j.value("uncertainty_inputs", json::array())) {
    if (!Stated(in)) continue;
    const std::string unit = in.contains("unit") ? " [" + Cell(in.at("unit")) + "]" : "";
    rows.push_back({Cell(in.at("input")) + unit, At(in, "type"), in.contains("u") ? Cell(in.at("u")) : "-",
                    in.contains("dof") && in.at("dof").is_number()
                        ? internal::Format("%.0f", in.at("dof").get<double>())
                        : "-",
                    in.contains("note") ? Cell(in.at("note")) : ""});
  }
  return html::Table({"input", "type", "u", "degrees of freedom", "note"}, rows) + NotStated(j);
}

// The report unit of a JSON unit, and the factor to it: deg to urad, mm to um, others as they are.
std::pair<std::string, double> Fine(const std::string& unit) {
  if (unit == "deg") return {"urad", kUradPerRad * kRadPerDeg};
  if (unit == "mm") return {"um", kUmPerMm};
  return {unit, 1.0};
}

// Whether a parameter is a centre of the sphere ("center_x", "center_x@1").
bool Centre(const std::string& name) { return name.rfind("center_", 0) == 0; }

// The effective degrees of freedom as the text report prints them: whole, ">1e6", "inf".
std::string Dof(const json& p) {
  if (!p.contains("dof") || !p.at("dof").is_number()) return "inf";
  const double dof = p.at("dof").get<double>();
  return dof > 1e6 ? ">1e6" : internal::Format("%.0f", dof);
}

// A parameter's ISO 230 name, or a dash and where the model names it.
std::string IsoName(const json& p) {
  const std::string iso = p.value("iso_name", "");
  return iso.empty() ? "&mdash;, see the model page" : "<span class=\"words\">" + Escape(iso) + "</span>";
}

// The seven errors as GUM 7.2.6 states them: U to two significant digits, the value to the same
// place, in urad and um.
std::string ErrorsTable(const json& j) {
  std::vector<std::vector<std::string>> rows;
  for (const json& name : j.at("parameter_order")) {
    const std::string key = name.get<std::string>();
    if (Centre(key)) continue;  // the sphere's centres: in the JSON
    const json& p = j.at("parameters").at(key);
    const auto [unit, to_fine] = Fine(p.value("unit", ""));
    const double value = p.value("value", std::nan("")) * to_fine;
    std::vector<std::string> row = {Escape(key), IsoName(p)};
    if (p.contains("held")) {
      row.insert(row.end(), {gum::RoundResult(value, 0.0).value_text, At(p, "held"), "", "", "", Escape(unit)});
    } else if (!p.value("determined", true) || !p.contains("U") || !p.at("U").is_number()) {
      const double u =
          p.contains("std") && p.at("std").is_number() ? p.at("std").get<double>() * to_fine : std::nan("");
      const gum::RoundedResult r = gum::RoundResult(value, u);
      row.insert(row.end(), {p.value("determined", true) ? r.value_text : "undetermined", r.uncertainty_text, "-", "-",
                             "-", Escape(unit)});
    } else {
      const double u = p.at("u").get<double>() * to_fine, U = p.at("U").get<double>() * to_fine;
      const gum::RoundedResult r = gum::RoundResult(value, U);
      row.insert(row.end(), {r.value_text, gum::SignificantText(u), r.uncertainty_text,
                             html::Fixed(p.value("k", 0.0), 2), Dof(p), Escape(unit)});
    }
    rows.push_back(row);
  }
  return html::Table({"parameter", "ISO 230 name", "value", "u", "U = k u", "k", "degrees of freedom", "unit"}, rows) +
         "<p class=\"note\">GUM 7.2.6: U to two significant digits, the value to the same decimal place (the JSON "
         "report and the calibration file hold every digit). u: standard uncertainty; U: expanded uncertainty "
         "with coverage factor k. The sphere's centres of each setup are in the JSON report.</p>\n";
}

// The budget of one group of parameters (the angles, the lengths), in their fine unit: each stated
// input's contribution |c_i| u(x_i) with its sensitivity c_i, u, nu_eff, k, U.
std::string BudgetTable(const json& j, const std::string& group_unit) {
  std::vector<std::string> inputs;  // the stated inputs, in the budget's order
  for (const json& in : j.value("uncertainty_inputs", json::array())) {
    if (Stated(in)) inputs.push_back(in.at("input").get<std::string>());
  }
  std::vector<std::vector<std::string>> rows;
  for (const json& name : j.at("parameter_order")) {
    const json& p = j.at("parameters").at(name.get<std::string>());
    if (Centre(name.get<std::string>()) || !p.contains("budget")) continue;
    const auto [unit, to_fine] = Fine(p.value("unit", ""));
    if (unit != group_unit) continue;
    std::vector<std::string> row = {Escape(name.get<std::string>())};
    for (const std::string& input : inputs) {
      std::string cell = "-";
      for (const json& b : p.at("budget")) {
        if (b.at("input") != input) continue;
        cell = gum::SignificantText(b.value("u_contribution", 0.0) * to_fine);
        if (b.value("type", "") == "B") {
          cell += "<br><span class=\"note nw\">c = " + gum::SignificantText(b.value("sensitivity", 0.0) * to_fine, 3) +
                  " " + Escape(unit) + "/" + Cell(b.at("input_unit")) + "</span>";
        }
        break;
      }
      row.push_back(cell);
    }
    row.insert(row.end(), {gum::SignificantText(p.value("u", 0.0) * to_fine), Dof(p),
                           html::Fixed(p.value("k", 0.0), 2), gum::SignificantText(p.value("U", 0.0) * to_fine)});
    rows.push_back(row);
  }
  if (rows.empty()) return "";
  std::vector<std::string> header = {"parameter"};
  for (const std::string& input : inputs) header.push_back(Escape(input));
  header.insert(header.end(), {"u", "degrees of freedom", "k", "U"});
  return "<h4>" + std::string(group_unit == "urad" ? "The angles" : "The lengths") + " [" + Escape(group_unit) +
         "]</h4>\n" + html::Table(header, rows);
}

std::string Errors(const json& j) {
  std::string body = ErrorsTable(j);
  const std::string angles = BudgetTable(j, "urad"), lengths = BudgetTable(j, "um");
  if (angles.empty() && lengths.empty()) return body;
  return body +
         "<h3>Uncertainty budget</h3>\n<p class=\"note\">Each stated input's contribution |c<sub>i</sub>| "
         "u(x<sub>i</sub>) to u, two significant digits, with its sensitivity c<sub>i</sub> under it.</p>\n" +
         angles + lengths + NotStated(j);
}

// A RMS or a peak to valley of the JSON, in um, to 0.1 nm.
std::string Um(const json& j, const char* key) {
  return j.contains(key) && j.at(key).is_number() ? html::Fixed(j.at(key).get<double>(), 4) : "-";
}

std::string Effects(const json& j) {
  std::vector<std::vector<std::string>> rows;
  for (const json& e : j.value("effects", json::array())) {
    for (const json& p : e.at("parameters")) {
      const double u = p.contains("std") && p.at("std").is_number() ? p.at("std").get<double>() : std::nan("");
      const gum::RoundedResult r = gum::RoundResult(p.value("value", std::nan("")), u);
      rows.push_back({At(e, "id"), IsoName(e), At(p, "name"), r.value_text, r.uncertainty_text, At(p, "unit")});
    }
  }
  std::string body = rows.empty() ? "<p>No effect beyond the seven errors.</p>\n"
                                  : html::Table({"effect", "ISO 230 name", "parameter", "value", "u", "unit"}, rows) +
                                        "<p class=\"note\">u to two significant digits, the value to the same "
                                        "place.</p>\n";
  if (j.contains("before") && j.contains("after")) {
    const json &b = j.at("before"), &a = j.at("after");
    body += "<h3>Before and after</h3>\n";
    body += html::Table({"residual", "seven errors", "with the effects"},
                        {{"rms [um]", Um(b, "rms_um"), Um(a, "rms_um")},
                         {"peak to valley [um]", Um(b, "pv_um"), Um(a, "pv_um")},
                         {"cross-validated rms [um]", Um(b, "cv_rms_um"), Um(a, "cv_rms_um")},
                         {"leave-one-setup-out rms [um]", Um(b, "loso_rms_um"), Um(a, "loso_rms_um")},
                         {"parameters", At(b, "n_params"), At(a, "n_params")}});
  }
  if (j.contains("validation")) {
    const json& v = j.at("validation");
    body += "<h3>Validation on " + At(v, "points_file") + "</h3>\n";
    body += html::Table(
        {"validation file", "before", "after"},
        {{"rms [um]", Um(v, "before_rms_um"), Um(v, "after_rms_um")},
         {"least-squares sphericity [um]", Um(v, "before_ls_sphericity_um"), Um(v, "after_ls_sphericity_um")}});
    if (v.contains("note")) body += "<p class=\"note\">" + Cell(v.at("note")) + "</p>\n";
  }
  return body;
}

// A curve's range or error motion value with its U95, as GUM 7.2.6 states them.
std::string RangeText(const json& c, const std::string& unit) {
  const json &pv = c.at("pv_" + unit), &u95 = c.at("pv_u95_" + unit);
  if (!pv.is_number()) return "-";
  const gum::RoundedResult r = gum::RoundResult(pv.get<double>(), u95.is_number() ? u95.get<double>() : std::nan(""));
  return r.value_text + " ± " + r.uncertainty_text + " (U95)";
}

// The error curves: per curve its convention, range, components and certificate value from the
// JSON, the figure drawn from the result's curve (its table's points, the JSON's, marked) and the
// table.
std::string Curves(const json& j, const CalibrationWorkflowResult& run) {
  const json curves = j.value("error_curves", json::array());
  if (curves.empty() || !run.trace) return "";
  std::string body =
      "<p>Each effect of an axis angle as its curve over the measured range, "
      "about its mean over the measured angles (a constant is a zero of the axis or a centre, not "
      "determined), with the 95 % band of the curve from the fitted components' covariance.</p>\n";
  for (std::size_t i = 0; i < curves.size() && i < run.trace->curves.size(); ++i) {
    const json& c = curves[i];
    const ErrorCurve& curve = run.trace->curves[i];
    const std::string unit = c.at("unit").get<std::string>();
    body += "<h4>" + At(c, "id") + " (" + At(c, "iso_name") + ")</h4>\n<p>" + At(c, "convention") + ".</p>\n";
    std::string fitted, left;
    for (const json& f : c.at("fitted")) fitted += (fitted.empty() ? "" : ", ") + Cell(f);
    for (const json& l : c.at("left_out")) {
      left += (left.empty() ? "" : ", ") + Cell(l.at("name")) + " (" +
              html::Fixed(100.0 * l.at("represented").get<double>(), 0) + " %)";
    }
    std::vector<std::vector<std::string>> rows = {
        {"measured range [deg]", At(c, "range_lo_deg") + " to " + At(c, "range_hi_deg") +
                                     (c.value("full_turn", false) ? " (a full turn)"
                                                                  : " (not a full turn: the curve over it is "
                                                                    "determined, not each harmonic)")},
        {"components fitted", fitted},
        {"searched, not fitted (the share of each that those fitted represent over the range)",
         left.empty() ? "none" : left},
        {std::string(curve.encoder ? "range of the positional deviation" : "error motion value (peak to valley)") +
             " [" + Escape(unit) + "]",
         RangeText(c, unit)},
        {"coverage factor k of the band", At(c, "coverage_factor")},
    };
    body += html::Table({"item", "value"}, rows);
    // The figure: the curve and its band at 1 deg steps, the table's points (the JSON's) marked.
    std::vector<double> x, v, lo, hi;
    const int steps = std::max(1, static_cast<int>(std::ceil(curve.range_hi_deg - curve.range_lo_deg)));
    for (int s = 0; s <= steps; ++s) {
      const double a = curve.range_lo_deg + (curve.range_hi_deg - curve.range_lo_deg) * s / steps;
      const double value = curve.ValueAt(a), u = curve.U95At(a);
      x.push_back(a);
      v.push_back(value);
      lo.push_back(value - u);
      hi.push_back(value + u);
    }
    std::vector<double> mark_x, mark_v;
    const json& angles = c.at("angle_deg");
    const json& values = c.at("value_" + unit);
    for (std::size_t k = 0; k < angles.size(); ++k) {
      double a = angles[k].get<double>();
      if (a < curve.range_lo_deg) a += 360.0;  // a range that passes 360 deg is drawn unwrapped
      mark_x.push_back(a);
      mark_v.push_back(values[k].get<double>());
    }
    html::CurveAxes axes;
    axes.title = curve.name + " (" + curve.iso_name + ")";
    axes.x_label = curve.variable + " [deg]";
    axes.y_label = curve.name + " [" + unit + "]";
    axes.x_lo = curve.range_lo_deg;
    axes.x_hi = curve.range_hi_deg;
    body += html::Figure(html::SvgCurve(axes, x, v, lo, hi, mark_x, mark_v), axes.title,
                         "The curve [" + unit + "] over " + curve.variable +
                             " [deg] with its 95 % band (grey); the circles are the table's values.");
    // The table, 12 angles a row.
    const json& u95 = c.at("u95_" + unit);
    for (std::size_t k0 = 0; k0 < angles.size(); k0 += 12) {
      std::vector<std::string> head = {Escape(curve.variable) + " [deg]"};
      std::vector<std::string> value_row = {"value [" + Escape(unit) + "]"}, u_row = {"U95 [" + Escape(unit) + "]"};
      for (std::size_t k = k0; k < std::min(angles.size(), k0 + 12); ++k) {
        const gum::RoundedResult r = gum::RoundResult(values[k].get<double>(), u95[k].get<double>());
        head.push_back(Cell(angles[k]));
        value_row.push_back(r.value_text);
        u_row.push_back(r.uncertainty_text);
      }
      body += html::Table(head, {value_row, u_row});
    }
  }
  return body;
}

std::string Form(const json& j) {
  if (!j.contains("sphere_form")) return "<p>Not analysed.</p>\n";
  const json& f = j.at("sphere_form");
  std::string body = "<p>" + At(f, "design") + "</p>\n";
  if (f.contains("rms_um")) {
    const json& rms_u = f.value("rms_std_um", json());
    const gum::RoundedResult rms =
        gum::RoundResult(f.at("rms_um").get<double>(), rms_u.is_number() ? rms_u.get<double>() : std::nan(""));
    body += html::Table({"the sphere's form", "value"}, {{"rms [um]", rms.value_text},
                                                         {"u of the rms [um]", rms.uncertainty_text},
                                                         {"peak to valley [um]", Um(f, "pv_um")},
                                                         {"highest degree", At(f, "degree_max")}});
  }
  std::vector<std::vector<std::string>> rows;
  for (const json& t : f.value("terms", json::array())) {
    const json& u = t.value("std_um", json());
    const gum::RoundedResult r =
        gum::RoundResult(t.value("value_um", std::nan("")), u.is_number() ? u.get<double>() : std::nan(""));
    rows.push_back({At(t, "l"), At(t, "m"), r.value_text, r.uncertainty_text});
  }
  if (rows.empty()) return body;
  // The map of the form over the sphere's body frame, from the coefficients as reported.
  std::vector<FormTerm> terms;
  std::vector<double> c_um;
  for (const json& t : f.at("terms")) {
    terms.push_back({t.at("l").get<int>(), t.at("m").get<int>()});
    c_um.push_back(t.at("value_um").get<double>());
  }
  constexpr double kStep = 5.0;
  std::vector<double> azimuth, polar, form_um;
  for (double p = kStep / 2; p < 180; p += kStep) {
    for (double a = kStep / 2; a < 360; a += kStep) {
      const double pr = p * kRadPerDeg, ar = a * kRadPerDeg;
      const Eigen::Vector3d u(std::sin(pr) * std::cos(ar), std::sin(pr) * std::sin(ar), std::cos(pr));
      azimuth.push_back(a);
      polar.push_back(p);
      form_um.push_back(FormValue(terms, c_um.data(), u));
    }
  }
  html::MapAxes axes;
  axes.title = "The sphere's form in its body frame";
  axes.x_label = "azimuth [deg]";
  axes.y_label = "polar angle from the body's z [deg]";
  axes.value_label = "form [um]";
  axes.cell_deg = kStep;
  body += html::Figure(html::SvgMap(axes, azimuth, polar, form_um), axes.title,
                       "The fitted form F(u) [um] at each direction u of the sphere's body frame [deg], from the "
                       "coefficients below.");
  // The coefficients in two column groups side by side: half the length.
  const std::size_t half = (rows.size() + 1) / 2;
  std::vector<std::vector<std::string>> pairs;
  for (std::size_t i = 0; i < half; ++i) {
    std::vector<std::string> row = rows[i];
    if (half + i < rows.size()) {
      row.insert(row.end(), rows[half + i].begin(), rows[half + i].end());
    } else {
      row.insert(row.end(), 4, "");
    }
    pairs.push_back(row);
  }
  return body + html::Table({"degree l", "order m", "coefficient [um]", "u [um]", "degree l", "order m",
                             "coefficient [um]", "u [um]"},
                            pairs);
}

std::string Ambiguous(const json& j) {
  std::string body;
  for (const json& a : j.value("ambiguous", json::array())) {
    body += "<li>" + At(a, "chosen") + " or " + At(a, "other") + ": separated by " + At(a, "separate_by") + "</li>\n";
  }
  for (const json& c : j.contains("sphere_form") ? j.at("sphere_form").value("confounded", json::array())
                                                 : json::array()) {
    body += "<li>" + Cell(c) + "</li>\n";
  }
  for (const json& n : j.value("nearly_dependent", json::array())) {
    std::string terms;
    for (const auto& [name, weight] : n.at("terms").items()) terms += (terms.empty() ? "" : ", ") + Escape(name);
    body += "<li>nearly dependent (relative singular value " + At(n, "relative_singular_value") + "): " + terms +
            "</li>\n";
  }
  return body.empty() ? "<p>Nothing.</p>\n" : "<ul>\n" + body + "</ul>\n";
}

std::string Comparison(const json& j) {
  const json& summary = j.at("comparison_summary");
  std::string body =
      "<p>With " + At(summary, "previous_file") + ": <strong>" + At(summary, "verdict") + "</strong></p>\n";
  const std::string models = summary.at("models").get<std::string>();
  if (!models.empty()) body += "<p>" + Escape(models) + "</p>\n";
  std::vector<std::vector<std::string>> rows;
  std::string counted;
  for (const json& c : j.at("comparison")) {
    // GUM 7.2.6: the difference's U to two significant digits, the values to the same place.
    const double U = c.at("U").is_number() ? c.at("U").get<double>() : std::nan("");
    const auto at_u = [&](const char* key) {
      return c.at(key).is_number() ? gum::RoundResult(c.at(key).get<double>(), U).value_text : std::string("-");
    };
    std::string previous = at_u("previous"), now = at_u("now");
    if (c.at("found_in") == "now") previous = "(now only)";
    if (c.at("found_in") == "previous") now = "(previous only)";
    const std::string en = c.at("En").is_number() ? html::Fixed(c.at("En").get<double>(), 2) : "-";
    const std::string model = c.at("model") == "previous" ? "earlier, refitted" : "today's";
    rows.push_back({At(c, "parameter"), model, At(c, "unit"), previous, now, at_u("difference"),
                    std::isfinite(U) ? gum::SignificantText(U) : "-", en});
    if (c.contains("note")) counted += "<li>" + At(c, "parameter") + ": " + At(c, "note") + "</li>\n";
  }
  body += html::Table({"parameter", "model", "unit", "previous", "now", "difference", "U (k = 2)", "En"}, rows);
  body +=
      "<p class=\"note\">difference = now - previous; U: expanded uncertainty of the difference; "
      "En = difference / U; model: today's own, or today's readings refitted with the earlier calibration's (the "
      "verdict's, when the two differ).</p>\n<h3>How the two calibrations' inputs were counted</h3>\n<ul>\n";
  std::string correlated;
  for (const json& name : summary.at("correlated_inputs")) correlated += (correlated.empty() ? "" : ", ") + Cell(name);
  body += "<li>fully correlated (the same source in both, cancelling where it acts alike): " +
          (correlated.empty() ? std::string("none") : correlated) + "</li>\n";
  for (const json& note : summary.at("notes")) body += "<li>" + Cell(note) + "</li>\n";
  return body + counted + "</ul>\n";
}

// A known form's check (JSON "known_form", or one of "known_forms_of_other_spheres"): its
// numbers, the verdict and the warnings.
std::string KnownForm(const json& k) {
  const bool agrees = k.value("agrees", false);
  std::string body = "<p>The sphere's form as known from <strong>" + At(k, "source") + "</strong>, " + At(k, "terms") +
                     " coefficients, entered the fit as a prior on its coefficients (it moves only within its "
                     "covariance). Verdict: <strong>" +
                     std::string(k.value("exceeds_bound", false) ? "the sphere's form EXCEEDS its certificate's bound"
                                 : agrees                        ? "the readings agree with it"
                                                                 : "the readings DISAGREE with it") +
                     "</strong>.</p>\n";
  std::vector<std::vector<std::string>> rows = {
      {"the form as known: RMS over the sphere [um]", At(k, "known_rms_um")},
      {"the form fitted: RMS over the sphere [um]", At(k, "fitted_rms_um")},
      {"what the form explains of the readings: RMS [um]", At(k, "explained_rms_um")},
      {"residual RMS with the form held as known [um]", At(k, "rms_with_um")},
      {"residual RMS without a form [um]", At(k, "rms_without_um")},
      {"the prior's chi-square", At(k, "chi_square")},
      {"its degrees of freedom (coefficients)", At(k, "terms")},
      {"p (the prior's chi-square)", At(k, "p_value")},
  };
  rows.push_back({"the prior against the readings: chi-square", At(k, "conflict_chi_square")});
  rows.push_back({"its degrees of freedom (directions the readings determine)", At(k, "conflict_degrees_of_freedom")});
  rows.push_back({"p (the prior against the readings)", At(k, "conflict_p_value")});
  if (!k.at("bound_rms_um").is_null()) {
    rows.push_back({"the certificate's bound: RMS (k = 1) [um]", At(k, "bound_rms_um")});
    rows.push_back(
        {"the sphere's form exceeds its certificate's bound", k.value("exceeds_bound", false) ? "yes" : "no"});
  }
  body += html::Table({"quantity", "value"}, rows);
  body += "<p>" + At(k, "verdict") + "</p>\n";
  const json& warnings = k.value("warnings", json::array());
  if (!warnings.empty()) body += "<div class=\"warn\"><h3>Warnings</h3>\n" + List(warnings) + "</div>\n";
  return body;
}

// The residual maps of the seven errors' fit and of the reported fit beside it, on one colour
// scale; one map when the seven errors are the reported fit.
std::string ResidualMaps(const CalibrationWorkflowResult& run) {
  const auto residuals = [&](const CalibrationResult& fit, std::vector<double>& theta, std::vector<double>& phi,
                             std::vector<double>& um) {
    for (std::size_t i = 0; i < run.points.samples.size() && i < fit.residuals_mm.size(); ++i) {
      theta.push_back(run.points.samples[i].theta_deg);
      phi.push_back(run.points.samples[i].phi_deg);
      um.push_back(fit.residuals_mm[i] * kUmPerMm);
    }
  };
  std::vector<double> theta0, phi0, before, theta1, phi1, after;
  residuals(run.seven, theta0, phi0, before);
  const bool both = run.Extended();
  if (both) residuals(run.Reported(), theta1, phi1, after);
  html::MapAxes axes;
  axes.x_label = "theta [deg]";
  axes.y_label = "phi [deg]";
  axes.value_label = "residual [um]";
  const std::string caption =
      "Each reading's residual |p - O| - R [um] at its axis readings theta, phi [deg]; the setups drawn over each "
      "other in file order";
  if (!both) {
    axes.title = "Residuals of the seven errors' fit (the reported fit)";
    return html::Figure(html::SvgMap(axes, theta0, phi0, before), axes.title, caption + ".");
  }
  double lo = 0.0, hi = 0.0;
  for (const std::vector<double>* values : {&before, &after}) {
    for (const double v : *values) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  axes.value_lo = lo;
  axes.value_hi = hi;
  axes.plot_width = 260;
  axes.plot_height = 150;
  html::MapAxes after_axes = axes;
  axes.title = "Before: the seven errors";
  after_axes.title = "After: with the effects found";
  return html::FigureRow(
      {html::Figure(html::SvgMap(axes, theta0, phi0, before), axes.title, caption + ", with the seven errors alone."),
       html::Figure(html::SvgMap(after_axes, theta1, phi1, after), after_axes.title,
                    caption + ", with the effects found; one colour scale for both.")});
}

// The statements of the lab tested against the readings (JSON "statements"): one row each, the
// orientation the readings support under a rejected known form, the effects not applied.
std::string Statements(const json& j) {
  const json& st = j.at("statements");
  std::vector<std::vector<std::string>> rows;
  std::string notes;
  for (const json& t : st.at("tests")) {
    const bool rejected = t.value("rejected", false);
    const int dof = t.value("degrees_of_freedom", 0);
    const std::string verdict = dof == 0                     ? "not tested"
                                : !rejected                  ? "agrees"
                                : t.value("accepted", false) ? "<strong class=\"nw\">REJECTED</strong>, accepted"
                                                             : "<strong class=\"nw\">REJECTED</strong>";
    // The numbers as the text report gives them: chi-square to 4 digits, p to 2.
    std::string chi_square = "-", p = "-";
    if (dof > 0 && t.contains("chi_square") && t.at("chi_square").is_number()) {
      chi_square = internal::Format("%.4g", t.at("chi_square").get<double>());
    }
    if (dof > 0 && t.contains("p_value") && t.at("p_value").is_number()) {
      const double value = t.at("p_value").get<double>();
      p = Escape(value > 0.0 ? internal::Format("%.2g", value) : std::string("< 1e-300"));
    }
    rows.push_back({At(t, "statement"), At(t, "stated"), At(t, "readings"), chi_square, At(t, "degrees_of_freedom"), p,
                    verdict});
    if (t.contains("supported_orientation")) notes += "<li>" + At(t.at("supported_orientation"), "text") + "</li>\n";
  }
  std::string body =
      "<p>Each statement is tested against the readings' own estimate of what it states (the "
      "statement left out, the effects found kept), with both covariances; it is rejected when p < " +
      At(st, "p_level") + ".</p>\n";
  body += html::Table(
      {"statement", "stated", "the readings without it", "chi-square", "degrees of freedom", "p", "verdict"}, rows);
  if (!notes.empty()) body += "<ul>\n" + notes + "</ul>\n";
  std::string withheld;
  for (const json& e : st.at("withheld_effects")) withheld += (withheld.empty() ? "" : ", ") + Cell(e);
  if (!withheld.empty()) {
    body += "<p>The trace adds nothing on top of a rejected statement: " + withheld + " not applied.</p>\n";
  }
  return body;
}

}  // namespace

std::string CalibrationWorkflowResult::HtmlReport() const {
  const json j = json::parse(JsonReport());
  const std::string usable = j.value("usable", false) ? "usable" : "not usable";
  std::string body = "<h1>Calibration report</h1>\n<p>" + At(j, "points_file") + " — " + At(j, "program") +
                     " — the calibration is <strong>" + usable + "</strong>, judged against " +
                     At(j, "usable_against") + ".</p>\n";
  std::string told = List(j.value("warnings", json::array()));
  if (!j.value("why_not_usable", json::array()).empty()) told += List(j.at("why_not_usable"));
  body += "<div class=\"warn\"><h3>Warnings</h3>\n" + told + "</div>\n";
  using html::NewPage;
  body += Section("Identification", Identification(j, *this), NewPage::kNo);
  body += Section("Method", Method(j, *this), NewPage::kNo);
  body += Section("Conditions and uncertainty inputs", Conditions(j), NewPage::kNo);
  if (j.contains("statements")) {
    body += Section("The lab's statements, tested against the readings", Statements(j), NewPage::kNo);
  }
  body += Section("The seven errors", Errors(j));
  body += Section("Effects found", Effects(j), NewPage::kNo);
  const std::string curves = Curves(j, *this);
  if (!curves.empty()) body += Section("Error curves", curves, NewPage::kNo);
  body += Section("Residual maps", ResidualMaps(*this), NewPage::kNo);
  body += Section("The sphere's form", Form(j), NewPage::kNo);
  if (j.contains("known_form")) {
    std::string known = KnownForm(j.at("known_form"));
    for (const json& k : j.value("known_forms_of_other_spheres", json::array())) {
      std::string setups;
      for (const json& s : k.at("setups")) setups += (setups.empty() ? "" : ", ") + Cell(s);
      known += "<h3>The known form of the sphere of setups " + setups + "</h3>\n" + KnownForm(k);
    }
    body += Section("The sphere's known form", known, NewPage::kNo);
  }
  body += Section("What stays ambiguous", Ambiguous(j), NewPage::kNo);
  if (j.contains("comparison")) body += Section("Comparison with an earlier calibration", Comparison(j), NewPage::kNo);
  return html::Page("Calibration report: " + points_path, body);
}

}  // namespace sph
