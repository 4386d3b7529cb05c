#include "measure_cmd.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "app_common.hpp"
#include "gnuplot.hpp"
#include "sph/core/calibration_file.hpp"
#include "sph/core/error.hpp"
#include "sph/core/gum.hpp"
#include "sph/core/noise_floor.hpp"
#include "sph/core/output_files.hpp"
#include "sph/core/points_file.hpp"
#include "sph/core/setup_checks.hpp"
#include "sph/core/sphere_measurement.hpp"
#include "sph/core/xyz_file.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/compensation.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/units.hpp"
#include "sph/sphere/sphere_fit.hpp"

namespace sph::apps {
namespace {

using nlohmann::json;

using gum::BudgetInput;
using gum::EvaluationType;
using internal::Format;

const char* const kProgram = "sph_measure";

/// What was read: the points to evaluate and, for readings, what compensated them.
struct Input {
  std::vector<Eigen::Vector3d> points_mm;
  std::vector<RawReading> readings;           ///< empty for x y z input
  std::optional<AppliedCalibration> applied;  ///< what compensated them, with its covariance
  std::string covariance_note;                ///< what of the calibration goes without its uncertainty
  std::optional<int> setup;
  std::optional<StatedSphereRadius> header_radius;  ///< the radius the points file states for the setup's sphere
  std::string description;                       ///< one line for the report
  std::string form_note;                         ///< what the calibration file says of the calibration sphere's form
  std::vector<std::string> warnings;             ///< readings that parse but look wrong (PlausibilityWarnings)
  std::optional<double> calibration_fit_rms_um;  ///< the calibration file's source.fit_rms_um
};

std::string Vec3Text(const Eigen::Vector3d& v, const char* fmt, double scale = 1.0) {
  return Format(fmt, v.x() * scale) + " " + Format(fmt, v.y() * scale) + " " + Format(fmt, v.z() * scale);
}

json Vec3Json(const Eigen::Vector3d& v, double scale = 1.0) {
  return json::array({v.x() * scale, v.y() * scale, v.z() * scale});
}

// x y z points, which need no calibration.
Input ReadXyzInput(const MeasureOptions& o) {
  if (!o.calibration_path.empty()) {
    throw Error("--calibration compensates readings (theta, phi, r); " + o.points_path +
                " is read as x y z coordinates (--xyz), which need none");
  }
  if (o.setup) throw Error("--setup selects a setup of a points file of readings, not of x y z coordinates (--xyz)");
  Input in;
  in.points_mm = ReadXyzFile(o.points_path);
  in.description = std::to_string(in.points_mm.size()) + " points (x y z)";
  return in;
}

// The setup to evaluate: --setup, else the file's only one (none when the file has no setup column).
std::optional<int> SelectedSetup(const MeasureOptions& o, const PointsData& data) {
  const std::vector<int> ids = data.SetupIds();
  if (o.setup) {
    if (std::find(ids.begin(), ids.end(), *o.setup) == ids.end()) {
      throw Error(o.points_path + ": there is no setup " + std::to_string(*o.setup));
    }
    return o.setup;
  }
  if (ids.size() > 1) {
    std::string list;
    for (const int id : ids) list += (list.empty() ? "" : " ") + std::to_string(id);
    throw Error(o.points_path + ": the file holds several setups (" + list +
                "), each a placement of a sphere: choose one with --setup");
  }
  if (data.has_setup) return ids.front();
  return std::nullopt;
}

// probe_incidence of `cal`, folded into the readings of `in` and taken out of `cal`, so that the
// calibration's draws compensate them alike. Its angle needs the sphere's centre: that of the
// points without it, then again.
void FoldProbeIncidence(const MeasureOptions& o, int term, Calibration& cal, Input& in) {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  for (int pass = 0; pass < 2; ++pass) {
    const LeastSquaresSphere fit = FitSphereLeastSquares(in.points_mm);
    if (!fit.sphere.ok) throw Error(o.points_path + ": the compensated points determine no sphere");
    center = fit.sphere.center;
    in.points_mm = CompensateAll(cal, in.readings, center);
  }
  std::vector<const double*> blocks;
  for (const auto& v : cal.effect_values) blocks.push_back(v.data());
  const ScmsErrorTrig<double> trig = ErrorTrigOf(cal.geometry.data());
  for (RawReading& r : in.readings) {
    r.r_mm += ProbeIncidenceError(cal.geometry.data(), trig, cal.effects, blocks.data(), EffectReading(r, 0.0),
                                  cal.probe_offset_mm, center.data());
  }
  cal.effects.terms.erase(cal.effects.terms.begin() + term);
  cal.effect_values.erase(cal.effect_values.begin() + term);
  in.points_mm = CompensateAll(cal, in.readings);
}

// What the report says of the calibration sphere's form the file holds (empty: none).
std::string FormNote(const MeasureOptions& o, const CalibrationFile& file) {
  if (file.form_terms.empty()) return "";
  int l_max = 0;
  for (const FormTerm& t : file.form_terms) l_max = std::max(l_max, t.l);
  return Format("the calibration sphere's form (degrees 2..%d, rms %.4f um over the whole sphere) ", l_max,
                FormRms(file.form_terms, file.form_values_mm) * kUmPerMm) +
         (o.subtract_sphere_form ? "is taken off the points (--subtract-sphere-form)"
                                 : "is in the calibration file; --subtract-sphere-form takes it off when "
                                   "these points are of that sphere");
}

// --subtract-sphere-form: the calibration sphere's form, turned as the sphere was mounted in the
// setup measured, taken off the points of `in` about their least-squares centre.
void TakeOffSphereForm(const MeasureOptions& o, const CalibrationFile& file, const PointsData& data,
                       AppliedCalibration& applied, Input& in) {
  if (file.form_terms.empty()) {
    throw Error(o.calibration_path +
                ": holds no form of the calibration sphere (sph_calibrate stores one when the sphere was measured "
                "in at least two known orientations on its mount), which --subtract-sphere-form takes off");
  }
  applied.form.rotation = CalibrationSphereRotation(data.header, in.setup.value_or(0), o.points_path);
  const LeastSquaresSphere ls = FitSphereLeastSquares(in.points_mm);
  if (!ls.sphere.ok) throw Error(o.points_path + ": the compensated points determine no sphere");
  applied.form.center_mm = ls.sphere.center;  // the form's directions are taken from here
  in.points_mm = ApplyCalibration(applied, in.readings);
}

// What of the calibration goes without its uncertainty (empty: nothing).
std::string CovarianceNote(const MeasureOptions& o, const AppliedCalibration& applied, const Calibration& cal) {
  std::vector<std::string> without;
  if (applied.covariance.size() > 0 && !applied.effects_in_covariance && !cal.effects.Empty()) {
    without.push_back("its effects are applied without their uncertainty");
  }
  if (applied.covariance.size() > 0 && !applied.form.Empty() && !applied.form_in_covariance) {
    without.push_back("the form is taken off without its uncertainty");
  }
  if (without.empty()) return "";
  return o.calibration_path + " holds the covariance of the seven errors alone: " + without.front() +
         (without.size() > 1 ? ", and " + without.back() : std::string());
}

// The calibration file's source.fit_rms_um, when it is a positive number.
std::optional<double> FitRmsOf(const CalibrationFile& file) {
  std::optional<double> rms;
  for (const auto& [key, value] : file.source) {
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (key == "fit_rms_um" && end != value.c_str() && *end == '\0' && v > 0.0 && std::isfinite(v)) rms = v;
  }
  return rms;
}

Input ReadInput(const MeasureOptions& o) {
  if (o.xyz) return ReadXyzInput(o);
  if (o.calibration_path.empty()) {
    throw Error(o.points_path +
                ": readings (theta, phi, r) need a calibration to become points: pass "
                "--calibration FILE, or --xyz when the file holds x y z coordinates");
  }
  Input in;
  const PointsData data = ReadPointsFile(o.points_path);
  in.warnings = PlausibilityWarnings(data);
  const CalibrationFile file = ReadCalibrationFile(o.calibration_path);
  Calibration cal = ToCalibration(file);
  CheckProbeOffsetMatches(data, cal.probe_offset_mm, o.calibration_path);
  if (const auto range = ConditionsOf(data.header).probe_range_mm)
    CheckReadingsInProbeRange(data, *range, "probe_range_mm");
  in.setup = SelectedSetup(o, data);
  for (const Sample& s : data.samples) {
    if (!in.setup || s.setup == *in.setup) in.readings.push_back({s.theta_deg, s.phi_deg, s.r_mm});
  }
  in.points_mm = CompensateAll(cal, in.readings);
  if (const int t = cal.effects.Find(Effect::kProbeIncidence); t >= 0) FoldProbeIncidence(o, t, cal, in);
  if (const std::size_t n = ProbeExtrapolations(cal, in.readings); n > 0) {
    const EffectReference& ref = cal.effects.reference;
    in.warnings.push_back(
        Format("%zu of %zu readings lie outside the probe readings the calibration's probe terms were "
               "fitted over (r_mm %.6f to %.6f): the probe polynomial is extrapolated there",
               n, in.readings.size(), ref.FitMin(), ref.FitMax()));
  }
  in.form_note = FormNote(o, file);
  AppliedCalibration applied = AppliedCalibration::Of(file, o.subtract_sphere_form);
  if (o.subtract_sphere_form) TakeOffSphereForm(o, file, data, applied, in);
  in.covariance_note = CovarianceNote(o, applied, cal);
  in.applied = std::move(applied);
  in.calibration_fit_rms_um = FitRmsOf(file);
  in.header_radius = SphereRadiusOfSetup(data.header, in.setup.value_or(0));
  in.description = std::to_string(in.readings.size()) + " readings" +
                   (in.setup ? " (setup " + std::to_string(*in.setup) + ")" : "") + ", compensated with " +
                   o.calibration_path;
  return in;
}

// --- form-error map -------------------------------------------------------------------------------

/// A gnuplot script (data inline) that draws the radial residuals about the least-squares sphere
/// over the sphere: azimuth about a pole against the angle from it, colour = residual [um]. The
/// pole is the z axis (for an SCMS the Theta axis, so the map is the machine's theta/phi) unless
/// the points form a cap, which is then centred at the top of the map. It draws to the variable
/// `png` when that is set (gnuplot -e), else to `png_path`.
std::string FormMapScript(const std::vector<Eigen::Vector3d>& points, const SphereEvaluation& ev,
                          const std::string& name, const std::string& png_path) {
  const bool cap = ev.coverage.cap_half_angle_deg <= 135.0;
  const Eigen::Vector3d e3 = cap ? ev.coverage.mean_direction : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d ref = std::abs(e3.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d e1 = (ref - ref.dot(e3) * e3).normalized();
  const Eigen::Vector3d e2 = e3.cross(e1);
  double max_abs_um = 0.0, max_polar_deg = 0.0;
  std::ostringstream data;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d v = (points[i] - ev.ls.sphere.center).normalized();
    const double polar = std::acos(std::clamp(v.dot(e3), -1.0, 1.0)) * kDegPerRad;
    double azimuth = std::atan2(v.dot(e2), v.dot(e1)) * kDegPerRad;
    if (azimuth < 0.0) azimuth += 360.0;
    const double res_um = ev.residuals_mm[i] * kUmPerMm;
    max_abs_um = std::max(max_abs_um, std::abs(res_um));
    max_polar_deg = std::max(max_polar_deg, polar);
    data << Format("%.4f %.4f %.6g\n", azimuth, polar, res_um);
  }
  if (!(max_abs_um > 0.0)) max_abs_um = 1e-6;
  const double y_max = std::min(180.0, 15.0 * std::ceil(max_polar_deg / 15.0 + 1e-9));
  const double point_size = std::clamp(2.4 * std::sqrt(300.0 / static_cast<double>(points.size())), 0.35, 2.4);

  std::ostringstream s;
  s << "# Form-error map written by sph_measure " SPH_VERSION ". Run: gnuplot <this file>\n"
    << "# Radial residuals about the least-squares sphere; data inline (azimuth_deg polar_deg residual_um).\n"
    << "set encoding utf8\n"
    << "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {\n"
    << "  set terminal pngcairo size 1200,680 enhanced font 'sans,11'\n"
    << "} else {\n"
    << "  set terminal png size 1200,680\n"
    << "}\n"
    << "if (!exists(\"png\")) png = " << GnuplotQuoted(png_path) << "\n"
    << "set output png\n";
  const std::string title = Format(
      "Form error of %s (%d points): radial residual about the least-squares sphere, R = %.6f mm\n"
      "sphericity: least squares %.4f µm, minimum zone %.4f µm",
      name.c_str(), ev.n_points, ev.ls.sphere.radius, ev.sphericity_ls_mm * kUmPerMm, ev.mz.width * kUmPerMm);
  s << "set title " << GnuplotDoubleQuoted(title) << " noenhanced\n";
  s << "set xlabel "
    << GnuplotQuoted(cap ? "azimuth about the cap's centre [deg]" : "azimuth about the z (Θ) axis [deg]") << "\n";
  s << "set ylabel " << GnuplotQuoted(cap ? "angle from the cap's centre [deg]" : "polar angle from +z [deg]") << "\n";
  s << "set cblabel 'radial residual [µm]'\n"
    << "set xrange [0:360]\nset xtics 0,45,360\n";
  s << Format("set yrange [%g:0]\nset ytics 0,15,%g\n", y_max, y_max);
  s << Format("set cbrange [%.6g:%.6g]\n", -max_abs_um, max_abs_um)
    << "set palette defined (0 '#2166ac', 0.25 '#67a9cf', 0.5 '#f7f7f7', 0.75 '#ef8a62', 1 '#b2182b')\n"
    << "set object 1 rectangle from graph 0,0 to graph 1,1 behind fillcolor rgb '#d9d9d9' fillstyle solid noborder\n"
    << "set grid front lc rgb '#ffffff'\nunset key\n"
    << "$residuals << EOD\n"
    << data.str() << "EOD\n";
  s << Format("plot $residuals using 1:2:3 with points pt 5 ps %.2f lc palette\n", point_size);
  return s.str();
}

/// Stages the form-error map: the script (--plot-script) and the image (--plot), drawn now.
void DrawFormMap(const MeasureOptions& o, const std::vector<Eigen::Vector3d>& points, const SphereEvaluation& ev,
                 OutputFiles& files) {
  const std::string name = o.points_path.substr(o.points_path.find_last_of('/') + 1);
  const std::string script = FormMapScript(points, ev, name, o.plot_path.empty() ? "form_map.png" : o.plot_path);
  if (!o.plot_script_path.empty()) files.Stage(o.plot_script_path, [&](std::ostream& f) { f << script; });
  if (o.plot_path.empty()) return;
  const std::size_t slash = o.plot_path.find_last_of('/');
  GnuplotRun run;
  run.program = o.gnuplot;
  run.folder = slash == std::string::npos ? "." : o.plot_path.substr(0, slash == 0 ? 1 : slash);
  run.script = script;
  run.description = "the form-error map";
  run.timeout_s = o.plot_timeout_s;
  run.Draw("png", o.plot_path, files);
  RunGnuplot(run, o.plot_path);
}

// --- the noise floor of the form values ---------------------------------------------------------

struct NoiseFloorResult {
  std::optional<FormNoiseFloor> floor;
  std::string sigma_source;  ///< where sigma came from
  std::string note;          ///< why there is none
};

NoiseFloorResult NoiseFloorOf(const MeasureOptions& o, const Input& in, const SphereEvaluation& ev) {
  NoiseFloorResult r;
  std::optional<double> sigma_um = o.noise_um;
  r.sigma_source = "--noise-um";
  if (!sigma_um && in.calibration_fit_rms_um) {
    sigma_um = in.calibration_fit_rms_um;
    r.sigma_source = "the calibration's fit rms";
  }
  if (o.noise_floor_draws == 0) {
    r.note = "not computed (--noise-floor-draws 0)";
  } else if (!sigma_um) {
    r.note = "not computed: no noise given (--noise-um) and no calibration fit rms to take it from";
  } else if (ev.n_points < 5) {
    r.note = "not computed: fewer than 5 points";
  } else {
    NoiseFloorOptions nopts;
    nopts.draws = o.noise_floor_draws;
    nopts.seed = o.seed;
    r.floor = EstimateFormNoiseFloor(in.points_mm, ev.ls.sphere.center, ev.ls.sphere.radius, ev.ls.rms,
                                     *sigma_um / kUmPerMm, nopts);
  }
  return r;
}

void WriteNoiseFloorText(std::ostream& out, const SphereEvaluation& ev, const NoiseFloorResult& r) {
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

json NoiseFloorJson(const SphereEvaluation& ev, const NoiseFloorResult& r) {
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

// --- the budget (GUM) of each result --------------------------------------------------------------

struct ResultBudget {
  MeasuredResult which;
  const char* name;  ///< as in the report: radius_mm, sphericity_ls_um, ...
  const char* key;   ///< of the JSON
  double value_mm = 0.0;
  gum::UncertaintyStatement statement;
  std::optional<gum::PropagationResult> mc;  ///< the JCGM 101 check, for the sphericities
  std::string mc_note;                      ///< why there is none
};

struct Budgets {
  std::vector<ResultBudget> results;
  gum::CoverageSpec coverage;
  std::string type_a_form_note;  ///< where the sphericities' Type A comes from, or why there is none
};

Budgets BudgetsOf(const MeasureOptions& o, const Input& in, const SphereEvaluation& ev, const NoiseFloorResult& floor,
                  Progress& progress) {
  Budgets b;
  if (o.coverage) b.coverage.probability = *o.coverage;
  const AppliedCalibration none;
  const AppliedCalibration& applied = in.applied ? *in.applied : none;
  const bool calibrated = applied.covariance.size() > 0;
  std::array<ResultSensitivity, 3> c{};
  if (calibrated) {
    progress.Stage("uncertainty budget: sensitivities to " + std::to_string(applied.covariance.rows()) +
                   " calibration parameters");
    c = SensitivitiesOf(in.readings, applied, ev);
  }
  // Type A of the sphericities: how much the probe's noise alone moves each statistic at these
  // directions (the noise floor's std), from that many simulated measurements.
  double ls_a = 0.0, mz_a = 0.0, form_dof = gum::kInfiniteDof;
  if (floor.floor) {
    ls_a = floor.floor->ls_pv_std_mm;
    mz_a = std::isfinite(floor.floor->mz_std_mm) ? floor.floor->mz_std_mm : 0.0;
    form_dof = std::max(1.0, floor.floor->draws - 1.0);
    b.type_a_form_note =
        Format("the std of each sphericity over the noise floor's %d simulated measurements", floor.floor->draws);
    if (!std::isfinite(floor.floor->mz_std_mm)) {
      b.type_a_form_note += " (the minimum zone's is not simulated for this many points: left out of its budget)";
    }
  } else {
    b.type_a_form_note = "the sphericities' own scatter is not evaluated: the noise floor is " + floor.note;
  }
  const double n_dof = std::max(1.0, ev.n_points - 4.0);
  b.results = {{MeasuredResult::kRadius, "radius_mm", "radius", ev.ls.sphere.radius, {}, {}, {}},
               {MeasuredResult::kSphericityLs, "sphericity_ls_um", "sphericity_ls", ev.sphericity_ls_mm, {}, {}, {}},
               {MeasuredResult::kSphericityMz, "sphericity_mz_um", "sphericity_mz", ev.mz.width, {}, {}, {}}};
  const std::array<double, 3> type_a{ev.radius_fit_std_mm, ls_a, mz_a};
  const std::array<double, 3> dof{n_dof, form_dof, form_dof};
  const std::array<const char*, 3> type_a_name{
      "measurement (scatter of the points)", "measurement (noise of the points)", "measurement (noise of the points)"};
  for (std::size_t k = 0; k < 3; ++k) {
    ResultBudget& r = b.results[k];
    r.statement = MeasurementBudget(type_a_name[k], type_a[k], dof[k], c[k], applied, b.coverage);
    if (r.which == MeasuredResult::kRadius) continue;
    if (!calibrated) {
      r.mc_note = "no calibration covariance to propagate";
    } else if (o.mc_max_trials == 0) {
      r.mc_note = "not run (--mc-max-trials 0)";
    } else if (ev.n_points > o.mc_max_points) {
      r.mc_note = Format("not run: %d points, above --mc-max-points %ld (each trial compensates and fits them all)",
                         ev.n_points, o.mc_max_points);
    } else {
      progress.Stage(std::string("Monte Carlo check (JCGM 101) of ") + r.name);
      gum::PropagationOptions mo;
      mo.probability = r.statement.coverage_probability;
      mo.significant_digits = o.mc_digits;
      mo.seed = o.seed;
      mo.batch_trials = o.mc_batch_trials;
      mo.max_trials = o.mc_max_trials;
      r.mc = CheckByMonteCarlo(r.which, in.readings, applied, ev, type_a[k], dof[k], mo);
    }
  }
  progress.Finish();
  return b;
}

double ReportScale(const BudgetInput& in) { return in.unit.empty() ? kUmPerMm : 1.0; }

void WriteBudgetText(std::ostream& out, const Budgets& b, int mc_digits) {
  out << "uncertainty (GUM): each input's contribution |c_i| u(x_i), the combined u, effective degrees of freedom "
         "nu_eff and U = k u, in um\n";
  for (const ResultBudget& r : b.results) {
    const gum::UncertaintyStatement& st = r.statement;
    const std::string dof = !std::isfinite(st.dof) ? "inf" : st.dof > 1e6 ? ">1e6" : Format("%.0f", st.dof);
    const std::string value =
        r.which == MeasuredResult::kRadius ? Format("%.9f", r.value_mm) : Format("%.4f", r.value_mm * kUmPerMm);
    out << Format("  %-18s %s   u %.4f   nu_eff %s   k %.2f   U %.4f\n", r.name, value.c_str(), st.u * kUmPerMm,
                  dof.c_str(), st.k, st.U * kUmPerMm);
    for (const BudgetInput& in : st.inputs) {
      std::string detail = in.type == EvaluationType::kA
                               ? (std::isfinite(in.dof) ? Format("A, %.0f degrees of freedom", in.dof) : "A")
                               : "B";
      if (!in.unit.empty()) {
        detail += Format(", u %.4g ", in.standard_uncertainty) + in.unit +
                  Format(", sensitivity %.4g um/", in.sensitivity * kUmPerMm) + in.unit;
      }
      out << Format("    %-44s %.4f   (%s)\n", in.name.c_str(), in.Contribution() * kUmPerMm, detail.c_str());
    }
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

json BudgetsJson(const Budgets& b, int mc_digits) {
  json j = json::object();
  for (const ResultBudget& r : b.results) {
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

void WriteText(std::ostream& out, const MeasureOptions& o, const Input& in, const SphereEvaluation& ev,
               const std::optional<CalibrationUncertainty>& u, const std::string& uncertainty_note,
               const NoiseFloorResult& floor, const Budgets& budgets) {
  const double r = ev.ls.sphere.radius;
  out << kProgram << " " SPH_VERSION ": " << o.points_path << "\n  " << in.description << "\n\n";
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
  WriteNoiseFloorText(out, ev, floor);
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
    out << Format(
               u->form_exceeds_calibration
                   ? "  the form error (sphericity_ls %.4f um) exceeds it: it is in the measurement (the part or the "
                     "probe), not an artefact of the calibration\n"
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

std::string JsonReport(const MeasureOptions& o, const Input& in, const SphereEvaluation& ev,
                       const std::optional<CalibrationUncertainty>& u, const std::string& uncertainty_note,
                       const NoiseFloorResult& floor, const Budgets& budgets) {
  json j;
  j["created_by"] = std::string(kProgram) + " " SPH_VERSION;
  j["input"] = {{"points_file", o.points_path},
                {"format", o.xyz ? "xyz" : "sph-points 1"},
                {"calibration_file", o.calibration_path.empty() ? json(nullptr) : json(o.calibration_path)},
                {"setup", in.setup ? json(*in.setup) : json(nullptr)},
                {"n_points", ev.n_points}};
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
  j["noise_floor"] = NoiseFloorJson(ev, floor);
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

}  // namespace

void SetupMeasureApp(CLI::App& app, MeasureOptions& o) {
  app.description(
      "Measure a sphere: compensate raw readings with a calibration (or read x y z points), fit the "
      "least-squares sphere, evaluate least-squares and minimum-zone sphericity and their uncertainty "
      "from the calibration, and draw the form-error map.");
  app.add_option("points", o.points_path, "Points file: readings (sph-points 1), or x y z [mm] with --xyz")->required();
  app.add_flag("--xyz", o.xyz, "The points file holds x y z coordinates [mm], one point a line (also NIST .ds)");
  app.add_flag("--subtract-sphere-form", o.subtract_sphere_form,
               "The points are of the calibration sphere: take its form (from the calibration file) off them, in the "
               "orientation the points file's mount_rotation_deg gives");
  app.add_option("-c,--calibration", o.calibration_path, "Calibration file (JSON, from sph_calibrate -o)");
  app.add_option("--setup", o.setup, "Setup id to measure, when the points file holds several");
  app.add_option("--json", o.json_path, "Write the results as JSON to this file ('-' for stdout)");
  app.add_option("-o,--output", o.output_path, "Write the compensated points (x_mm y_mm z_mm) to this file");
  app.add_option("--plot", o.plot_path, "Draw the form-error map to this PNG file (needs gnuplot)");
  app.add_option("--plot-script", o.plot_script_path,
                 "Write the form-error map as a gnuplot script (data inline; run: gnuplot FILE)");
  app.add_option("--gnuplot", o.gnuplot, "The gnuplot program")->capture_default_str();
  AddPlotTimeoutOption(app, o.plot_timeout_s);
  app.add_option("--uncertainty-samples", o.uncertainty_samples,
                 "Calibration draws for the uncertainty from the calibration's covariance (0: none)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000000));
  AddSeedOption(app, o.seed, "Seed of the calibration draws")->capture_default_str();
  app.add_option("--noise-um", o.noise_um,
                 "The probe's noise sigma for the noise floor of the form values [um] (default: the calibration's "
                 "fit rms, its source.fit_rms_um)")
      ->check(InRange({0.0, 1000.0, "um", true}));
  app.add_option("--noise-floor-draws", o.noise_floor_draws,
                 "Simulated measurements of pure noise at the measured directions for the noise floor; 0: none")
      ->capture_default_str()
      ->check(CLI::Range(0, 100000));
  app.add_option("--coverage", o.coverage,
                 "Coverage probability of the expanded uncertainties U = k u (k from the effective degrees of "
                 "freedom); default: k = 2")
      ->check(InRange(ranges::kCoverageProbability));
  app.add_option("--mc-max-trials", o.mc_max_trials,
                 "JCGM 101 adaptive Monte Carlo check of the sphericities' budgets: at most this many trials; 0: none")
      ->capture_default_str()
      ->check(CLI::Range(0L, 100000000L));
  app.add_option("--mc-batch-trials", o.mc_batch_trials, "Trials per batch of that check")
      ->capture_default_str()
      ->check(CLI::Range(10L, 10000000L));
  app.add_option("--mc-max-points", o.mc_max_points, "Run that check only for at most this many points")
      ->capture_default_str()
      ->check(CLI::Range(0L, 100000000L));
  app.add_option("--mc-digits", o.mc_digits,
                 "Significant digits of u that set the check's numerical tolerance (JCGM 101 7.9.2)")
      ->capture_default_str()
      ->check(CLI::Range(1, 3));
  app.add_option("--max-dilution", o.max_dilution,
                 "Warn when the coverage determines radius or centre this many times worse than points over the "
                 "whole sphere")
      ->capture_default_str()
      ->check(InRange({0.0, 1e6, "", true}));
  app.add_flag("-q,--quiet", o.quiet, "No text report on stdout (warnings still go to stderr)");
  AddProgressOptions(app, o.progress);
}

int RunMeasure(const MeasureOptions& o, std::ostream& out, std::ostream& err) {
  try {
    if (o.uncertainty_samples == 1) throw Error("--uncertainty-samples: 1 draw gives no spread; use 0 or at least 2");
    const bool text = !o.quiet && o.json_path != "-";
    RunPaths()
        .Input("points", o.points_path)
        .Input("--calibration", o.calibration_path)
        .Output("the text report (-q leaves it out)", text ? "-" : "")
        .Output("--json", o.json_path)
        .Output("--output", o.output_path)
        .Output("--plot", o.plot_path)
        .Output("--plot-script", o.plot_script_path);
    Progress progress(kProgram, err, o.progress);
    progress.Stage("reading " + o.points_path);
    const Input in = ReadInput(o);
    progress.Finish();
    for (const std::string& w : in.warnings) err << kProgram << ": warning: " << w << "\n";
    SphereEvaluationOptions eopts;
    eopts.max_dilution = o.max_dilution;
    progress.Stage("fitting the spheres of " + std::to_string(in.points_mm.size()) + " points");
    const SphereEvaluation ev = EvaluateSphere(in.points_mm, o.points_path, eopts);

    std::optional<CalibrationUncertainty> u;
    std::string note;
    if (!in.applied) {
      note = "none (x y z input carries no calibration)";
    } else if (in.applied->covariance.size() == 0) {
      note = "none (" + o.calibration_path + " holds no covariance)";
    } else if (o.uncertainty_samples == 0) {
      note = "not computed (--uncertainty-samples 0)";
    } else {
      UncertaintyOptions uopts;
      uopts.samples = o.uncertainty_samples;
      uopts.seed = o.seed;
      uopts.progress = [&](int done, int total) { progress.Update("uncertainty: calibration draws", done, total); };
      u = PropagateCalibrationUncertainty(in.readings, *in.applied, ev, uopts);
    }
    progress.Finish();  // the report follows on stdout, maybe the same terminal

    const NoiseFloorResult floor = NoiseFloorOf(o, in, ev);
    const Budgets budgets = BudgetsOf(o, in, ev, floor, progress);

    OutputFiles files(out);
    if (!o.json_path.empty()) {
      const std::string report = JsonReport(o, in, ev, u, note, floor, budgets);
      files.Stage(o.json_path, [&](std::ostream& f) { f << report; });
    }
    if (!o.output_path.empty()) {
      files.Stage(o.output_path, [&](std::ostream& f) {
        WriteXyz(f, in.points_mm,
                 {std::string(kProgram) + " " SPH_VERSION ": " + o.points_path + ", " + in.description,
                  "columns: x_mm y_mm z_mm"});
      });
    }
    if (!o.plot_path.empty() || !o.plot_script_path.empty()) DrawFormMap(o, in.points_mm, ev, files);
    if (text) WriteText(out, o, in, ev, u, note, floor, budgets);
    if (!text) {
      for (const auto& w : ev.warnings) err << kProgram << ": warning: " << w << "\n";
    }
    progress.Finish();
    files.Commit();
    return kExitOk;
  } catch (const std::exception& e) {
    err << kProgram << ": error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace sph::apps
