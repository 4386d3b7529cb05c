#include "sph/calib/calibrate_workflow.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <map>
#include <utility>

#include "fit_problem.hpp"
#include "sph/calib/misreading.hpp"
#include "sph/core/cancellation.hpp"
#include "sph/core/error.hpp"
#include "sph/core/ranges.hpp"
#include "sph/core/valid_range.hpp"
#include "sph/internal/format.hpp"
#include "sph/io/output_files.hpp"
#include "sph/io/parameter_settings.hpp"
#include "sph/io/setup_checks.hpp"
#include "sph/model/units.hpp"

namespace sph {

namespace {

using internal::Format;

// The known forms' files: the reference sphere's (empty: none) and another sphere's by the setup
// that names it in CalibrationOptions::other_form_priors.
struct KnownFormFiles {
  std::string reference;
  std::map<int, std::string> others;
};

// The budget of the calibration reported (the trace's final fit when `extended`); none, with a
// warning, when the fit was not analysed or a refit fails.
void MakeBudget(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  const CalibrationResult& result = run.Reported();
  if (result.analysis.Empty() || !result.converged) return;
  const EffectFit* extended = run.Extended() ? &run.trace->after.fit : nullptr;
  BudgetRefit refit = [&](const PointsData& p, const CalibrationOptions& q) {
    if (extended == nullptr) {
      CalibrationOptions start = q;
      start.initial_geometry = result.geometry;
      const CalibrationResult r = Calibrate(p, start);
      return internal::PackParameters(r.geometry, r.centers_mm);
    }
    const EffectFit fit = FitEffects(p, q, extended->model, EffectFitStart::From(*extended));
    return internal::PackParameters(fit.calibration.geometry, fit.calibration.centers_mm, fit.values, fit.form_values);
  };
  try {
    run.budget = MakeCalibrationBudget(WithoutOutliers(run.points, result), run.settings, result, run.inputs, refit);
  } catch (const Cancelled&) {
    throw;
  } catch (const std::exception& e) {
    run.warnings.push_back(std::string("no uncertainty budget: ") + e.what());
    if (o.on_warning) o.on_warning(run.warnings.back());
  }
}

// The certificate's bound of the form: the options', else the header's [um].
std::optional<double> FormBoundUm(const CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  return o.conditions.sphere_form_rms_um ? o.conditions.sphere_form_rms_um
                                         : ConditionsOf(run.points.header).sphere_form_rms_um;
}

void Tell(const std::function<void(const std::string&)>& f, const std::string& text) {
  if (f) f(text);
}

void Warn(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o, const std::string& warning) {
  run.warnings.push_back(warning);
  Tell(o.on_warning, warning);
}

// A sphere of the points: the reference (setups empty) or another, by the setups that measured it.
struct PointsSphere {
  std::string name;  // in messages: "R0" or "sphere_radius_mm@2,3"
  double radius_mm = 0.0;
  double u_um = 0.0;
  std::vector<int> setups;
  std::string file;  // the form's file matched to it
};

std::vector<PointsSphere> SpheresOf(const CalibrationWorkflowResult& run) {
  std::vector<PointsSphere> spheres{{"R0", run.settings.sphere_radius_mm, run.inputs.sphere_radius_u_um, {}, ""}};
  std::map<std::string, std::size_t> index;  // by the radius, as PointsHeader::FormKey() writes it
  for (const auto& [setup, radius_mm] : run.settings.sphere_radii_mm) {
    const auto [it, is_new] = index.emplace(internal::Shortest(radius_mm), spheres.size());
    if (is_new) spheres.push_back({"sphere_radius_mm@", radius_mm, 0.0, {}, ""});
    PointsSphere& s = spheres[it->second];
    s.name += (s.setups.empty() ? "" : ",") + std::to_string(setup);
    s.setups.push_back(setup);
  }
  return spheres;
}

std::string SpheresText(const std::vector<PointsSphere>& spheres) {
  std::string text;
  for (const PointsSphere& s : spheres) {
    text += (text.empty() ? "" : ", ") + s.name + " " + Format("%.9g", s.radius_mm) + " mm (u " + Format("%g", s.u_um) +
            " um)";
  }
  return text;
}

// The sphere of the points whose form `file` holds (by its R0), refused when none or several.
PointsSphere& SphereOfFile(std::vector<PointsSphere>& spheres, const CalibrationFile& file, const std::string& path,
                           const std::string& points_path) {
  if (!file.sphere_radius_mm) {
    throw Error(path + ": states no sphere_radius_mm, so it cannot be told which of the points' spheres (" +
                SpheresText(spheres) + ") its form belongs to");
  }
  double file_u_um = 0.0;
  for (const CalibrationFile::CovarianceInput& in : file.covariance_inputs) {
    if (in.input == "R0 (certificate)" && in.unit == "um") file_u_um = in.u;
  }
  std::vector<std::size_t> matches;
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    const double difference_um = std::abs(spheres[i].radius_mm - *file.sphere_radius_mm) * kUmPerMm;
    if (difference_um <= spheres[i].u_um + file_u_um + 1e-3) matches.push_back(i);
  }
  const std::string its = path + ": its sphere, sphere_radius_mm " + Format("%.9g", *file.sphere_radius_mm) +
                          " mm (u " + Format("%g", file_u_um) + " um), ";
  if (matches.empty()) {
    throw Error(its + "is none of the spheres of " + points_path + " (" + SpheresText(spheres) +
                ") within their standard uncertainties: the known form belongs to its own sphere");
  }
  if (matches.size() > 1) {
    std::vector<PointsSphere> both;
    for (const std::size_t i : matches) both.push_back(spheres[i]);
    throw Error(its + "could be any of the spheres of " + points_path + " " + SpheresText(both) +
                " within their standard uncertainties: which sphere's form it holds is ambiguous");
  }
  PointsSphere& sphere = spheres[matches.front()];
  if (!sphere.file.empty()) {
    throw Error(path + " and " + sphere.file + " both hold a form of the sphere " + sphere.name + " of " + points_path);
  }
  sphere.file = path;
  return sphere;
}

// The spheres' forms as known: each file's (matched to its sphere), else the reference sphere's
// certificate's bound.
KnownFormFiles SettleKnownForm(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  KnownFormFiles files;
  const std::optional<double> bound_um = FormBoundUm(run, o);
  std::vector<PointsSphere> spheres = SpheresOf(run);
  for (const std::string& path : o.sphere_form_paths) {
    const CalibrationFile file = ReadCalibrationFile(path);
    if (spheres.size() == 1) {  // one sphere: the file's R0 must be the points'
      CheckSameSphere(file, path, run.settings.sphere_radius_mm, run.inputs.sphere_radius_u_um, run.points_path);
      if (!spheres[0].file.empty()) {
        throw Error(path + " and " + spheres[0].file + " both hold a form of the sphere R0 of " + run.points_path);
      }
      spheres[0].file = path;
    } else {
      SphereOfFile(spheres, file, path, run.points_path);
    }
    std::vector<std::string> notes;
    FormPrior prior = FormPriorOfFile(file, path, &notes);
    for (const std::string& n : notes) Warn(run, o, n);
    const PointsSphere& sphere =
        *std::find_if(spheres.begin(), spheres.end(), [&](const PointsSphere& s) { return s.file == path; });
    if (sphere.setups.empty()) {
      run.settings.form_prior = std::move(prior);
      continue;
    }
    const auto known = std::find_if(sphere.setups.begin(), sphere.setups.end(), [&](int setup) {
      const auto r = run.points.header.mount_rotations.find(setup);
      return r == run.points.header.mount_rotations.end() || r->second.known();
    });
    if (known == sphere.setups.end()) {
      throw Error(path + ": holds the form of the sphere " + sphere.name + " of " + run.points_path +
                  ", but every setup of that sphere is of unknown orientation (mount_rotation_deg@<setup>: unknown), "
                  "where a known form does not apply");
    }
    run.settings.other_form_priors[*known] = std::move(prior);
    files.others[*known] = path;
  }
  if (run.settings.form_prior.Empty() && bound_um && o.trace) {
    const int l_max = FormDegreeLimit(run.points, o.trace_options);
    if (l_max >= 2) {
      run.settings.form_prior = CertificateFormPrior(*bound_um * kMmPerUm, l_max);
    } else {
      Warn(run, o, "sphere_form_rms_um: the pattern resolves no form of degree 2 or more: the bound is not used");
    }
  }
  if (!files.others.empty() && run.settings.form_prior.Empty()) {
    throw Error(run.points_path + ": a known form of another sphere (" + files.others.begin()->second +
                ") needs the reference sphere's form known too: a --sphere-form file of it (R0 " +
                Format("%.9g", run.settings.sphere_radius_mm) +
                " mm), or its certificate's bound (--sphere-form-rms-um)");
  }
  files.reference = spheres[0].file;
  return files;
}

// The fit's settings from the options and the points' header (the options win); run.inputs gets
// the measuring conditions of both. Returns the known forms' files.
KnownFormFiles Settle(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  const PointsHeader& header = run.points.header;
  const auto radius = o.sphere_radius_mm ? o.sphere_radius_mm : header.sphere_radius_mm;
  const auto offset = o.probe_offset_mm ? o.probe_offset_mm : header.probe_offset_mm;
  if (!radius) {
    throw Error(run.points_path +
                ": the reference sphere radius R0 is not given: add a header line "
                "'# sphere_radius_mm: <R0>' to the file or pass --sphere-radius-mm");
  }
  if (!offset) {
    throw Error(run.points_path +
                ": the nominal probe zero distance d is not given: add a header line "
                "'# probe_offset_mm: <d>' to the file or pass --probe-offset-mm");
  }
  run.inputs = CalibrationInputs().With(ConditionsOf(header)).With(o.conditions);
  if (o.coverage) run.inputs.coverage.probability = *o.coverage;
  run.settings = o.fit;
  run.settings.sphere_radius_mm = run.inputs.RadiusAtTemperatureMm(*radius);
  run.settings.sphere_radii_mm.clear();
  for (const auto& [setup, radius_mm] : header.sphere_radii_mm) {
    run.settings.sphere_radii_mm[setup] = run.inputs.RadiusAtTemperatureMm(radius_mm);  // same temperature, CTE
  }
  run.settings.probe_offset_mm = *offset;
  // What the header holds and informs, then the options' (which win for a parameter both name).
  auto named = [&](const std::string& name) {
    return std::any_of(o.fit.fixed.begin(), o.fit.fixed.end(),
                       [&](const FixedParameter& f) { return f.name == name; }) ||
           std::any_of(o.fit.priors.begin(), o.fit.priors.end(),
                       [&](const ParameterPrior& p) { return p.name == name; });
  };
  run.settings.fixed.clear();
  run.settings.priors.clear();
  for (const FixedParameter& f : FixedParametersOf(header)) {
    if (!named(f.name)) run.settings.fixed.push_back(f);
  }
  for (const ParameterPrior& p : ParameterPriorsOf(header)) {
    if (!named(p.name)) run.settings.priors.push_back(p);
  }
  run.settings.fixed.insert(run.settings.fixed.end(), o.fit.fixed.begin(), o.fit.fixed.end());
  run.settings.priors.insert(run.settings.priors.end(), o.fit.priors.begin(), o.fit.priors.end());
  if (o.fit.robust_loss != RobustLoss::kNone && o.trace && o.effects.empty()) {
    throw Error(
        "--robust-loss keeps every reading at a weight, which the trace's selection of effects does not "
        "(it judges outliers by their residuals): use it with --no-trace, or with --effects for a fixed "
        "model");
  }
  KnownFormFiles files = SettleKnownForm(run, o);
  run.probe_range_mm = o.conditions.probe_range_mm ? o.conditions.probe_range_mm : ConditionsOf(header).probe_range_mm;
  if (run.probe_range_mm) {
    CheckReadingsInProbeRange(run.points, *run.probe_range_mm,
                              o.conditions.probe_range_mm ? "--probe-range-mm" : "probe_range_mm");
  }
  return files;
}

// The residual traced to further effects (or the fixed effects fitted), and its validation.
void Trace(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  TraceOptions trace_options = o.trace_options;
  trace_options.probe_range_mm = run.probe_range_mm;
  if (o.effects.empty()) {
    run.trace = TraceResidual(run.points, run.settings, run.seven, trace_options);
  } else {
    std::vector<Effect> fixed;
    for (const Effect& e : o.effects) {
      if (std::find(fixed.begin(), fixed.end(), e) == fixed.end()) fixed.push_back(e);
    }
    run.trace = FitFixedEffects(run.points, run.settings, run.seven, fixed, trace_options);
  }
  if (o.validate_path.empty()) return;
  Validation& v = run.validation.emplace(Validate(o.validate_path, run.settings.probe_offset_mm, *run.trace));
  if (SameFile(o.validate_path, run.points_path)) {
    v.note =
        "the validation file is the calibration's own points file: this shows how the model fits its own data, "
        "not an independent check" +
        (v.note.empty() ? std::string() : "; " + v.note);
  }
}

// How the readings agree with the known forms, their warnings among the run's.
void CheckForm(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o, const KnownFormFiles& files) {
  if (run.settings.form_prior.Empty() || !run.trace || run.trace->after.fit.model.form.Empty()) return;
  const std::string& file = files.reference;
  run.known_form = CheckKnownForm(run.points, run.settings, run.trace->after.fit,
                                  file.empty() ? "the certificate's bound" : file, FormBoundUm(run, o), !file.empty());
  for (const std::string& w : run.known_form->warnings) Warn(run, o, w);
  for (const auto& [setup, path] : files.others) {
    run.other_known_forms.push_back(CheckOtherKnownForm(run.points, run.settings, run.trace->after.fit, setup, path));
    for (const std::string& w : run.other_known_forms.back().warnings) Warn(run, o, w);
  }
}

// The calibration file's content, usable or not: the seven errors, the trace's effects but
// probe_drift (`*drift_left_out` says whether one was left out), the covariance.
CalibrationFile FileOf(const CalibrationWorkflowResult& run, bool* drift_left_out) {
  CalibrationFile file = MakeCalibrationFile(run.Reported(), run.Context());
  const bool drift = run.Extended() && AddEffectsToCalibrationFile(run.trace->after.fit, file);
  if (drift_left_out != nullptr) *drift_left_out = drift;
  std::vector<int> columns;
  for (int p = 0; p < kNumScmsParams; ++p) columns.push_back(p);
  if (run.Extended()) columns = AppliedColumns(run.trace->after.fit);
  AddCovarianceToCalibrationFile(columns, run.Reported(), run.budget ? &*run.budget : nullptr, file);
  return file;
}

// Whether two calibration files hold one model: the same parameters (the effects' components and
// the form's terms), in any order, and the same drift fitted beside them.
bool SameModel(const CalibrationFile& a, const CalibrationFile& b) {
  auto sorted = [](const CalibrationFile& f) {
    std::vector<std::string> names = CalibrationParameterNames(f);
    std::sort(names.begin(), names.end());
    return names;
  };
  return sorted(a) == sorted(b) && a.probe_drift_powers == b.probe_drift_powers;
}

// `run`'s readings calibrated with the model of `previous` (CompareWithEarlier()): the reported
// calibration, its budget and its usability; warnings kept in its own.
CalibrationWorkflowResult RefitWithModelOf(const CalibrationWorkflowResult& run, const CalibrationFile& previous,
                                           const CalibrationWorkflowOptions& o) {
  CalibrationWorkflowResult like;
  like.points = run.points;
  like.points_path = run.points_path;
  like.settings = run.settings;
  like.inputs = run.inputs;
  like.probe_range_mm = run.probe_range_mm;
  like.program = run.program;
  like.seven = run.seven;
  std::vector<EffectTerm> terms = previous.effects.terms;
  if (!previous.probe_drift_powers.empty()) {  // the file's drift is left out, its powers are not
    EffectTerm drift{Effect::kProbeDrift, {}};
    for (int power : previous.probe_drift_powers) drift.components.push_back({power, 0, false});
    terms.push_back(drift);
  }
  if (!terms.empty() || !previous.form_terms.empty() || !run.settings.form_prior.Empty()) {
    TraceOptions trace_options = o.trace_options;
    trace_options.probe_range_mm = run.probe_range_mm;
    trace_options.progress = nullptr;
    like.trace = FitGivenModel(like.points, like.settings, like.seven, terms, previous.form_terms, trace_options,
                               &previous.effects.reference);
  }
  CalibrationWorkflowOptions quiet = o;
  quiet.on_warning = nullptr;
  MakeBudget(like, quiet);
  like.usability = JudgeUsability(like.Reported(), like.Context());
  return like;
}

}  // namespace

