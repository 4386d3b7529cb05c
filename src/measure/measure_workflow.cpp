#include "sph/measure/measure_workflow.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <utility>

#include "sph/core/cancellation.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/points_file.hpp"
#include "sph/io/xyz_file.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/units.hpp"
#include "sph/sphere/sphere_fit.hpp"

namespace sph {
namespace {

using internal::Format;

// The options with the path of the points they measure (named in the messages), and the points
// when they were given in memory.
struct Args : MeasurementWorkflowOptions {
  std::string points_path;
  std::optional<PointsData> points;
};

// Each step told is also where a cancellation is seen (sph/core/cancellation.hpp).
void Tell(const Args& o, const std::string& stage, long done = 0, long total = 0) {
  ThrowIfCancelled();
  if (o.on_progress) o.on_progress(stage, done, total);
}

// x y z points, which need no calibration.
MeasuredPoints ReadXyzInput(const Args& o) {
  if (!o.calibration_path.empty()) {
    throw Error("--calibration compensates readings (theta, phi, r); " + o.points_path +
                " is read as x y z coordinates (--xyz), which need none");
  }
  if (o.setup) throw Error("--setup selects a setup of a points file of readings, not of x y z coordinates (--xyz)");
  MeasuredPoints in;
  in.points_mm = ReadXyzFile(o.points_path);
  in.description = std::to_string(in.points_mm.size()) + " points (x y z)";
  return in;
}

// The setup to evaluate: --setup, else the file's only one (none when the file has no setup column).
std::optional<int> SelectedSetup(const Args& o, const PointsData& data) {
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
void FoldProbeIncidence(const Args& o, int term, Calibration& cal, MeasuredPoints& in) {
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
std::string FormNote(const Args& o, const CalibrationFile& file) {
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
void TakeOffSphereForm(const Args& o, const CalibrationFile& file, const PointsData& data, AppliedCalibration& applied,
                       MeasuredPoints& in) {
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
std::string CovarianceNote(const Args& o, const AppliedCalibration& applied, const Calibration& cal) {
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

MeasuredPoints ReadInput(const Args& o) {
  if (o.xyz && o.points) {
    throw Error(o.points_path +
                ": readings (theta, phi, r) given in memory are not x y z coordinates: --xyz reads "
                "a file of them");
  }
  if (o.xyz) return ReadXyzInput(o);
  if (o.calibration_path.empty()) {
    throw Error(o.points_path +
                ": readings (theta, phi, r) need a calibration to become points: pass "
                "--calibration FILE, or --xyz when the file holds x y z coordinates");
  }
  MeasuredPoints in;
  std::optional<PointsData> read;
  const PointsData& data = o.points ? *o.points : read.emplace(ReadPointsFile(o.points_path));
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
  in.metadata = data.header.metadata;
  in.calibration_source = file.source;
  in.header_radius = SphereRadiusOfSetup(data.header, in.setup.value_or(0));
  in.description = std::to_string(in.readings.size()) + " readings" +
                   (in.setup ? " (setup " + std::to_string(*in.setup) + ")" : "") + ", compensated with " +
                   o.calibration_path;
  return in;
}

MeasurementNoiseFloor NoiseFloorOf(const Args& o, const MeasuredPoints& in, const SphereEvaluation& ev) {
  MeasurementNoiseFloor r;
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

MeasurementBudgets BudgetsOf(const Args& o, const MeasuredPoints& in, const SphereEvaluation& ev,
                             const MeasurementNoiseFloor& floor) {
  MeasurementBudgets b;
  if (o.coverage) b.coverage.probability = *o.coverage;
  const AppliedCalibration none;
  const AppliedCalibration& applied = in.applied ? *in.applied : none;
  const bool calibrated = applied.covariance.size() > 0;
  std::array<ResultSensitivity, 3> c{};
  if (calibrated) {
    Tell(o, "uncertainty budget: sensitivities to " + std::to_string(applied.covariance.rows()) +
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
    MeasuredResultBudget& r = b.results[k];
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
      Tell(o, std::string("Monte Carlo check (JCGM 101) of ") + r.name);
      gum::PropagationOptions mo;
      mo.probability = r.statement.coverage_probability;
      mo.significant_digits = o.mc_digits;
      mo.seed = o.seed;
      mo.batch_trials = o.mc_batch_trials;
      mo.max_trials = o.mc_max_trials;
      r.mc = CheckByMonteCarlo(r.which, in.readings, applied, ev, type_a[k], dof[k], mo);
    }
  }
  return b;
}

}  // namespace

void MeasurementWorkflowOptions::Check() const {
  if (uncertainty_samples == 1) throw Error("--uncertainty-samples: 1 draw gives no spread; use 0 or at least 2");
}

std::string MeasurementWorkflowResult::Program() const {
  return options.program.empty() ? std::string("sph_measure " SPH_VERSION) : options.program;
}

void MeasurementWorkflowResult::WritePoints(std::ostream& out) const {
  WriteXyz(out, input.points_mm,
           {Program() + ": " + points_path + ", " + input.description, "columns: x_mm y_mm z_mm"});
}

namespace {
MeasurementWorkflowResult Run(Args& o);
}  // namespace

MeasurementWorkflowResult RunMeasurementWorkflow(const std::string& points_path,
                                                 const MeasurementWorkflowOptions& options) {
  options.Check();
  Args o;
  static_cast<MeasurementWorkflowOptions&>(o) = options;
  o.points_path = points_path;
  return Run(o);
}

MeasurementWorkflowResult RunMeasurementWorkflow(PointsData points, const std::string& source,
                                                 const MeasurementWorkflowOptions& options) {
  options.Check();
  Args o;
  static_cast<MeasurementWorkflowOptions&>(o) = options;
  o.points_path = source;
  o.points = std::move(points);
  return Run(o);
}

namespace {
MeasurementWorkflowResult Run(Args& o) {
  const std::string& points_path = o.points_path;
  const MeasurementWorkflowOptions& options = o;
  MeasurementWorkflowResult run;
  run.points_path = points_path;
  run.options = options;
  Tell(o, "reading " + points_path);
  run.input = ReadInput(o);
  const MeasuredPoints& in = run.input;
  if (o.on_warning) {
    for (const std::string& w : in.warnings) o.on_warning(w);
  }
  SphereEvaluationOptions eopts;
  eopts.max_dilution = o.max_dilution;
  Tell(o, "fitting the spheres of " + std::to_string(in.points_mm.size()) + " points");
  run.evaluation = EvaluateSphere(in.points_mm, points_path, eopts);
  if (!in.applied) {
    run.uncertainty_note = "none (x y z input carries no calibration)";
  } else if (in.applied->covariance.size() == 0) {
    run.uncertainty_note = "none (" + o.calibration_path + " holds no covariance)";
  } else if (o.uncertainty_samples == 0) {
    run.uncertainty_note = "not computed (--uncertainty-samples 0)";
  } else {
    UncertaintyOptions uopts;
    uopts.samples = o.uncertainty_samples;
    uopts.seed = o.seed;
    uopts.progress = [&](int done, int total) { Tell(o, "uncertainty: calibration draws", done, total); };
    run.uncertainty = PropagateCalibrationUncertainty(in.readings, *in.applied, run.evaluation, uopts);
  }
  run.noise_floor = NoiseFloorOf(o, in, run.evaluation);
  run.budgets = BudgetsOf(o, in, run.evaluation, run.noise_floor);
  return run;
}
}  // namespace

}  // namespace sph
