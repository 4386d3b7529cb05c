// The Python module `sph`: the library's points files, its calibration and measurement workflows,
// the simulator and the Monte Carlo study for scripts, with NumPy arrays in and out. Thin, as the
// apps are: it converts, calls the library (the GIL released, Ctrl-C stopping it) and returns what
// the library renders; sph::Error becomes sph.Error (a ValueError) with the library's message.
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "sph/calib/calibrate_workflow.hpp"
#include "sph/calib/montecarlo_options.hpp"
#include "sph/core/cancellation.hpp"
#include "sph/core/error.hpp"
#include "sph/core/ranges.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/dcc.hpp"
#include "sph/io/parameter_settings.hpp"
#include "sph/io/points_file.hpp"
#include "sph/measure/measure_workflow.hpp"
#include "sph/model/compensation.hpp"
#include "sph/model/effect_terms.hpp"
#include "sph/model/units.hpp"
#include "sph/simulation/simulation_options.hpp"

namespace py = pybind11;

namespace {

// The header of `data` as the file states it: key -> value text, in file order (the columns
// line too). One writing of the header: the library's writer, read back field by field.
py::dict HeaderDict(const sph::PointsData& data) {
  sph::PointsData header_only;
  header_only.header = data.header;
  header_only.has_time = data.has_time;
  header_only.has_setup = data.has_setup;
  std::ostringstream text;
  sph::WritePoints(text, header_only);
  py::dict header;
  std::istringstream lines(text.str());
  std::string line;
  while (std::getline(lines, line)) {
    if (line.empty() || line[0] != '#') continue;
    if (const auto field = sph::HeaderFieldOf(std::string_view(line).substr(1))) {
      header[py::str(field->key)] = field->value;
    }
  }
  return header;
}

template <typename T>
py::array_t<T> Column(const sph::PointsData& data, T (*get)(const sph::Sample&)) {
  py::array_t<T> a(static_cast<py::ssize_t>(data.samples.size()));
  auto m = a.template mutable_unchecked<1>();
  for (std::size_t i = 0; i < data.samples.size(); ++i) m(static_cast<py::ssize_t>(i)) = get(data.samples[i]);
  return a;
}

// Readings of a points file: the library's PointsData, its columns as NumPy arrays.
struct Points {
  sph::PointsData data;
};

// Runs `work` (the library's, without the GIL) on a thread of its own while this thread waits and
// checks for signals every 50 ms: when a handler raises (Ctrl-C's KeyboardInterrupt), the work is
// asked to stop (sph/core/cancellation.hpp), and once it has, that exception is raised here.
template <typename Work>
auto Interruptible(Work work) -> decltype(work()) {
  using Result = decltype(work());
  sph::Cancellation cancellation;
  std::optional<Result> result;
  std::exception_ptr failure;
  std::mutex mutex;
  std::condition_variable finished;
  bool done = false, interrupted = false;
  {
    py::gil_scoped_release release;
    std::thread worker([&] {
      const sph::CancellationScope scope(&cancellation);
      try {
        result.emplace(work());
      } catch (...) {
        failure = std::current_exception();
      }
      const std::lock_guard<std::mutex> lock(mutex);
      done = true;
      finished.notify_one();
    });
    std::unique_lock<std::mutex> lock(mutex);
    while (!finished.wait_for(lock, std::chrono::milliseconds(50), [&] { return done; })) {
      if (interrupted) continue;
      lock.unlock();
      {
        const py::gil_scoped_acquire gil;
        interrupted = PyErr_CheckSignals() != 0;  // the handler's exception is now set
      }
      if (interrupted) cancellation.Request();
      lock.lock();
    }
    lock.unlock();
    worker.join();
  }
  if (interrupted) throw py::error_already_set();
  if (failure) std::rethrow_exception(failure);
  return std::move(*result);
}

// A 1-D float64 array of `name`, without a copy when it is one already (C order).
py::array_t<double, py::array::c_style | py::array::forcecast> Column1D(const py::handle& values, const char* name,
                                                                        const std::string& source) {
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(values);
  if (!a) {
    PyErr_Clear();
    throw sph::Error(source + ": " + name + " must be an array of numbers");
  }
  if (a.ndim() != 1) throw sph::Error(source + ": " + name + " must be a 1-D array");
  return a;
}

// Points from arrays and a header dict, checked as a file is (sph::PointsFromColumns(): the
// header's "<source>:<line>: problem", a reading's "<source>: sample <i>: problem"), without
// copies of the arrays beyond the readings the points hold; the GIL released while they are made.
Points MakePoints(const py::handle& theta_deg, const py::handle& phi_deg, const py::handle& r_mm, const py::object& t_s,
                  const py::object& setup, const py::object& header, const std::string& source) {
  const auto theta = Column1D(theta_deg, "theta_deg", source), phi = Column1D(phi_deg, "phi_deg", source),
             r = Column1D(r_mm, "r_mm", source);
  const auto n = theta.size();
  if (phi.size() != n || r.size() != n) {
    throw sph::Error(source + ": theta_deg, phi_deg and r_mm must be 1-D arrays of one length");
  }
  std::optional<py::array_t<double, py::array::c_style | py::array::forcecast>> t, s;
  if (!t_s.is_none()) t = Column1D(t_s, "t_s", source);
  if (!setup.is_none()) s = Column1D(setup, "setup", source);
  if ((t && t->size() != n) || (s && s->size() != n)) {
    throw sph::Error(source + ": t_s and setup must be 1-D arrays of the readings' length");
  }
  std::vector<sph::HeaderField> fields;
  if (!header.is_none()) {
    for (auto item : py::cast<py::dict>(header)) {
      fields.push_back({py::str(item.first), py::str(item.second)});
    }
  }
  sph::PointsColumns columns;
  columns.n = static_cast<std::size_t>(n);
  columns.theta_deg = theta.data();
  columns.phi_deg = phi.data();
  columns.r_mm = r.data();
  columns.t_s = t ? t->data() : nullptr;
  columns.setup = s ? s->data() : nullptr;
  py::gil_scoped_release release;
  return Points{sph::PointsFromColumns(fields, columns, source)};
}

// A path given as str or os.PathLike (pathlib.Path).
std::string PathOf(const py::handle& path) {
  return py::cast<std::string>(py::module_::import("os").attr("fspath")(path));
}

// What a keyword of type T takes, in Python's words, for the TypeError of a value it cannot take.
template <typename T>
std::string Expected() {
  if constexpr (std::is_same_v<T, bool>) {
    return "a bool";
  } else if constexpr (std::is_integral_v<T>) {
    return "an int from " + std::to_string(std::numeric_limits<T>::min()) + " to " +
           std::to_string(std::numeric_limits<T>::max());
  } else if constexpr (std::is_floating_point_v<T>) {
    return "a float (or an int)";
  } else if constexpr (std::is_same_v<T, std::string>) {
    return "a str";
  } else {
    return "a str or a sequence of str";
  }
}

// A value as the TypeError names it: its type and its repr, cut to 40 characters.
std::string Described(const py::handle& value) {
  std::string repr = py::str(py::repr(value));
  if (repr.size() > 40) repr = repr.substr(0, 37) + "...";
  return "the " + std::string(py::str(py::type::of(value).attr("__name__"))) + " " + repr;
}

// The value of keyword `key` of `function` as a T; a TypeError naming the keyword, the type it
// takes and the value given when it is not one (or out of T's range).
template <typename T>
T Cast(const py::handle& value, const std::string& key, const char* function) {
  try {
    return py::cast<T>(value);
  } catch (const py::cast_error&) {
  }
  throw py::type_error(std::string(function) + "(): " + key + " takes " + Expected<T>() + ", not " +
                       Described(value));
}

std::vector<std::string> Strings(const py::handle& value, const std::string& key, const char* function) {
  if (py::isinstance<py::str>(value)) return {py::cast<std::string>(value)};
  return Cast<std::vector<std::string>>(value, key, function);
}

// The keywords of calibrate() besides the conditions (kConditionFields) and of measure().
constexpr const char* kCalibrateKeywords[] = {"no_trace",
                                              "effects",
                                              "validate",
                                              "compare",
                                              "sphere_form",
                                              "sphere_radius_mm",
                                              "probe_offset_mm",
                                              "fix",
                                              "prior",
                                              "robust_loss",
                                              "robust_scale_sigma",
                                              "max_std_um",
                                              "max_iterations",
                                              "harmonics",
                                              "phi_wobble_pivot_mm",
                                              "drift_order",
                                              "hold_confounded",
                                              "seed",
                                              "coverage",
                                              "accept_rejected",
                                              "target_u"};
constexpr const char* kMeasureKeywords[] = {
    "calibration",  "xyz",          "subtract_sphere_form", "setup",    "uncertainty_samples", "seed",
    "max_dilution", "noise_um",     "noise_floor_draws",    "coverage", "mc_max_trials",       "mc_batch_trials",
    "mc_digits",    "mc_max_points"};

// Whether `key` is a keyword of `function`; a TypeError naming it when not, as Python's own.
template <std::size_t N>
void CheckKeyword(const std::string& key, const char* const (&keywords)[N], const char* function, bool conditions) {
  for (const char* k : keywords) {
    if (key == k) return;
  }
  if (conditions) {
    for (const sph::ConditionField& f : sph::kConditionFields) {
      if (key == f.key) return;
    }
  }
  throw py::type_error(std::string(function) + "() got an unexpected keyword argument '" + key + "'");
}

// sph_calibrate's options as keyword arguments (its names with '_' for '-'), into the workflow's.
sph::CalibrationWorkflowOptions CalibrationOptionsOf(const py::kwargs& kwargs) {
  sph::CalibrationWorkflowOptions o;
  for (auto item : kwargs) {
    const std::string key = py::str(item.first);
    const py::handle v = item.second;
    CheckKeyword(key, kCalibrateKeywords, "calibrate", true);
    if (v.is_none()) continue;  // not given
    if (key == "no_trace") {
      o.trace = !Cast<bool>(v, key, "calibrate");
    } else if (key == "effects") {
      std::vector<std::string> ids;
      for (const std::string& text : Strings(v, key, "calibrate")) {
        std::istringstream list(text);
        for (std::string id; std::getline(list, id, ',');) ids.push_back(id);
      }
      for (const std::string& id : ids) {
        if (!sph::EffectFromId(id, &o.effects.emplace_back())) throw sph::Error("effects: unknown effect '" + id + "'");
      }
    } else if (key == "validate") {
      o.validate_path = PathOf(v);
    } else if (key == "compare") {
      o.compare_path = PathOf(v);
    } else if (key == "sphere_form") {
      if (py::isinstance<py::str>(v) || py::hasattr(v, "__fspath__")) {
        o.sphere_form_paths.push_back(PathOf(v));
      } else {
        for (const py::handle path : v) o.sphere_form_paths.push_back(PathOf(path));  // one per sphere
      }
    } else if (key == "sphere_radius_mm") {
      o.sphere_radius_mm = Cast<double>(v, key, "calibrate");
    } else if (key == "probe_offset_mm") {
      o.probe_offset_mm = Cast<double>(v, key, "calibrate");
    } else if (key == "fix") {
      for (const std::string& t : Strings(v, key, "calibrate")) o.fit.fixed.push_back(sph::ParseFixedParameter(t, "fix " + t));
    } else if (key == "prior") {
      for (const std::string& t : Strings(v, key, "calibrate")) o.fit.priors.push_back(sph::ParseParameterPrior(t, "prior " + t));
    } else if (key == "robust_loss") {
      const std::string loss = Cast<std::string>(v, key, "calibrate");
      if (loss != "huber" && loss != "cauchy") {
        throw sph::Error("robust_loss: expected 'huber' or 'cauchy', got '" + loss + "'");
      }
      o.fit.robust_loss = loss == "cauchy" ? sph::RobustLoss::kCauchy : sph::RobustLoss::kHuber;
    } else if (key == "robust_scale_sigma") {
      o.fit.robust_scale_sigma = Cast<double>(v, key, "calibrate");
    } else if (key == "max_std_um") {
      o.fit.max_std_um = Cast<double>(v, key, "calibrate");
      o.requirement.max_std_stated = true;  // given, it is the requirement (as sph_calibrate's option)
    } else if (key == "accept_rejected") {
      o.accept_rejected = Cast<bool>(v, key, "calibrate");
    } else if (key == "target_u") {
      for (const std::string& t : Strings(v, key, "calibrate")) {
        const sph::FixedParameter f = sph::ParseFixedParameter(t, "target_u " + t);
        if (!f.value || !(*f.value > 0.0)) {
          throw sph::Error("target_u " + t +
                           ": expected NAME_UNIT=U, U the largest expanded uncertainty (> 0) the use "
                           "allows, e.g. alpha_urad=5");
        }
        o.requirement.target_u.push_back({f.name, *f.value, t});
      }
    } else if (key == "max_iterations") {
      o.fit.max_iterations = Cast<int>(v, key, "calibrate");
    } else if (key == "harmonics") {
      const int h = Cast<int>(v, key, "calibrate");
      o.trace_options.harmonics = {h, h};
    } else if (key == "phi_wobble_pivot_mm") {
      o.trace_options.phi_wobble_pivot_mm = Cast<double>(v, key, "calibrate");
    } else if (key == "drift_order") {
      o.trace_options.drift_order = Cast<int>(v, key, "calibrate");
    } else if (key == "hold_confounded") {
      o.trace_options.hold_confounded = Cast<bool>(v, key, "calibrate");
    } else if (key == "seed") {
      o.trace_options.seed = Cast<std::uint64_t>(v, key, "calibrate");
    } else if (key == "coverage") {
      o.coverage = Cast<double>(v, key, "calibrate");
    } else {
      for (const sph::ConditionField& f : sph::kConditionFields) {
        if (key == f.key) o.conditions.*f.field = Cast<double>(v, key, "calibrate");
      }
    }
  }
  o.Check();
  return o;
}

// A calibration's result: what the library renders (the JSON report, the text report, the
// calibration file), the JSON parsed by Python's json module, and views of it.
struct Calibration {
  py::dict report;
  std::string text;
  std::string calibration_file;  // empty when the calibration is not usable
  py::dict parameters;
  std::vector<std::string> parameter_names;
  py::array_t<double> covariance;
  py::array_t<double> residuals_um;        // the reported calibration's, file order
  py::array_t<double> residuals_seven_um;  // the seven-error fit's
  std::shared_ptr<const sph::CalibrationWorkflowResult> run;  // for dcc()
};

py::array_t<double> Micrometres(const std::vector<double>& mm) {
  py::array_t<double> a(static_cast<py::ssize_t>(mm.size()));
  auto m = a.mutable_unchecked<1>();
  for (std::size_t i = 0; i < mm.size(); ++i) m(static_cast<py::ssize_t>(i)) = mm[i] * sph::kUmPerMm;
  return a;
}

// What a calibration run renders, taken while the GIL is released.
struct RenderedCalibration {
  std::string json, text, file;
  std::vector<double> residuals_mm, residuals_seven_mm;
  std::shared_ptr<const sph::CalibrationWorkflowResult> run;
};

RenderedCalibration Render(sph::CalibrationWorkflowResult&& result) {
  RenderedCalibration r;
  r.run = std::make_shared<const sph::CalibrationWorkflowResult>(std::move(result));
  const sph::CalibrationWorkflowResult& run = *r.run;
  r.json = run.JsonReport();
  std::ostringstream out;
  run.WriteTextReport(out);
  r.text = out.str();
  if (run.usability.usable) {
    std::ostringstream cal;
    sph::WriteCalibration(cal, run.MakeCalibrationFile());
    r.file = cal.str();
  }
  r.residuals_mm = run.Reported().residuals_mm;
  r.residuals_seven_mm = run.seven.residuals_mm;
  return r;
}

// `key` of the report's dict `d`, or None when the report leaves it out.
py::object Get(const py::dict& d, const char* key) { return d.contains(key) ? py::object(d[key]) : py::none(); }

Calibration Calibrate(py::object path_or_points, const py::kwargs& kwargs) {
  const sph::CalibrationWorkflowOptions options = CalibrationOptionsOf(kwargs);
  RenderedCalibration r;
  if (py::isinstance<Points>(path_or_points)) {
    Points points = py::cast<Points>(path_or_points);  // a copy: the workflow takes its points
    r = Interruptible([&] {
      const std::string source = points.data.source;
      return Render(sph::RunCalibrationWorkflow(std::move(points.data), source, options));
    });
  } else {
    const std::string path = PathOf(path_or_points);
    r = Interruptible([&] { return Render(sph::RunCalibrationWorkflow(path, options)); });
  }
  Calibration c;
  c.report = py::module_::import("json").attr("loads")(r.json);
  c.text = std::move(r.text);
  c.calibration_file = std::move(r.file);
  c.residuals_um = Micrometres(r.residuals_mm);
  c.residuals_seven_um = Micrometres(r.residuals_seven_mm);
  c.run = r.run;
  const py::dict params = c.report["parameters"];
  for (auto name : c.report["parameter_order"]) c.parameter_names.push_back(py::cast<std::string>(name));
  const auto n = static_cast<py::ssize_t>(c.parameter_names.size());
  // Each parameter's standard uncertainty; NaN where the report states none (undetermined, or the
  // fit not analysed). A held parameter's is 0.
  std::vector<double> std_of(c.parameter_names.size(), std::numeric_limits<double>::quiet_NaN());
  for (py::ssize_t i = 0; i < n; ++i) {
    const py::dict p = params[py::str(c.parameter_names[i])];
    const py::object sd = Get(p, "std");
    if (!sd.is_none()) std_of[i] = py::cast<double>(sd);
    py::dict entry;
    entry["value"] = p["value"];
    entry["std"] = sd;
    entry["U"] = Get(p, "U");  // none for a parameter held or undetermined, or without a budget
    entry["unit"] = p["unit"];
    c.parameters[py::str(c.parameter_names[i])] = entry;
  }
  // The covariance in the report's units: its correlations scaled by the standard uncertainties
  // (a held parameter, std 0, has none with the others; NaN where a standard uncertainty or a
  // correlation is not stated).
  c.covariance = py::array_t<double>({n, n});
  auto cov = c.covariance.mutable_unchecked<2>();
  const py::object rows = Get(c.report, "correlation");
  for (py::ssize_t i = 0; i < n; ++i) {
    const py::list row = rows.is_none() ? py::list(n) : py::list(rows[py::int_(i)]);  // None: not stated
    for (py::ssize_t j = 0; j < n; ++j) {
      const bool held = std_of[i] == 0.0 || std_of[j] == 0.0;
      cov(i, j) = held               ? 0.0
                  : row[j].is_none() ? std::numeric_limits<double>::quiet_NaN()
                                     : py::cast<double>(row[j]) * (std_of[i] * std_of[j]);
    }
  }
  return c;
}

// The calibration a compensation uses: a calibration file's path, or a CalibrationResult's file.
sph::Calibration CalibrationOf(const py::handle& calibration) {
  if (py::isinstance<Calibration>(calibration)) {
    const Calibration& c = py::cast<const Calibration&>(calibration);
    if (c.calibration_file.empty())
      throw sph::Error("calibration: the calibration is not usable (no calibration file)");
    std::istringstream in(c.calibration_file);
    return sph::ToCalibration(
        sph::ParseCalibration(in, "<calibration of " + std::string(py::str(c.report["points_file"])) + ">"));
  }
  const std::string path = PathOf(calibration);
  py::gil_scoped_release release;
  return sph::LoadCalibration(path);
}

// The compensated points [mm] of readings: sph.Points or an (n, 3) array of theta_deg phi_deg r_mm,
// which is checked as a points file's rows are (sph::PointsFromColumns()).
py::array_t<double> Compensate(const py::object& readings, const py::object& calibration, const py::object& center_mm) {
  const std::vector<sph::Sample>* samples = nullptr;
  std::optional<sph::PointsData> checked;
  if (py::isinstance<Points>(readings)) {
    samples = &py::cast<const Points&>(readings).data.samples;
  } else {
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(readings);
    if (!a || a.ndim() != 2 || a.shape(1) != 3) {
      PyErr_Clear();
      throw sph::Error("compensate: readings must be sph.Points or an (n, 3) array of theta_deg phi_deg r_mm");
    }
    sph::PointsColumns columns;
    columns.n = static_cast<std::size_t>(a.shape(0));
    columns.stride = 3;
    columns.theta_deg = a.data();
    columns.phi_deg = a.data() + 1;
    columns.r_mm = a.data() + 2;
    {
      py::gil_scoped_release release;
      checked = sph::PointsFromColumns({}, columns, "compensate: readings");
    }
    samples = &checked->samples;
  }
  std::optional<Eigen::Vector3d> center;
  if (!center_mm.is_none()) {
    const auto c = py::cast<std::vector<double>>(center_mm);
    if (c.size() != 3) throw sph::Error("compensate: center_mm must be 3 numbers (x y z)");
    for (std::size_t k = 0; k < 3; ++k) {
      sph::CheckedValue(c[k], sph::ranges::kCenterMm, std::string("compensate: center_mm ") + "xyz"[k]);
    }
    center = Eigen::Vector3d(c[0], c[1], c[2]);
  }
  const sph::Calibration cal = CalibrationOf(calibration);
  std::vector<Eigen::Vector3d> points;
  {
    py::gil_scoped_release release;
    points = center ? sph::CompensateAll(cal, *samples, *center) : sph::CompensateAll(cal, *samples);
  }
  py::array_t<double> out({static_cast<py::ssize_t>(points.size()), py::ssize_t{3}});
  auto m = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (int k = 0; k < 3; ++k) m(static_cast<py::ssize_t>(i), k) = points[i][k];
  }
  return out;
}