CalibrationComparison CompareWithEarlier(const CalibrationWorkflowResult& run, const CalibrationFile& previous,
                                         const std::string& previous_source,
                                         const CalibrationWorkflowOptions& options) {
  const CalibrationFile today = FileOf(run, nullptr);
  CalibrationComparison own = CompareCalibrations(previous, today, previous_source);
  if (SameModel(previous, today)) return own;
  std::string why;
  try {
    const CalibrationWorkflowResult like = RefitWithModelOf(run, previous, options);
    if (like.usability.usable && like.warnings.empty()) {
      return LikeForLike(CompareCalibrations(previous, FileOf(like, nullptr), previous_source), own);
    }
    for (const std::string& reason : like.usability.reasons) why += (why.empty() ? "" : "; ") + reason;
    for (const std::string& warning : like.warnings) why += (why.empty() ? "" : "; ") + warning;
  } catch (const Cancelled&) {
    throw;
  } catch (const std::exception& e) {
    why = e.what();
  }
  return NotLikeForLike(std::move(own), why);
}

void CalibrationWorkflowOptions::Check() const {
  const std::string what = "calibration options: ";
  if (sphere_radius_mm) CheckedValue(*sphere_radius_mm, ranges::kSphereRadiusMm, what + "sphere_radius_mm");
  if (probe_offset_mm) CheckedValue(*probe_offset_mm, ranges::kProbeOffsetMm, what + "probe_offset_mm");
  CheckedValue(fit.max_std_um, ranges::kStdUm, what + "fit.max_std_um");
  CheckedValue(fit.max_iterations, ranges::kMaxIterations, what + "fit.max_iterations");
  CheckedValue(trace_options.harmonics.theta, ranges::kHarmonicOrder, what + "trace_options.harmonics.theta");
  CheckedValue(trace_options.harmonics.phi, ranges::kHarmonicOrder, what + "trace_options.harmonics.phi");
  CheckedValue(trace_options.drift_order, ranges::kDriftOrder, what + "trace_options.drift_order");
  CheckedValue(trace_options.phi_wobble_pivot_mm, ranges::kPivotMm, what + "trace_options.phi_wobble_pivot_mm");
  if (coverage) CheckedValue(*coverage, ranges::kCoverageProbability, what + "coverage");
  if (!trace && !effects.empty()) throw Error(what + "effects need trace (a fixed model is fitted in its place)");
  if (!trace && !sphere_form_paths.empty()) {
    throw Error(what + "sphere_form_paths needs trace (the known form is fitted with the effects' model)");
  }
  if (!trace && !validate_path.empty()) {
    throw Error(what + "validate_path needs trace (it compares the seven errors with the trace's model)");
  }
}

