// The measurement's HTML report: rendered from the JSON report (the numbers are the JSON's), with
// the form map drawn from the least-squares residuals.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "sph/internal/html_json.hpp"
#include "sph/io/html_report.hpp"
#include "sph/measure/measure_workflow.hpp"
#include "sph/model/units.hpp"
#include "sph/stats/rounding.hpp"

namespace sph {

namespace {

using nlohmann::json;
using html::Escape;
using html::JsonField;
using html::Section;

// A length in mm to the nanometre (6 decimals): 6 significant digits would round a 20 mm radius
// to 0.1 um.
std::string Mm(const json& j, const char* key) {
  return j.contains(key) && j.at(key).is_number() ? html::Fixed(j.at(key).get<double>(), 6) : "-";
}

std::string Vector(const json& v) {
  if (!v.is_array()) return "-";
  std::string out;
  for (const json& x : v) out += (out.empty() ? "" : ", ") + (x.is_number() ? html::Fixed(x.get<double>(), 6) : "-");
  return out;
}

// A budgeted result of the JSON (budget.radius, ...) as GUM 7.2.6 states it: U to two significant
// digits, the value to the same place (the radius in mm, U in um).
std::pair<std::string, std::string> Stated(const json& j, const char* key) {
  if (!j.contains("budget") || !j.at("budget").contains(key)) return {"-", "-"};
  const json& r = j.at("budget").at(key);
  const bool mm = r.value("value_unit", "") == "mm";
  const double U_um = r.value("U", std::nan(""));
  const gum::RoundedResult stated = gum::RoundResult(r.value("value", std::nan("")), mm ? U_um / kUmPerMm : U_um);
  return {stated.value_text + (mm ? " mm" : " um"), gum::SignificantText(U_um) + " um"};
}

std::string Results(const json& j) {
  const auto [radius, radius_U] = Stated(j, "radius");
  const auto [ls, ls_U] = Stated(j, "sphericity_ls");
  const auto [mz, mz_U] = Stated(j, "sphericity_mz");
  return html::Table({"result", "value", "U (k as in the budget)"}, {{"radius", radius, radius_U},
                                                                     {"least-squares sphericity", ls, ls_U},
                                                                     {"minimum-zone sphericity", mz, mz_U}}) +
         "<p class=\"note\">GUM 7.2.6: U to two significant digits, the value to the same decimal place (the JSON "
         "report holds every digit). The evaluation's further values, at its resolution:</p>\n" +
         html::Table({"of the evaluation", "value"},
                     {{"diameter [mm]", Mm(j, "diameter_mm")},
                      {"radius minus the stated radius [um]", JsonField(j, "radius_deviation_um")},
                      {"least-squares centre x, y, z [mm]", Vector(j.value("center_mm", json()))},
                      {"minimum-zone centre x, y, z [mm]", Vector(j.value("mz_center_mm", json()))},
                      {"minimum-zone inner radius [mm]", Mm(j, "mz_inner_radius_mm")},
                      {"minimum-zone outer radius [mm]", Mm(j, "mz_outer_radius_mm")},
                      {"rms of the residuals [um]", JsonField(j, "rms_um")}});
}

std::string NoiseFloor(const json& j) {
  if (!j.contains("noise_floor") || j.at("noise_floor").is_null()) return "<p>Not computed.</p>\n";
  const json& n = j.at("noise_floor");
  if (!n.value("computed", false)) return "<p>Not computed: " + JsonField(n, "note") + "</p>\n";
  std::string body = html::Table({"noise floor", "value"}, {{"noise sigma [um]", JsonField(n, "sigma_um")},
                                                            {"its source", JsonField(n, "sigma_source")},
                                                            {"simulated measurements", JsonField(n, "draws")},
                                                            {"rms of the form of pure noise [um]",
                                                             JsonField(n, "rms_form_um")}});
  std::vector<std::vector<std::string>> form;
  for (const char* key : {"sphericity_ls_um", "sphericity_mz_um"}) {
    if (!n.contains(key)) continue;
    const json& s = n.at(key);
    form.push_back({Escape(key), JsonField(s, "mean_um"), JsonField(s, "std_um"), JsonField(s, "within_noise")});
  }
  if (!form.empty()) {
    body += html::Table({"of pure noise", "mean [um]", "std [um]", "the measured value within the noise"}, form);
  }
  return body;
}

std::string Budget(const json& j) {
  if (!j.contains("budget")) return "<p>None.</p>\n";
  const json& b = j.at("budget");
  std::string body;
  std::vector<std::vector<std::string>> results;
  const std::pair<const char*, const char*> kResults[] = {
      {"radius", "radius"}, {"sphericity_ls", "least-squares sphericity"}, {"sphericity_mz", "minimum-zone sphericity"}};
  for (const auto& [key, name] : kResults) {
    if (!b.contains(key)) continue;
    const json& r = b.at(key);
    const std::string unit = JsonField(r, "unit");
    std::string verdict = "-";
    if (r.contains("monte_carlo") && !r.at("monte_carlo").is_null()) {
      const json& mc = r.at("monte_carlo");
      verdict = std::string(mc.value("gum_validated", false) ? "GUM validated" : "GUM not validated") +
                " (" + JsonField(mc, "method") + ", " + JsonField(mc, "trials") + " trials, tolerance " +
                JsonField(mc, "tolerance_um") + " um; interval " + JsonField(mc, "low_um") + " to " +
                JsonField(mc, "high_um") + " um)";
    } else if (r.contains("mc_note")) {
      verdict = JsonField(r, "mc_note");
    }
    const auto [value, U] = Stated(j, key);
    results.push_back({name, value, unit, gum::SignificantText(r.value("u", std::nan(""))), JsonField(r, "k"), U,
                       JsonField(r, "dof"), verdict});
    std::vector<std::vector<std::string>> rows;
    std::string not_stated;
    for (const json& in : r.value("budget", json::array())) {
      if (in.value("type", "") == "B" && in.value("u_input", 0.0) == 0.0) {
        not_stated += (not_stated.empty() ? "" : ", ") + html::JsonText(in.at("input"));
        continue;
      }
      rows.push_back({html::JsonText(in.at("input")) + " [" + JsonField(in, "input_unit") + "]", JsonField(in, "type"),
                      JsonField(in, "u_input"), gum::SignificantText(in.value("sensitivity", std::nan("")), 4),
                      gum::SignificantText(in.value("u_contribution", std::nan(""))), JsonField(in, "dof")});
    }
    body += "<h3>Budget of the " + std::string(name) + " [" + unit + "]</h3>\n" +
            html::Table({"input", "type", "u of the input (input's unit)", "sensitivity",
                         "contribution to u [" + unit + "]", "degrees of freedom"},
                        rows) +
            (not_stated.empty() ? "" : "<p>Not stated, taken as exact: " + not_stated + ".</p>\n");
  }
  return html::Table({"result", "value", "unit of u, U", "u", "k", "U = k u", "degrees of freedom",
                      "JCGM 101 check"},
                     results) +
         "<p class=\"note\">Type A of the sphericities: " + JsonField(b, "type_a_sphericity") + ".</p>\n" + body;
}

}  // namespace

std::string MeasurementWorkflowResult::HtmlReport() const {
  const json j = json::parse(JsonReport());
  const json& in = j.value("input", json::object());
  std::string body = "<h1>Sphere measurement report</h1>\n<p>" + JsonField(in, "points_file") + " \u2014 " +
                     JsonField(j, "created_by") + "</p>\n";
  body += "<div class=\"warn\"><h3>Warnings</h3>\n" + html::JsonList(j.value("warnings", json::array())) + "</div>\n";
  using html::NewPage;
  body += Section("Identification",
                  html::Table({"item", "value"}, {{"points file", JsonField(in, "points_file")},
                                                  {"format", JsonField(in, "format")},
                                                  {"calibration file", JsonField(in, "calibration_file")},
                                                  {"setup", JsonField(in, "setup")},
                                                  {"points", JsonField(in, "n_points")},
                                                  {"program", JsonField(j, "created_by")},
                                                  {"report made", Escape(html::UtcNow())}}) +
                      html::HeaderTables(j),
                  NewPage::kNo);
  body += Section("Results", Results(j), NewPage::kNo);
  // The form map: each point's residual about the least-squares sphere at its direction from the
  // centre (azimuth 0-360 deg, polar angle from +z).
  std::vector<double> azimuth, polar, residual_um;
  const Eigen::Vector3d& c = evaluation.ls.sphere.center;
  for (std::size_t i = 0; i < input.points_mm.size() && i < evaluation.residuals_mm.size(); ++i) {
    const Eigen::Vector3d u = (input.points_mm[i] - c).normalized();
    double az = std::atan2(u.y(), u.x()) / kRadPerDeg;
    if (az < 0) az += 360.0;
    azimuth.push_back(az);
    polar.push_back(std::acos(std::clamp(u.z(), -1.0, 1.0)) / kRadPerDeg);
    residual_um.push_back(evaluation.residuals_mm[i] * 1e3);
  }
  html::MapAxes axes;
  axes.title = "Form error about the least-squares sphere";
  axes.x_label = "azimuth [deg]";
  axes.y_label = "polar angle from +z [deg]";
  axes.value_label = "radial deviation [um]";
  body += Section("Form map", html::Figure(html::SvgMap(axes, azimuth, polar, residual_um), axes.title,
                                           "Each point's radial deviation from the least-squares sphere [um] at "
                                           "its direction from the centre [deg]."));
  body += Section("Noise floor", NoiseFloor(j), NewPage::kNo);
  body += Section("Uncertainty budget", Budget(j));
  return html::Page("Sphere measurement report: " + points_path, body);
}

}  // namespace sph