// A measurement's result: the reports the library renders and the compensated points.
struct Measurement {
  py::dict report;
  std::string text;
  py::array_t<double> points_mm;
  std::shared_ptr<const sph::MeasurementWorkflowResult> run;  // for dcc()
};

// The laboratory's settings of a certificate: the file `settings` (a path, or None), then the
// keywords (each key of the settings file, a str or a list of them), which replace its values.
sph::dcc::Settings DccSettingsOf(const py::object& settings, const py::kwargs& keys) {
  sph::dcc::Settings s;
  if (!settings.is_none()) s = sph::dcc::ReadSettings(PathOf(settings));
  std::string text;
  for (const auto& [k, v] : keys) {
    const std::string key = py::cast<std::string>(k);
    std::vector<std::string> values;
    if (py::isinstance<py::str>(v)) {
      values.push_back(py::cast<std::string>(v));
    } else {
      values = py::cast<std::vector<std::string>>(v);
    }
    for (const std::string& value : values) {
      if (value.find('\n') != std::string::npos) throw sph::Error("dcc: " + key + ": a value of one line is expected");
      text += key + ": " + value + "\n";
    }
  }
  std::istringstream in(text);
  const sph::dcc::Settings given = sph::dcc::ParseSettings(in, "<keywords>");
  std::vector<sph::dcc::Field> kept;
  for (const sph::dcc::Field& f : s.fields) {
    const bool replaced =
        std::any_of(given.fields.begin(), given.fields.end(), [&](const sph::dcc::Field& g) { return g.key == f.key; });
    if (!replaced) kept.push_back(f);
  }
  kept.insert(kept.end(), given.fields.begin(), given.fields.end());
  s.fields = kept;
  return s;
}