bool CalibrationWorkflowResult::Extended() const {
  return trace && !(trace->after.fit.model.Empty() && trace->after.fit.model.form.Empty());
}

const CalibrationResult& CalibrationWorkflowResult::Reported() const {
  return Extended() ? trace->after.fit.calibration : seven;
}

ReportContext CalibrationWorkflowResult::Context() const {
  ReportContext ctx;
  ctx.budget = budget ? &*budget : nullptr;
  ctx.program = program;
  ctx.points_path = points_path;
  ctx.sphere_radius_mm = settings.sphere_radius_mm;
  ctx.sphere_radii_mm = settings.sphere_radii_mm;
  ctx.probe_offset_mm = settings.probe_offset_mm;
  ctx.max_std_um = settings.max_std_um;
  ctx.probe_range_mm = probe_range_mm;
  ctx.metadata = points.header.metadata;
  ctx.trace = trace ? &*trace : nullptr;
  ctx.validation = validation ? &*validation : nullptr;
  ctx.comparison = comparison ? &*comparison : nullptr;
  ctx.known_form = known_form ? &*known_form : nullptr;
  ctx.other_known_forms = &other_known_forms;
  ctx.likely_cause = likely_cause;
  return ctx;
}

void CalibrationWorkflowResult::WriteTextReport(std::ostream& out) const {
  sph::WriteTextReport(out, Reported(), Context());
}

