#include "sph/calib/calibrate_workflow.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <utility>

#include "sph/core/error.hpp"
#include "sph/core/output_files.hpp"
#include "sph/core/setup_checks.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/effect_terms.hpp"

namespace sph {

namespace {

using internal::Format;

// Every parameter of a fit in the analysis' order: the seven errors, each setup's centre, the
// effects' values in term order (rad, mm), then the sphere form's coefficients per group (mm).
Eigen::VectorXd ParameterVector(const CalibrationResult& r, const std::vector<std::vector<double>>& effects = {},
                                const std::vector<std::vector<double>>& form = {}) {
  std::size_t n = kNumScmsParams + 3 * r.centers_mm.size();
  for (const auto& block : effects) n += block.size();
  for (const auto& block : form) n += block.size();
  Eigen::VectorXd v(static_cast<Eigen::Index>(n));
  Eigen::Index k = 0;
  for (double g : r.geometry) v(k++) = g;
  for (const Eigen::Vector3d& c : r.centers_mm) v.segment<3>(k) = c, k += 3;
  for (const auto& blocks : {&effects, &form}) {
    for (const auto& block : *blocks) {
      for (double x : block) v(k++) = x;
    }
  }
  return v;
}

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
      return ParameterVector(Calibrate(p, start));
    }
    const EffectFit fit = FitEffects(p, q, extended->model, EffectFitStart::From(*extended));
    return ParameterVector(fit.calibration, fit.values, fit.form_values);
  };
  try {
    run.budget = MakeCalibrationBudget(WithoutOutliers(run.points, result), run.settings, result.analysis,
                                       result.n_points, run.inputs, refit);
  } catch (const std::exception& e) {
    run.warnings.push_back(std::string("no uncertainty budget: ") + e.what());
    if (o.on_warning) o.on_warning(run.warnings.back());
  }
}

// The fit's settings from the options and the points' header (the options win); run.inputs gets
// the measuring conditions of both.
void Settle(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
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
  run.probe_range_mm = o.conditions.probe_range_mm ? o.conditions.probe_range_mm : ConditionsOf(header).probe_range_mm;
  if (run.probe_range_mm) {
    CheckReadingsInProbeRange(run.points, *run.probe_range_mm,
                              o.conditions.probe_range_mm ? "--probe-range-mm" : "probe_range_mm");
  }
}

// The residual traced to further effects (or the fixed effects fitted), and its validation.
void Trace(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  TraceOptions topts = o.tracing;
  topts.probe_range_mm = run.probe_range_mm;
  if (o.effects.empty()) {
    run.trace = TraceResidual(run.points, run.settings, run.seven, topts);
  } else {
    std::vector<Effect> fixed;
    for (const Effect& e : o.effects) {
      if (std::find(fixed.begin(), fixed.end(), e) == fixed.end()) fixed.push_back(e);
    }
    run.trace = FitFixedEffects(run.points, run.settings, run.seven, fixed, topts);
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

void Tell(const std::function<void(const std::string&)>& f, const std::string& text) {
  if (f) f(text);
}

}  // namespace

void CalibrationWorkflowOptions::Check() const {
  auto need = [](bool ok, const std::string& what) {
    if (!ok) throw Error("calibration options: " + what);
  };
  need(!sphere_radius_mm || (*sphere_radius_mm > 0.0 && *sphere_radius_mm <= kMaxSphereRadiusMm),
       Format("sphere_radius_mm must be > 0 and <= %g mm", kMaxSphereRadiusMm));
  need(!probe_offset_mm || (*probe_offset_mm > 0.0 && *probe_offset_mm <= kMaxProbeOffsetMm),
       Format("probe_offset_mm must be > 0 and <= %g mm", kMaxProbeOffsetMm));
  need(fit.max_std_um > 0.0 && fit.max_std_um <= 1e6, "fit.max_std_um must be > 0 and <= 1e+06 um");
  need(fit.max_iterations >= 1 && fit.max_iterations <= 100000, "fit.max_iterations must be from 1 to 100000");
  need(tracing.harmonics.theta >= 0 && tracing.harmonics.theta <= 12 && tracing.harmonics.phi >= 0 &&
           tracing.harmonics.phi <= 12,
       "tracing.harmonics must be from 0 to 12");
  need(tracing.drift_order >= 1 && tracing.drift_order <= 3, "tracing.drift_order must be from 1 to 3");
  need(std::isfinite(tracing.phi_wobble_pivot_mm) && std::abs(tracing.phi_wobble_pivot_mm) <= kMaxPivotMm,
       Format("tracing.phi_wobble_pivot_mm must be within +-%g mm", kMaxPivotMm));
  need(!coverage || (*coverage >= 0.5 && *coverage <= 0.9999), "coverage must be >= 0.5 and <= 0.9999");
  need(trace || effects.empty(), "effects need trace (a fixed model is fitted in the trace's place)");
  need(trace || validate_path.empty(),
       "validate_path needs trace (it compares the seven errors with the trace's model)");
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
  return ctx;
}

void CalibrationWorkflowResult::WriteTextReport(std::ostream& out) const {
  sph::WriteTextReport(out, Reported(), Context());
}

std::string CalibrationWorkflowResult::JsonReport() const { return sph::JsonReport(Reported(), Context()); }

CalibrationFile CalibrationWorkflowResult::MakeCalibrationFile(bool* drift_left_out) const {
  if (!usability.usable) throw Error("the calibration is not usable: no calibration file");
  CalibrationFile file = sph::MakeCalibrationFile(Reported(), Context());
  const bool drift = Extended() && AddEffectsToCalibrationFile(trace->after.fit, file);
  if (drift_left_out != nullptr) *drift_left_out = drift;
  std::vector<int> columns;
  for (int p = 0; p < kNumScmsParams; ++p) columns.push_back(p);
  if (Extended()) columns = AppliedColumns(trace->after.fit);
  AddCovarianceToCalibrationFile(columns, Reported(), budget ? &*budget : nullptr, file);
  return file;
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
  Settle(run, options);
  // Readings that parse but look wrong: said first, whatever follows.
  Tell(options.on_stage, "checking " + std::to_string(run.points.samples.size()) + " samples");
  for (const std::string& w : PlausibilityWarnings(run.points)) {
    run.warnings.push_back(w);
    Tell(options.on_warning, w);
  }
  Tell(options.on_stage, "calibrating the seven errors");
  run.seven = Calibrate(run.points, run.settings);
  if (options.trace) Trace(run, options);
  MakeBudget(run, options);
  run.usability = JudgeUsability(run.Reported(), run.Context());
  return run;
}

}  // namespace sph