// sph_measure's options as keyword arguments (its names with '_' for '-', calibration for -c).
sph::MeasurementWorkflowOptions MeasurementOptionsOf(const py::kwargs& kwargs) {
  sph::MeasurementWorkflowOptions o;
  for (auto item : kwargs) {
    const std::string key = py::str(item.first);
    const py::handle v = item.second;
    CheckKeyword(key, kMeasureKeywords, "measure", false);
    if (v.is_none()) continue;  // not given
    if (key == "calibration")
      o.calibration_path = PathOf(v);
    else if (key == "xyz")
      o.xyz = Cast<bool>(v, key, "measure");
    else if (key == "subtract_sphere_form")
      o.subtract_sphere_form = Cast<bool>(v, key, "measure");
    else if (key == "setup")
      o.setup = Cast<int>(v, key, "measure");
    else if (key == "uncertainty_samples")
      o.uncertainty_samples = Cast<int>(v, key, "measure");
    else if (key == "seed")
      o.seed = Cast<std::uint64_t>(v, key, "measure");
    else if (key == "max_dilution")
      o.max_dilution = Cast<double>(v, key, "measure");
    else if (key == "noise_um")
      o.noise_um = Cast<double>(v, key, "measure");
    else if (key == "noise_floor_draws")
      o.noise_floor_draws = Cast<int>(v, key, "measure");
    else if (key == "coverage")
      o.coverage = Cast<double>(v, key, "measure");
    else if (key == "mc_max_trials")
      o.mc_max_trials = Cast<long>(v, key, "measure");
    else if (key == "mc_batch_trials")
      o.mc_batch_trials = Cast<long>(v, key, "measure");
    else if (key == "mc_digits")
      o.mc_digits = Cast<int>(v, key, "measure");
    else if (key == "mc_max_points")
      o.mc_max_points = Cast<long>(v, key, "measure");
  }
  o.Check();
  return o;
}

