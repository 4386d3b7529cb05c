// The calibration's Digital Calibration Certificate (sph/io/dcc.hpp): its numbers are the JSON
// report's, converted to SI units and rounded as GUM 7.2.6 states them.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sph/calib/calibrate_workflow.hpp"
#include "sph/io/dcc.hpp"
#include "sph/model/scms_model.hpp"

namespace sph {

namespace {

using nlohmann::json;

double Number(const json& j, const char* key) {
  return j.contains(key) && j.at(key).is_number() ? j.at(key).get<double>() : std::nan("");
}

// The reference the SCMS model is taken from.
constexpr const char* kPaper =
    "Li Shaobo, Yuan Daocheng, He Huabin, Du Wei: Identification and Compensation Method for Position-independent "
    "Geometric Error of Spherical Coordinate Measuring System (in Chinese; Institute of Machinery Manufacturing "
    "Technology, China Academy of Engineering Physics)";

std::vector<dcc::Method> Methods(const json& j, const CalibrationWorkflowResult& run) {
  std::vector<dcc::Method> methods;
  methods.push_back(
      {"The SCMS model: seven position-independent geometric errors",
       "The seven errors alpha, a, beta, b, epsilon, c and d' of the Denavit-Hartenberg model of the SCMS, and the "
       "centre of the sphere in each setup, fitted by least squares (Levenberg-Marquardt) to the readings' "
       "distances from the reference sphere of radius R0. ISO 230-1 names the location errors of the Phi axis: "
       "alpha is EA0B, a is X0B, beta is -EB0B; b, epsilon, c and d' (the probe's offsets, orientation and zero) "
       "have no ISO 230 name.",
       {"ISO 230-1:2012"},
       {kPaper}});
  if (run.trace) {
    std::string added;
    for (const json& e : j.value("effects", json::array())) {
      added += (added.empty() ? "" : ", ") + e.value("id", "") +
               (e.value("iso_name", "").empty() ? "" : " (" + e.at("iso_name").get<std::string>() + ")");
    }
    methods.push_back({"The trace of the residual: the effects the seven-error model lacks",
                       "The residual's structure searched for the library's effects (encoder errors, error "
                       "motions, the probe's gain, nonlinearity, incidence and drift, the sphere's form), each "
                       "added when the extended BIC and the cross-validated RMS favour it and its pattern "
                       "transfers between setups. Added: " +
                           (added.empty() ? std::string("none") : added) + ".",
                       {"ISO 230-7:2015"},
                       {}});
  }
  methods.push_back({"The uncertainty: GUM",
                     "The fit's covariance (Type A) and each stated Type B input (R0's certificate, the sphere's "
                     "temperature, the probe's scale, priors) by sensitivity coefficients from refits; U = k u.",
                     {"JCGM 100:2008"},
                     {}});
  return methods;
}

std::vector<dcc::Quantity> Conditions(const json& j, const CalibrationWorkflowResult& run, double k, double p) {
  std::vector<dcc::Quantity> conditions;
  const double u_r0_um = run.inputs.sphere_radius_u_um;
  dcc::Quantity r0 = dcc::InSi("sphere_radius_mm", "R0, the reference sphere's radius at 20 degC (its certificate's)",
                               Number(j, "sphere_radius_mm"), "mm", u_r0_um > 0.0 ? k * u_r0_um / 1000.0 : 0.0, k, p);
  r0.description = u_r0_um > 0.0 ? "U = k u(R0), u(R0) from the certificate"
                                 : "taken as exact: no u(R0) stated (sphere_radius_u_um)";
  conditions.push_back(r0);
  dcc::Quantity d =
      dcc::InSi("probe_offset_mm", "d, the nominal probe zero distance", Number(j, "probe_offset_mm"), "mm", 0.0, k, p);
  conditions.push_back(d);
  const CalibrationInputs& in = run.inputs;
  dcc::Quantity t;
  t.id = "sphere_temperature_c";
  t.name = "the sphere's temperature while measured";
  t.value = in.sphere_temperature_c;
  t.unit = "\\degreeCelsius";
  t.uncertainty = k * in.sphere_temperature_u_c;
  t.coverage_factor = k;
  t.coverage_probability = p;
  t.description = in.sphere_cte_per_k > 0.0 ? "R0 corrected to it with the expansion coefficient given"
                                            : "no expansion coefficient stated (sphere_cte_per_k): R0 not corrected";
  const bool stated = ConditionsOf(run.points.header).sphere_temperature_c.has_value() ||
                      in.sphere_temperature_c != 20.0 || in.sphere_temperature_u_c > 0.0 || in.sphere_cte_per_k > 0.0;
  if (!stated) {
    t.value = std::nan("");
    t.text = "not stated (sphere_temperature_c): R0 taken at 20 degC, not corrected";
  }
  conditions.push_back(t);
  return conditions;
}

dcc::Result SevenErrors(const json& j) {
  dcc::Result r{"The seven geometric errors",
                "Each error's value with its expanded uncertainty U = k u (its coverage factor and probability "
                "from the budget's effective degrees of freedom), in SI units.",
                {}};
  for (const json& name : j.at("parameter_order")) {
    const std::string key = name.get<std::string>();
    if (key.find('@') != std::string::npos || key.rfind("center", 0) == 0) continue;  // the sphere's centres
    const json& p = j.at("parameters").at(key);
    const std::string iso = p.value("iso_name", "");
    const std::string label = key + (iso.empty() ? " (no ISO 230 name)" : " (ISO 230-1: " + iso + ")");
    const std::string unit = p.value("unit", "");
    dcc::Quantity q;
    if (p.contains("held")) {
      q = dcc::InSi("parameters." + key, label, Number(p, "value"), unit, 0.0);
      q.description = "held (" + p.at("held").get<std::string>() + "), not fitted";
    } else if (!p.value("determined", true) || !std::isfinite(Number(p, "U"))) {
      q.id = "parameters." + key;
      q.name = label;
      q.text = "not determined by these readings";
    } else {
      q = dcc::InSi("parameters." + key, label, Number(p, "value"), unit, Number(p, "U"), Number(p, "k"),
                    Number(p, "coverage_probability"));
    }
    r.quantities.push_back(q);
  }
  return r;
}

dcc::Result Effects(const json& j, double k, double p) {
  dcc::Result r{"The effects beyond the seven errors",
                "Each parameter of each effect the trace added, with U = k u from the fit's standard uncertainty "
                "(a normal distribution).",
                {}};
  for (const json& e : j.value("effects", json::array())) {
    const std::string iso = e.value("iso_name", "");
    for (const json& par : e.at("parameters")) {
      const std::string name = par.value("name", "");
      r.quantities.push_back(dcc::InSi("effects." + name,
                                       name + " (" + e.value("description", "") + (iso.empty() ? "" : "; " + iso) + ")",
                                       Number(par, "value"), par.value("unit", ""), k * Number(par, "std"), k, p));
    }
  }
  return r;
}

dcc::Result Fit(const json& j, const CalibrationWorkflowResult& run) {
  dcc::Result r{"The fit", "", {}};
  const json& fit = j.at("fit");
  r.quantities.push_back(dcc::InSi("fit.rms_um", "the readings' residual RMS", Number(fit, "rms_um"), "um"));
  dcc::Quantity n;
  n.id = "fit.n_points";
  n.name = "readings fitted";
  n.value = Number(fit, "n_points");
  n.unit = "\\one";
  n.uncertainty = 0.0;
  r.quantities.push_back(n);
  dcc::Quantity usable;
  usable.id = "usable";
  usable.name = "the calibration";
  usable.text = run.usability.usable ? "usable" : "not usable";
  for (const std::string& why : run.usability.reasons) usable.text += "; " + why;
  r.quantities.push_back(usable);
  return r;
}

// The sphere's form: its RMS when the design separates it, and the known form's check.
std::vector<dcc::Quantity> Form(const json& j, double k, double p) {
  std::vector<dcc::Quantity> q;
  if (j.contains("sphere_form") && j.at("sphere_form").contains("rms_um")) {
    const json& f = j.at("sphere_form");
    q.push_back(dcc::InSi("sphere_form.rms_um", "the sphere's form, its RMS over the sphere", Number(f, "rms_um"), "um",
                          k * Number(f, "rms_std_um"), k, p));
  }
  if (j.contains("known_form")) {
    const json& f = j.at("known_form");
    q.push_back(dcc::InSi("known_form.known_rms_um", "the known form (" + f.value("source", "") + "), its RMS",
                          Number(f, "known_rms_um"), "um"));
    q.push_back(dcc::InSi("known_form.fitted_rms_um", "the form fitted with the known form as a prior, its RMS",
                          Number(f, "fitted_rms_um"), "um"));
    dcc::Quantity verdict;
    verdict.id = "known_form.verdict";
    verdict.name = "the readings against the known form";
    verdict.text = f.value("verdict", "");
    q.push_back(verdict);
  }
  return q;
}

dcc::Result Comparison(const json& j) {
  const json& s = j.at("comparison_summary");
  dcc::Result r{"The comparison with the previous calibration (" + s.value("previous_file", "") + ")",
                "Each parameter's difference now - previous with the U of the difference (k = " +
                    std::to_string(static_cast<int>(Number(s, "k"))) +
                    ", the inputs common to both counted as correlated), and En = difference / U. Verdict: " +
                    s.value("verdict", ""),
                {}};
  const double k = Number(s, "k");
  const json& rows = j.at("comparison");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const json& c = rows[i];
    const std::string name = c.value("parameter", "") + " (" +
                             (c.value("model", "") == "previous" ? "the previous model refitted" : "today's model") +
                             ")";
    const std::string id = "comparison." + std::to_string(i);
    dcc::Quantity d = dcc::InSi(id + ".difference", name + ": now - previous", Number(c, "difference"),
                                c.value("unit", ""), Number(c, "U"), k, dcc::ProbabilityOfK(k));
    if (!std::isfinite(d.value)) d.text = "found in one calibration only";
    r.quantities.push_back(d);
    if (std::isfinite(Number(c, "En"))) {
      dcc::Quantity en = dcc::InSi(id + ".En", name + ": En", Number(c, "En"), "");
      r.quantities.push_back(en);
    }
  }
  return r;
}

}  // namespace