std::string CalibrationWorkflowResult::JsonReport() const { return sph::JsonReport(Reported(), Context()); }

CalibrationFile CalibrationWorkflowResult::MakeCalibrationFile(bool* drift_left_out) const {
  if (!usability.usable) throw Error("the calibration is not usable: no calibration file");
  return FileOf(*this, drift_left_out);
}

CalibrationWorkflowResult RunCalibrationWorkflow(const std::string& points_path,
                                                 const CalibrationWorkflowOptions& options) {
  Tell(options.on_stage, "reading " + points_path);
  return RunCalibrationWorkflow(ReadPointsFile(points_path), points_path, options);
}

CalibrationWorkflowResult RunCalibrationWorkflow(PointsData points, const std::string& points_path,
                                                 const CalibrationWorkflowOptions& options) {
  options.Check();
  CalibrationWorkflowResult run;
  run.points = std::move(points);
  run.points_path = points_path;
  run.program = options.program.empty() ? std::string("sph_calibrate " SPH_VERSION) : options.program;
  const KnownFormFiles form_files = Settle(run, options);
  std::optional<CalibrationFile> previous;
  if (!options.compare_path.empty()) {  // bad input is told before the fit
    Tell(options.on_stage, "reading " + options.compare_path);
    previous = ReadCalibrationFile(options.compare_path);
    CalibrationFile now;
    now.probe_offset_mm = run.settings.probe_offset_mm;
    CheckComparable(*previous, now, options.compare_path);
  }
  // Readings that parse but look wrong: said first, whatever follows.
  Tell(options.on_stage, "checking " + std::to_string(run.points.samples.size()) + " samples");
  for (const std::string& w : PlausibilityWarnings(run.points)) {
    run.warnings.push_back(w);
    Tell(options.on_warning, w);
  }
  Tell(options.on_stage, "calibrating the seven errors");
  run.seven = Calibrate(run.points, run.settings);
  if (options.trace) Trace(run, options);
  CheckForm(run, options, form_files);
  MakeBudget(run, options);
  if (const auto m = LikelyMisreading(run.points, run.settings, run.seven)) run.likely_cause = m->Reason();
  run.usability = JudgeUsability(run.Reported(), run.Context());
  if (previous) {
    Tell(options.on_stage, "comparing with " + options.compare_path);
    run.comparison = CompareWithEarlier(run, *previous, options.compare_path, options);
    if (run.comparison->model == kTodaysModel && !run.comparison->models.empty()) {
      Warn(run, options, run.comparison->models);
    }
  }
  return run;
}

}  // namespace sph