// What a measurement run renders, taken while the GIL is released.
struct RenderedMeasurement {
  std::string json, text;
  std::vector<Eigen::Vector3d> points;
  std::shared_ptr<const sph::MeasurementWorkflowResult> run;
};

RenderedMeasurement Render(sph::MeasurementWorkflowResult&& result) {
  RenderedMeasurement r;
  r.run = std::make_shared<const sph::MeasurementWorkflowResult>(std::move(result));
  const sph::MeasurementWorkflowResult& run = *r.run;
  r.json = run.JsonReport();
  std::ostringstream out;
  run.WriteTextReport(out);
  r.text = out.str();
  r.points = run.input.points_mm;
  return r;
}

Measurement Measure(const py::object& path_or_points, const py::kwargs& kwargs) {
  const sph::MeasurementWorkflowOptions options = MeasurementOptionsOf(kwargs);
  RenderedMeasurement run;
  if (py::isinstance<Points>(path_or_points)) {
    Points points = py::cast<Points>(path_or_points);  // a copy: the workflow takes its points
    run = Interruptible([&] {
      const std::string source = points.data.source;
      return Render(sph::RunMeasurementWorkflow(std::move(points.data), source, options));
    });
  } else {
    const std::string path = PathOf(path_or_points);
    run = Interruptible([&] { return Render(sph::RunMeasurementWorkflow(path, options)); });
  }
  Measurement r;
  r.run = run.run;
  r.report = py::module_::import("json").attr("loads")(run.json);
  r.text = std::move(run.text);
  r.points_mm = py::array_t<double>({static_cast<py::ssize_t>(run.points.size()), py::ssize_t{3}});
  auto m = r.points_mm.mutable_unchecked<2>();
  for (std::size_t i = 0; i < run.points.size(); ++i) {
    for (int k = 0; k < 3; ++k) m(static_cast<py::ssize_t>(i), k) = run.points[i][k];
  }
  return r;
}

