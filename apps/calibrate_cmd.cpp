#include "calibrate_cmd.hpp"

#include <algorithm>
#include <optional>

#include <CLI/CLI.hpp>

#include "app_common.hpp"
#include "calibrate_plots.hpp"
#include "sph/calib/budget.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/calib/report.hpp"
#include "sph/calib/trace.hpp"
#include "sph/calib/trace_report.hpp"
#include "sph/calib/usability.hpp"
#include "sph/core/calibration_file.hpp"
#include "sph/core/error.hpp"
#include "sph/core/output_files.hpp"
#include "sph/core/points_file.hpp"
#include "sph/core/setup_checks.hpp"

namespace sph::apps {

void SetupCalibrateApp(CLI::App& app, CalibrateOptions& o) {
  app.description(
      "Calibrate the seven geometric errors of a spherical coordinate measuring system from points "
      "measured on a reference sphere (format: docs/formats/points-files.md).");
  app.add_option("points", o.points_path, "Points file (sph-points 1)")->required();
  app.add_option("--sphere-radius-mm", o.sphere_radius_mm,
                 "Reference sphere radius R0 [mm] (overrides the file's sphere_radius_mm)")
      ->check(InRange(ranges::kSphereRadiusMm));
  app.add_option("--probe-offset-mm", o.probe_offset_mm,
                 "Nominal probe zero distance d [mm] (overrides the file's probe_offset_mm)")
      ->check(InRange(ranges::kProbeOffsetMm));
  app.add_option("--json", o.json_path, "Write the report as JSON to this file ('-' for stdout)");
  app.add_option("-o,--output", o.output_path,
                 "Write the calibration file (JSON) that compensation loads; written only when usable");
  app.add_option("--max-std-um", o.max_std_um,
                 "A parameter whose standard uncertainty, as a displacement of the probed point (angles times "
                 "R0), exceeds this is undetermined [um]")
      ->capture_default_str()
      ->check(InRange(ranges::kStdUm));
  app.add_option("--max-iterations", o.max_iterations, "Levenberg-Marquardt iteration limit")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_flag("-q,--quiet", o.quiet, "No text report on stdout (warnings still go to stderr)");
  AddProgressOptions(app, o.progress);
  std::string ids;
  for (const EffectInfo& e : kEffectInfo) ids += (ids.empty() ? "" : ", ") + std::string(e.id);
  auto* no_trace =
      app.add_flag("--no-trace", o.no_trace, "Fit the seven errors only; do not trace the residual to further effects");
  app.add_option("--effects", o.effects, "Fit exactly these effects (comma-separated), no selection: " + ids)
      ->delimiter(',')
      ->excludes(no_trace)
      ->check(CLI::IsMember([] {
        std::vector<std::string> v;
        for (const EffectInfo& e : kEffectInfo) v.emplace_back(e.id);
        return v;
      }()));
  app.add_flag("--hold-confounded", o.hold_confounded,
               "When the effect the trace would add cannot be told from another (by this design, or about equal "
               "scores), add neither and report both; default: add the one that explains more and name the other")
      ->excludes(no_trace);
  app.add_option("--validate", o.validate_path,
                 "Another points file of the same machine (another sphere or position): report its least-squares "
                 "sphericity compensated before and after")
      ->excludes(no_trace);
  app.add_option("--plot-dir", o.plot_dir,
                 "Write residual_map.png, residual_time.png and, when the sphere's form is fitted, "
                 "sphere_form_map.png (gnuplot) with their data into this folder")
      ->excludes(no_trace);
  AddPlotTimeoutOption(app, o.plot_timeout_s);
  app.add_option("--harmonics", o.harmonics,
                 "Highest harmonic order searched of the harmonic effects; 0: chosen on each axis from the "
                 "seven-error residual (4, or one above its highest significant harmonic), at most what the "
                 "pattern resolves ((n - 1) / 2 for n distinct angles, at most 12)")
      ->capture_default_str()
      ->check(CLI::Range(0, 12));
  app.add_option("--phi-wobble-pivot-mm", o.phi_wobble_pivot_mm,
                 "Distance along the Phi axis from its frame's origin to the bearing it tilts about (phi_wobble), "
                 "from the machine's drawing [mm]")
      ->capture_default_str()
      ->check(InRange(ranges::kPivotMm));
  app.add_option("--drift-order", o.drift_order, "Highest power of time of probe_drift")
      ->capture_default_str()
      ->check(CLI::Range(1, 3));
  AddSeedOption(app, o.seed, "Seed of the cross-validation folds")->capture_default_str();
  AddConditionOptions(app, o.conditions, "(overrides the file's ");
  app.add_option("--coverage", o.coverage,
                 "Coverage probability of the expanded uncertainties U = k u (k from the effective degrees of "
                 "freedom); default: k = 2")
      ->check(InRange(ranges::kCoverageProbability));
}

namespace {

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

// The budget of the calibration reported; none (with a warning) when the fit was not analysed or
// a refit fails.
std::optional<CalibrationBudget> BudgetOf(const PointsData& points, const CalibrationOptions& copts,
                                          const CalibrationResult& result, const EffectFit* extended,
                                          const CalibrationInputs& inputs, std::ostream& err) {
  if (result.analysis.Empty() || !result.converged) return std::nullopt;
  BudgetRefit refit = [&](const PointsData& p, const CalibrationOptions& o) {
    if (extended == nullptr) {
      CalibrationOptions q = o;
      q.initial_geometry = result.geometry;
      return ParameterVector(Calibrate(p, q));
    }
    const EffectFit fit = FitEffects(p, o, extended->model, EffectFitStart::From(*extended));
    return ParameterVector(fit.calibration, fit.values, fit.form_values);
  };
  try {
    return MakeCalibrationBudget(WithoutOutliers(points, result), copts, result.analysis, result.n_points, inputs,
                                 refit);
  } catch (const std::exception& e) {
    err << "sph_calibrate: warning: no uncertainty budget: " << e.what() << "\n";
    return std::nullopt;
  }
}

// The calibration's settings from the options and the points file's header (the options win);
// `inputs` gets the measuring conditions of both.
CalibrationOptions SettingsOf(const CalibrateOptions& o, const PointsData& points, CalibrationInputs* inputs) {
  const auto radius = o.sphere_radius_mm ? o.sphere_radius_mm : points.header.sphere_radius_mm;
  const auto offset = o.probe_offset_mm ? o.probe_offset_mm : points.header.probe_offset_mm;
  if (!radius) {
    throw Error(o.points_path +
                ": the reference sphere radius R0 is not given: add a header line "
                "'# sphere_radius_mm: <R0>' to the file or pass --sphere-radius-mm");
  }
  if (!offset) {
    throw Error(o.points_path +
                ": the nominal probe zero distance d is not given: add a header line "
                "'# probe_offset_mm: <d>' to the file or pass --probe-offset-mm");
  }
  *inputs = CalibrationInputs().With(ConditionsOf(points.header)).With(o.conditions);
  if (o.coverage) inputs->coverage.probability = *o.coverage;
  CalibrationOptions copts;
  copts.sphere_radius_mm = inputs->RadiusAtTemperatureMm(*radius);
  for (const auto& [setup, radius_mm] : points.header.sphere_radii_mm) {
    copts.sphere_radii_mm[setup] = inputs->RadiusAtTemperatureMm(radius_mm);  // the same temperature and CTE
  }
  copts.probe_offset_mm = *offset;
  copts.max_std_um = o.max_std_um;
  copts.max_iterations = o.max_iterations;
  return copts;
}

// The probe's measuring range: --probe-range-mm, else the points file's probe_range_mm.
std::optional<double> ProbeRangeOf(const CalibrateOptions& o, const PointsData& points) {
  return o.conditions.probe_range_mm ? o.conditions.probe_range_mm : ConditionsOf(points.header).probe_range_mm;
}

// The residual traced to further effects (or the effects of --effects fitted), from the seven-error
// fit `base`.
TraceResult TraceOf(const CalibrateOptions& o, const PointsData& points, const CalibrationOptions& copts,
                    const CalibrationResult& base, Progress& progress) {
  TraceOptions topts;
  topts.harmonics = {o.harmonics, o.harmonics};
  topts.drift_order = o.drift_order;
  topts.phi_wobble_pivot_mm = o.phi_wobble_pivot_mm;
  topts.probe_range_mm = ProbeRangeOf(o, points);
  topts.seed = o.seed;
  topts.hold_confounded = o.hold_confounded;
  topts.progress = [&](int round, int done, int total) {
    progress.Update("tracing the residual, round " + std::to_string(round) + ": candidates", done, total);
  };
  if (o.effects.empty()) return TraceResidual(points, copts, base, topts);
  std::vector<Effect> fixed;
  for (const std::string& id : o.effects) {
    Effect e;
    EffectFromId(id, &e);  // checked by the option's validator
    if (std::find(fixed.begin(), fixed.end(), e) == fixed.end()) fixed.push_back(e);
  }
  return FitFixedEffects(points, copts, base, fixed, topts);
}

// The calibration file of `result` (with the trace's effects when `extended`) staged to o.output_path,
// or the reason it is not written on err.
void StageCalibrationFile(const CalibrateOptions& o, const CalibrationResult& result, const ReportContext& ctx,
                          const EffectFit* extended, const CalibrationBudget* budget, bool usable, OutputFiles& files,
                          std::ostream& err) {
  const std::string prog = "sph_calibrate";
  if (!usable) {
    err << prog << ": not writing " << o.output_path << ": the calibration is not usable\n";
    return;
  }
  CalibrationFile file = MakeCalibrationFile(result, ctx);
  if (extended && AddEffectsToCalibrationFile(*extended, file)) {
    err << prog << ": note: " << o.output_path
        << " leaves out probe_drift: a drift belongs to the run it was measured in\n";
  }
  std::vector<int> columns;
  for (int p = 0; p < kNumScmsParams; ++p) columns.push_back(p);
  if (extended) columns = AppliedColumns(*extended);
  AddCovarianceToCalibrationFile(columns, result, budget, file);
  files.Stage(o.output_path, [&](std::ostream& f) { WriteCalibration(f, file); });
}

}  // namespace

int RunCalibrate(const CalibrateOptions& o, std::ostream& out, std::ostream& err) {
  const std::string prog = "sph_calibrate";
  const PlotFolder plot_folder(o.plot_dir);  // removed again when a failed run leaves it empty
  try {
    const bool text = !o.quiet && o.json_path != "-";
    RunPaths paths;
    paths.Input("points", o.points_path)
        .Input("--validate", o.validate_path)
        .Output("the text report (-q leaves it out)", text ? "-" : "")
        .Output("--json", o.json_path)
        .Output("--output", o.output_path);
    if (!o.plot_dir.empty()) {
      for (const std::string& f : kTracePlotFiles) paths.Output("--plot-dir", o.plot_dir + "/" + f);
    }
    Progress progress(prog, err, o.progress);
    progress.Stage("reading " + o.points_path);
    const PointsData points = ReadPointsFile(o.points_path);
    CalibrationInputs inputs;
    const CalibrationOptions copts = SettingsOf(o, points, &inputs);
    if (const std::optional<double> range = ProbeRangeOf(o, points)) {
      CheckReadingsInProbeRange(points, *range, o.conditions.probe_range_mm ? "--probe-range-mm" : "probe_range_mm");
    }
    // Readings that parse but look wrong: said first, on stderr, whatever the report's form.
    progress.Stage("checking " + std::to_string(points.samples.size()) + " samples");
    const std::vector<std::string> warnings = PlausibilityWarnings(points);
    progress.Finish();
    for (const std::string& w : warnings) err << prog << ": warning: " << w << "\n";
    progress.Stage("calibrating the seven errors");
    const CalibrationResult base = Calibrate(points, copts);
    std::optional<TraceResult> trace;
    std::optional<Validation> validation;
    if (!o.no_trace) {
      trace = TraceOf(o, points, copts, base, progress);
      if (!o.validate_path.empty()) {
        validation = Validate(o.validate_path, copts.probe_offset_mm, *trace);
        if (SameFile(o.validate_path, o.points_path)) {
          validation->note =
              "the validation file is the calibration's own points file: this shows how the model "
              "fits its own data, not an independent check" +
              (validation->note.empty() ? std::string() : "; " + validation->note);
        }
      }
    }
    progress.Finish();  // the report follows on stdout, maybe the same terminal
    // The calibration reported: the seven errors of the final model, fitted with its effects and
    // the sphere's form when the trace added any.
    const bool extended = trace && !(trace->after.fit.model.Empty() && trace->after.fit.model.form.Empty());
    const CalibrationResult& result = extended ? trace->after.fit.calibration : base;

    const std::optional<CalibrationBudget> budget =
        BudgetOf(points, copts, result, extended ? &trace->after.fit : nullptr, inputs, err);

    ReportContext ctx;
    ctx.budget = budget ? &*budget : nullptr;
    ctx.program = prog + " " SPH_VERSION;
    ctx.points_path = o.points_path;
    ctx.sphere_radius_mm = copts.sphere_radius_mm;
    ctx.sphere_radii_mm = copts.sphere_radii_mm;
    ctx.probe_offset_mm = copts.probe_offset_mm;
    ctx.max_std_um = o.max_std_um;
    ctx.probe_range_mm = ProbeRangeOf(o, points);
    ctx.metadata = points.header.metadata;
    ctx.trace = trace ? &*trace : nullptr;
    ctx.validation = validation ? &*validation : nullptr;
    const Usability usability = JudgeUsability(result, ctx);
    OutputFiles files(out);
    if (!o.json_path.empty()) {
      const std::string json = JsonReport(result, ctx);
      files.Stage(o.json_path, [&](std::ostream& f) { f << json; });
    }
    if (!o.output_path.empty()) {
      StageCalibrationFile(o, result, ctx, extended ? &trace->after.fit : nullptr, budget ? &*budget : nullptr,
                           usability.usable, files, err);
    }
    if (trace && !o.plot_dir.empty()) {
      plot_folder.Make();
      PlotTrace(o.plot_dir, points, copts, *trace, o.plot_timeout_s, files);
    }
    if (text) {
      WriteTextReport(out, result, ctx);
    }
    if (!text) {  // the report that says why is not shown: stderr does
      if (o.quiet) {
        for (const auto& w : result.warnings) err << prog << ": warning: " << w << "\n";
      }
      for (const std::string& why : usability.reasons) err << prog << ": not usable: " << why << "\n";
    }
    files.Commit();
    return usability.usable ? kExitOk : kExitNotUsable;
  } catch (const std::exception& e) {
    err << prog << ": error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace sph::apps
