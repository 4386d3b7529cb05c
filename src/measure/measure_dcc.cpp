// The measurement's Digital Calibration Certificate (sph/io/dcc.hpp): its numbers are the JSON
// report's, converted to SI units and rounded as GUM 7.2.6 states them.
#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

#include "sph/io/dcc.hpp"
#include "sph/measure/measure_workflow.hpp"

namespace sph {

namespace {

using nlohmann::json;

double Number(const json& j, const char* key) {
  return j.contains(key) && j.at(key).is_number() ? j.at(key).get<double>() : std::nan("");
}

// A result of the budget (budget.radius, ...) with its U; the radius in mm, the others in um.
dcc::Quantity Budgeted(const json& j, const char* key, const std::string& name) {
  const json& b = j.at("budget").at(key);
  const std::string value_unit = b.value("value_unit", "um");
  const double to_value_unit = value_unit == "mm" ? 1e-3 : 1.0;  // U is in um
  dcc::Quantity q = dcc::InSi(std::string("budget.") + key, name, Number(b, "value"), value_unit,
                              Number(b, "U") * to_value_unit, Number(b, "k"), Number(b, "coverage_probability"));
  if (b.contains("monte_carlo") && b.at("monte_carlo").contains("gum_validated")) {
    q.description = b.at("monte_carlo").value("gum_validated", false)
                        ? "the GUM interval agrees with the Monte Carlo method of JCGM 101"
                        : "the GUM interval does not agree with the Monte Carlo method of JCGM 101 (see the report)";
  }
  return q;
}

}  // namespace

std::string MeasurementWorkflowResult::Dcc(const dcc::Settings& lab) const {
  const json j = json::parse(JsonReport());
  dcc::Content c;
  c.kind = dcc::Kind::kMeasurement;
  const std::string prog = j.value("created_by", "");
  c.software = prog.substr(0, prog.find(' '));
  c.release = prog.find(' ') == std::string::npos ? "" : prog.substr(prog.find(' ') + 1);
  c.title = "Measurement of a sphere's radius and form";
  c.description = "From " + std::to_string(evaluation.n_points) + " points of " + points_path +
                  (options.calibration_path.empty() ? "" : ", compensated with " + options.calibration_path) + ".";
  c.methods = {{"The least-squares sphere",
                "The sphere that minimises the sum of the squared radial deviations of the points; its radius, "
                "and the peak to valley of the deviations (the least-squares sphericity).",
                {},
                {}},
               {"The minimum-zone sphere",
                "The two concentric spheres of least radial separation that enclose every point (the minimum-zone "
                "sphericity).",
                {},
                {}},
               {"The uncertainty: GUM, checked by JCGM 101",
                "The points' scatter, the calibration's covariance and its Type B inputs by sensitivity "
                "coefficients; U = k u; the sphericities' linear budget checked by the adaptive Monte Carlo "
                "method.",
                {"JCGM 100:2008", "JCGM 101:2008"},
                {}}};
  if (j.contains("header_sphere_radius_mm")) {
    c.conditions.push_back(dcc::InSi("header_sphere_radius_mm", "the radius the points file states for the sphere",
                                     Number(j, "header_sphere_radius_mm"), "mm", 0.0));
  }
  dcc::Result results{"The sphere", "", {}};
  results.quantities.push_back(Budgeted(j, "radius", "radius of the least-squares sphere"));
  results.quantities.push_back(Budgeted(j, "sphericity_ls", "least-squares sphericity (peak to valley)"));
  results.quantities.push_back(Budgeted(j, "sphericity_mz", "minimum-zone sphericity"));
  results.quantities.push_back(dcc::InSi("rms_um", "RMS of the radial deviations", Number(j, "rms_um"), "um"));
  c.results.push_back(results);
  const json& floor = j.value("noise_floor", json::object());
  if (floor.value("computed", false)) {
    dcc::Result noise{"The noise floor",
                      "What the probe's noise alone gives these points: a sphericity within it is not told apart "
                      "from noise.",
                      {}};
    for (const char* key : {"sphericity_ls_um", "sphericity_mz_um"}) {
      if (!floor.contains(key) || floor.at(key).is_null()) continue;
      const json& s = floor.at(key);
      dcc::Quantity q = dcc::InSi(std::string("noise_floor.") + key + ".mean_um",
                                  std::string(key) + " of pure noise, the mean", Number(s, "mean_um"), "um");
      q.description = s.value("within_noise", false) ? "the measured value is within the noise"
                                                     : "the measured value is above the noise: a form error";
      noise.quantities.push_back(q);
    }
    c.results.push_back(noise);
  }
  c.header = input.metadata;
  c.points_file = points_path;
  c.calibration_file = options.calibration_path;
  c.calibration_source = input.calibration_source;
  return dcc::WriteCertificate(c, lab);
}

}  // namespace sph