// A value of an option that the app takes as text ("2,0,0", "theta_encoder.c2=10"): a str as it
// is, numbers joined by commas, each in its shortest exact form ("%.17g").
std::string OptionText(const py::handle& value) {
  if (py::isinstance<py::str>(value)) return py::cast<std::string>(value);
  std::string text;
  char buf[32];
  for (const double x : py::cast<std::vector<double>>(value)) {
    std::snprintf(buf, sizeof buf, "%.17g", x);
    text += (text.empty() ? "" : ",") + std::string(buf);
  }
  return text;
}

// The values of a repeatable option: one text (a str, a number, or numbers as one value), or a
// sequence of them.
std::vector<std::string> OptionTexts(const py::handle& value) {
  if (py::isinstance<py::str>(value)) return {py::cast<std::string>(value)};
  if (!py::isinstance<py::sequence>(value)) return {OptionText(py::make_tuple(value))};  // mount_unknown=1
  const py::sequence items = py::cast<py::sequence>(value);
  if (items.size() > 0 && !py::isinstance<py::str>(items[0]) && !py::isinstance<py::sequence>(items[0])) {
    return {OptionText(value)};  // (2, 0, 0): one value of numbers
  }
  std::vector<std::string> texts;
  for (const py::handle item : items) texts.push_back(OptionText(item));
  return texts;
}

// The keywords of a function taking an options struct: each sets its field from a Python value.
template <typename Options>
struct Keyword {
  const char* name;
  std::function<void(Options&, const py::handle&)> set;
  std::string expected = "a str, a number or a sequence of them";  // what `set` takes, for a TypeError
};

template <typename Options, typename T>
Keyword<Options> Number(const char* name, T Options::*field) {
  return {name, [field](Options& o, const py::handle& v) { o.*field = py::cast<T>(v); }, Expected<T>()};
}

// The simulated machine's keywords (sph_simulate's and sph_montecarlo's --alpha-deg ... --noise-phi-arcsec).
template <typename Options>
void AddMachineKeywords(std::vector<Keyword<Options>>& k) {
  const auto machine = [](const char* name, auto sph::MachineOptions::*field) {
    using T = std::remove_reference_t<decltype(std::declval<sph::MachineOptions>().*field)>;
    return Keyword<Options>{name, [field](Options& o, const py::handle& v) { o.machine.*field = py::cast<T>(v); },
                            Expected<T>()};
  };
  using M = sph::MachineOptions;
  k.push_back(machine("alpha_deg", &M::alpha_deg));
  k.push_back(machine("a_mm", &M::a_mm));
  k.push_back(machine("beta_deg", &M::beta_deg));
  k.push_back(machine("b_mm", &M::b_mm));
  k.push_back(machine("epsilon_deg", &M::epsilon_deg));
  k.push_back(machine("c_mm", &M::c_mm));
  k.push_back(machine("d_prime_mm", &M::d_prime_mm));
  k.push_back(machine("sphere_radius_mm", &M::sphere_radius_mm));
  k.push_back(machine("probe_offset_mm", &M::probe_offset_mm));
  k.push_back(machine("theta_steps", &M::theta_steps));
  k.push_back(machine("phi_steps", &M::phi_steps));
  k.push_back({"angles", [](Options& o, const py::handle& v) { o.machine.angles_path = PathOf(v); }, "a str or a path"});
  k.push_back(machine("noise_r_um", &M::noise_r_um));
  k.push_back(machine("noise_theta_arcsec", &M::noise_theta_arcsec));
  k.push_back(machine("noise_phi_arcsec", &M::noise_phi_arcsec));
}

template <typename Options>
Keyword<Options> Texts(const char* name, std::vector<std::string> Options::*field) {
  return {name, [field](Options& o, const py::handle& v) { o.*field = OptionTexts(v); }};
}