std::string CalibrationWorkflowResult::Dcc(const dcc::Settings& lab) const {
  const json j = json::parse(JsonReport());
  // The effects' and the conditions' coverage: the budget's k, or the normal k of its probability.
  const json& coverage = j.value("coverage", json::object());
  const double p = coverage.contains("probability") ? coverage.at("probability").get<double>()
                                                    : dcc::ProbabilityOfK(coverage.value("k", 2.0));
  const double k = coverage.contains("probability") ? dcc::KOfProbability(p) : coverage.value("k", 2.0);
  dcc::Content c;
  c.kind = dcc::Kind::kCalibration;
  const std::string prog = j.value("program", "");
  c.software = prog.substr(0, prog.find(' '));
  c.release = prog.find(' ') == std::string::npos ? "" : prog.substr(prog.find(' ') + 1);
  c.title = "Calibration of the SCMS's geometric errors with a reference sphere";
  c.description = "From " + std::to_string(Reported().n_points) + " readings of the points file " + points_path +
                  " in " + std::to_string(Reported().setup_ids.size()) + " setup(s).";
  c.methods = Methods(j, *this);
  c.conditions = Conditions(j, *this, k, p);
  c.results.push_back(SevenErrors(j));
  if (!j.value("effects", json::array()).empty()) c.results.push_back(Effects(j, k, p));
  c.results.push_back(Fit(j, *this));
  const std::vector<dcc::Quantity> form = Form(j, k, p);
  if (!form.empty()) c.results.push_back({"The sphere's form", "", form});
  if (j.contains("comparison")) c.results.push_back(Comparison(j));
  c.header = points.header.metadata;
  if (!points.samples.empty()) {
    const auto [lo, hi] = std::minmax_element(points.samples.begin(), points.samples.end(),
                                              [](const Sample& a, const Sample& b) { return a.t_s < b.t_s; });
    c.duration_s = hi->t_s - lo->t_s;
  }
  c.points_file = points_path;
  return dcc::WriteCertificate(c, lab);
}

}  // namespace sph