// sph_simulate's options as keywords (its names with '_' for '-', without -o and --truth).
const std::vector<Keyword<sph::SimulationOptions>>& SimulateKeywords() {
  using S = sph::SimulationOptions;
  static const std::vector<Keyword<S>> keywords = [] {
    std::vector<Keyword<S>> k;
    AddMachineKeywords(k);
    k.push_back(Texts("center_mm", &S::centers_mm));
    k.push_back(Number("seed", &S::seed));
    k.push_back(Number("sample_period_s", &S::sample_period_s));
    k.push_back(Texts("effect_arcsec", &S::effects_arcsec));
    k.push_back(Texts("effect_um", &S::effects_um));
    k.push_back({"probe_range_mm", [](S& o, const py::handle& v) { o.probe_range_mm = py::cast<double>(v); }, Expected<double>()});
    k.push_back(Number("phi_wobble_pivot_mm", &S::phi_wobble_pivot_mm));
    k.push_back(Texts("mount_rotation_deg", &S::mount_rotations_deg));
    k.push_back(Texts("mount_unknown", &S::mount_unknown));
    k.push_back(Texts("other_sphere_radius_mm", &S::sphere_radii_mm));
    k.push_back({"form_um", [](S& o, const py::handle& v) { o.form.harmonics_um = OptionTexts(v); }});
    k.push_back({"form_flat_um", [](S& o, const py::handle& v) { o.form.flats_um = OptionTexts(v); }});
    k.push_back({"form_bump_um", [](S& o, const py::handle& v) { o.form.bumps_um = OptionTexts(v); }});
    k.push_back(Texts("scan_order", &S::scan_orders));
    k.push_back(Number("outlier_fraction", &S::outlier_fraction));
    k.push_back(Number("outlier_um", &S::outlier_um));
    return k;
  }();
  return keywords;
}

// sph_montecarlo's options of a study as keywords (without the plans and the files it writes).
const std::vector<Keyword<sph::MonteCarloOptions>>& MonteCarloKeywords() {
  using C = sph::MonteCarloOptions;
  static const std::vector<Keyword<C>> keywords = [] {
    std::vector<Keyword<C>> k;
    AddMachineKeywords(k);
    k.push_back({"eccentricities_mm", [](C& o, const py::handle& v) {
                   o.eccentricities_mm = py::isinstance<py::sequence>(v) ? py::cast<std::vector<double>>(v)
                                                                         : std::vector<double>{py::cast<double>(v)};
                 },
                 "a float or a sequence of floats"});
    k.push_back({"direction", [](C& o, const py::handle& v) { o.direction = OptionText(v); }});
    k.push_back(Number("random_direction", &C::random_direction));
    k.push_back(Number("setups", &C::setups));
    k.push_back(Number("trials", &C::trials));
    k.push_back(Number("seed", &C::seed));
    k.push_back(Number("threads", &C::threads));
    k.push_back(Number("max_std_um", &C::max_std_um));
    k.push_back(Number("table3", &C::table3));
    k.push_back(Number("table3_calibration_e_mm", &C::table3_calibration_e_mm));
    return k;
  }();
  return keywords;
}

// The options of `kwargs` by `keywords`; a TypeError naming an unknown one, as Python's own.
template <typename Options>
Options OptionsOf(const py::kwargs& kwargs, const std::vector<Keyword<Options>>& keywords, const char* function) {
  Options o;
  for (auto item : kwargs) {
    const std::string key = py::str(item.first);
    const auto k = std::find_if(keywords.begin(), keywords.end(), [&](const auto& w) { return key == w.name; });
    if (k == keywords.end()) {
      throw py::type_error(std::string(function) + "() got an unexpected keyword argument '" + key + "'");
    }
    try {
      if (!item.second.is_none()) k->set(o, item.second);  // None: not given
    } catch (const py::cast_error&) {
      throw py::type_error(std::string(function) + "(): " + key + " takes " + k->expected + ", not " +
                           Described(item.second));
    }
  }
  return o;
}

py::tuple Simulate(const py::kwargs& kwargs) {
  const auto options = OptionsOf(kwargs, SimulateKeywords(), "simulate");
  sph::SimulationRun run = Interruptible([&] { return sph::RunSimulation(options); });
  run.points.source = "<simulated>";
  return py::make_tuple(Points{std::move(run.points)}, py::module_::import("json").attr("loads")(run.truth_json));
}

// A Monte Carlo study's result: its report and the estimate of every converged trial.
struct MonteCarloResult {
  py::dict report;
  py::dict trials;
};

MonteCarloResult MonteCarlo(const py::kwargs& kwargs) {
  const auto options = OptionsOf(kwargs, MonteCarloKeywords(), "monte_carlo");
  sph::MonteCarloRun run;
  std::string json;
  std::tie(run, json) = Interruptible([&] {
    sph::MonteCarloRun study = sph::RunMonteCarloStudy(options);
    std::string report = study.JsonReport();
    return std::make_pair(std::move(study), std::move(report));
  });
  MonteCarloResult r;
  r.report = py::module_::import("json").attr("loads")(json);
  // The per-trial table: one row per converged trial, eccentricity by eccentricity, trials numbered
  // from 1 as the report's not_converged_trials; the estimates in the report's units.
  py::ssize_t n = 0;
  for (const auto& row : run.study.rows) n += static_cast<py::ssize_t>(row.estimates.size());
  py::array_t<double> eccentricity(n);
  py::array_t<std::int32_t> trial(n);
  std::vector<py::array_t<double>> columns;
  for (int p = 0; p < sph::kNumScmsParams; ++p) columns.emplace_back(n);
  py::ssize_t i = 0;
  for (const auto& row : run.study.rows) {
    std::size_t next = 0;  // the next converged trial's estimate
    for (int t = 0; t < row.trials && next < row.estimates.size(); ++t) {
      if (std::find(row.not_converged.begin(), row.not_converged.end(), t) != row.not_converged.end()) continue;
      eccentricity.mutable_at(i) = row.eccentricity_mm;
      trial.mutable_at(i) = t + 1;
      for (int p = 0; p < sph::kNumScmsParams; ++p) {
        columns[static_cast<std::size_t>(p)].mutable_at(i) = row.estimates[next][p] * sph::ReportUnitsOf(p).to_coarse;
      }
      ++next;
      ++i;
    }
  }
  r.trials["eccentricity_mm"] = eccentricity;
  r.trials["trial"] = trial;
  for (int p = 0; p < sph::kNumScmsParams; ++p) {
    r.trials[py::str(std::string(sph::kScmsParamInfo[static_cast<std::size_t>(p)].name) + "_" +
                     sph::ReportUnitsOf(p).coarse)] = columns[static_cast<std::size_t>(p)];
  }
  return r;
}

}  // namespace

PYBIND11_MODULE(sph, m) {
  m.doc() =
      "Calibration of spherical coordinate measuring systems: points files, the calibration and measurement\n"
      "workflows, simulated readings of a known machine and the Monte Carlo study.";
  m.attr("__version__") = SPH_VERSION;
  static py::exception<sph::Error> error(m, "Error", PyExc_ValueError);
  error.doc() = "Bad input: the library's message names the file, line and problem.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const sph::Error& e) {
      PyErr_SetString(error.ptr(), e.what());
    }
  });

  py::class_<Points>(m, "Points",
                     "Readings of a points file (sph-points 1): the columns as NumPy arrays and the header.")
      .def(py::init(&MakePoints), py::arg("theta_deg"), py::arg("phi_deg"), py::arg("r_mm"),
           py::arg("t_s") = py::none(), py::arg("setup") = py::none(), py::arg("header") = py::none(),
           py::arg("source") = "<points>",
           "Points from arrays and a header dict (key -> value as a file states it), checked as a file is "
           "(a key that is not a header key, a value with a line break, a setup that is not an integer "
           "are refused); `source` names them in messages. Float64 arrays in C order are read without a copy.")
      .def_property_readonly(
          "theta_deg",
          [](const Points& p) { return Column<double>(p.data, [](const sph::Sample& s) { return s.theta_deg; }); },
          "Theta axis readings [deg], float64, shape (n,)")
      .def_property_readonly(
          "phi_deg",
          [](const Points& p) { return Column<double>(p.data, [](const sph::Sample& s) { return s.phi_deg; }); },
          "Phi axis readings [deg], float64, shape (n,)")
      .def_property_readonly(
          "r_mm", [](const Points& p) { return Column<double>(p.data, [](const sph::Sample& s) { return s.r_mm; }); },
          "Probe readings [mm], float64, shape (n,)")
      .def_property_readonly(
          "t_s", [](const Points& p) { return Column<double>(p.data, [](const sph::Sample& s) { return s.t_s; }); },
          "Acquisition times [s] (the row index without a t_s column), float64, shape (n,)")
      .def_property_readonly(
          "setup",
          [](const Points& p) {
            return Column<std::int32_t>(p.data,
                                        [](const sph::Sample& s) { return static_cast<std::int32_t>(s.setup); });
          },
          "Setup id of each reading (0 without a setup column), int32, shape (n,)")
      .def_property_readonly(
          "header", [](const Points& p) { return HeaderDict(p.data); },
          "The header fields, key -> value text, as the file states them")
      .def_property_readonly(
          "source", [](const Points& p) { return p.data.source; }, "Where they came from")
      .def("__len__", [](const Points& p) { return p.data.samples.size(); })
      .def("__repr__", [](const Points& p) {
        return "<sph.Points '" + p.data.source + "': " + std::to_string(p.data.samples.size()) + " readings, " +
               std::to_string(p.data.SetupIds().size()) + " setup(s)>";
      });

  m.def(
      "read_points",
      [](const py::object& path_like) {
        const std::string path = PathOf(path_like);
        py::gil_scoped_release release;
        return Points{sph::ReadPointsFile(path)};
      },
      py::arg("path"), "Reads a points file (sph-points 1). Raises sph.Error 'path:line: problem' on a defect.");
  m.def(
      "write_points",
      [](const py::object& path_like, const Points& points) {
        const std::string path = PathOf(path_like);
        py::gil_scoped_release release;
        sph::WritePointsFile(path, points.data);
      },
      py::arg("path"), py::arg("points"), "Writes points as a points file (sph-points 1), atomically.");

  py::class_<Calibration>(m, "CalibrationResult", "A calibration run's result (sph.calibrate).")
      .def_readonly("report", &Calibration::report, "The report as sph_calibrate --json writes it, as a dict")
      .def_readonly("text", &Calibration::text, "The text report as sph_calibrate prints it")
      .def_readonly("calibration_file", &Calibration::calibration_file,
                    "The calibration file's content (sph_calibrate -o), JSON text; '' when not usable")
      .def_readonly("parameters", &Calibration::parameters,
                    "name -> {'value', 'std', 'U', 'unit'} in the report's units; 'std' and 'U' None where\n"
                    "the report states none (a parameter held or undetermined, a fit without a budget)")
      .def_readonly("parameter_names", &Calibration::parameter_names, "The covariance's row and column order")
      .def_readonly("covariance", &Calibration::covariance,
                    "Covariance of the parameters in the report's units (squared), shape (n, n); 0 for a\n"
                    "held parameter, NaN where the report states no standard uncertainty or correlation")
      .def_readonly(
          "residuals_um", &Calibration::residuals_um,
          "Residual of each reading, |p - O| - R, of the calibration reported [um], file order (outliers too)")
      .def_readonly("residuals_seven_um", &Calibration::residuals_seven_um,
                    "The same of the seven-error fit [um] (before the effects the trace added)")
      .def_property_readonly(
          "usable", [](const Calibration& c) { return py::cast<bool>(c.report["usable"]); },
          "Whether the calibration is usable (the report's verdict)")
      .def_property_readonly(
          "why_not_usable",
          [](const Calibration& c) {
            return c.report.contains("why_not_usable") ? py::list(c.report["why_not_usable"]) : py::list();
          },
          "Why it is not usable, the report's reasons (empty when usable)")
      .def(
          "dcc",
          [](const Calibration& c, const py::object& settings, const py::kwargs& keys) {
            const sph::dcc::Settings lab = DccSettingsOf(settings, keys);
            py::gil_scoped_release release;
            return c.run->Dcc(lab);
          },
          py::arg("settings") = py::none(),
          "The Digital Calibration Certificate as sph_calibrate --dcc writes it (XML text; docs/dcc.md): the\n"
          "administrative data from the settings file `settings` and the keywords (its keys: certificate_id=...,\n"
          "responsible_person=[...]), which replace the file's, and the points header. Raises sph.Error\n"
          "naming each key missing.")
      .def("__repr__", [](const Calibration& c) {
        std::ostringstream s;
        s << "<sph.CalibrationResult '" << std::string(py::str(c.report["points_file"]))
          << "': " << (py::cast<bool>(c.report["usable"]) ? "usable" : "not usable") << ", rms ";
        if (c.report.contains("after")) {
          s << std::string(py::str(c.report["before"]["rms_um"])) << " -> "
            << std::string(py::str(c.report["after"]["rms_um"]));
        } else {
          s << std::string(py::str(c.report["fit"]["rms_um"]));
        }
        s << " um, " << c.parameter_names.size() << " parameters>";
        return s.str();
      });

  m.def("calibrate", &Calibrate, py::arg("path_or_points"),
        "Runs the calibration workflow (what sph_calibrate does) on a points file's path or on sph.Points.\n"
        "Options are sph_calibrate's, '_' for '-': no_trace, effects, validate, compare, sphere_radius_mm,\n"
        "probe_offset_mm, fix, prior, robust_loss, robust_scale_sigma, max_std_um, max_iterations,\n"
        "harmonics, phi_wobble_pivot_mm, drift_order, hold_confounded, seed, coverage and the\n"
        "conditions (sphere_radius_u_um, sphere_temperature_c, ...). Raises TypeError on an unknown\n"
        "option, sph.Error on bad input.");

  m.def("compensate", &Compensate, py::arg("readings"), py::arg("calibration"), py::kw_only(),
        py::arg("center_mm") = py::none(),
        "The compensated points [mm], float64 shape (n, 3) x y z, of readings (sph.Points or an (n, 3)\n"
        "array of theta_deg phi_deg r_mm) with a calibration (a calibration file's path or a\n"
        "CalibrationResult). A probe_incidence term needs the measured sphere's centre, center_mm;\n"
        "without it the term is left out (sph.measure finds the centre itself).");

  py::class_<Measurement>(m, "MeasurementResult", "A sphere measurement's result (sph.measure).")
      .def_readonly("report", &Measurement::report, "The report as sph_measure --json writes it, as a dict")
      .def_readonly("text", &Measurement::text, "The text report as sph_measure prints it")
      .def_readonly("points_mm", &Measurement::points_mm, "The compensated points [mm], shape (n, 3) x y z")
      .def(
          "dcc",
          [](const Measurement& r, const py::object& settings, const py::kwargs& keys) {
            const sph::dcc::Settings lab = DccSettingsOf(settings, keys);
            py::gil_scoped_release release;
            return r.run->Dcc(lab);
          },
          py::arg("settings") = py::none(),
          "The Digital Calibration Certificate as sph_measure --dcc writes it (XML text; docs/dcc.md), the\n"
          "administrative data as CalibrationResult.dcc() takes them.")
      .def("__repr__", [](const Measurement& r) {
        return "<sph.MeasurementResult: " + std::to_string(r.points_mm.shape(0)) + " points>";
      });
  m.def("measure", &Measure, py::arg("path_or_points"),
        "Measures a sphere (what sph_measure does) of a points file's path or of sph.Points: the\n"
        "readings compensated with calibration=<file>, the least-squares and minimum-zone spheres, their\n"
        "uncertainties. Options are sph_measure's, '_' for '-': calibration, xyz, subtract_sphere_form,\n"
        "setup, uncertainty_samples, seed, max_dilution, noise_um, noise_floor_draws, coverage,\n"
        "mc_max_trials, mc_batch_trials, mc_digits, mc_max_points. Raises TypeError on an unknown option, sph.Error on "
        "bad input.");

  m.def("simulate", &Simulate,
        "Simulated readings of a known machine (what sph_simulate writes): returns (points, truth), the\n"
        "readings as sph.Points and the truth as the dict sph_simulate --truth writes. Options are\n"
        "sph_simulate's, '_' for '-': alpha_deg, a_mm, beta_deg, b_mm, epsilon_deg, c_mm, d_prime_mm,\n"
        "sphere_radius_mm, probe_offset_mm, theta_steps, phi_steps, angles, noise_r_um,\n"
        "noise_theta_arcsec, noise_phi_arcsec, center_mm, seed, sample_period_s, effect_arcsec,\n"
        "effect_um, probe_range_mm, phi_wobble_pivot_mm, mount_rotation_deg, mount_unknown,\n"
        "other_sphere_radius_mm, form_um, form_flat_um, form_bump_um, scan_order, outlier_fraction,\n"
        "outlier_um. A repeatable option takes a str in the app's words (\"theta_encoder.c2=10\") or a\n"
        "list of them; a value of numbers (center_mm) also a sequence of them: center_mm=[(2, 0, 0),\n"
        "(0, 2, 0)]. Raises TypeError on an unknown option, sph.Error on bad input.");

  py::class_<MonteCarloResult>(m, "MonteCarloResult", "A Monte Carlo study's result (sph.monte_carlo).")
      .def_readonly("report", &MonteCarloResult::report, "The report as sph_montecarlo --json writes it, as a dict")
      .def_readonly("trials", &MonteCarloResult::trials,
                    "Every converged trial's estimates: 'eccentricity_mm', 'trial' (from 1, int32) and one\n"
                    "float64 array per parameter in the report's units (alpha_deg, a_mm, ..., d_prime_mm)")
      .def("__repr__", [](const MonteCarloResult& r) {
        return "<sph.MonteCarloResult: " + std::string(py::str(r.report["trials"])) + " trials at " +
               std::to_string(py::len(r.report["eccentricities"])) + " eccentricities, " +
               std::to_string(py::len(r.trials["trial"])) + " converged>";
      });
  m.def("monte_carlo", &MonteCarlo,
        "The Monte Carlo study of the calibration (what sph_montecarlo does): repeated calibrations of\n"
        "simulated readings per eccentricity against the Cramer-Rao prediction. Options are\n"
        "sph_montecarlo's, '_' for '-': trials, eccentricities_mm, direction, random_direction, setups,\n"
        "seed, threads, max_std_um, table3, table3_calibration_e_mm and the machine's (alpha_deg ...\n"
        "noise_phi_arcsec, as sph.simulate). Raises TypeError on an unknown option, sph.Error on bad input.");
}
