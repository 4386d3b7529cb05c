#include "calibrate_cmd.hpp"

#include <exception>

#include <CLI/CLI.hpp>

#include "app_common.hpp"
#include "calibrate_plots.hpp"
#include "sph/core/calibration_file.hpp"
#include "sph/core/output_files.hpp"
#include "sph/core/parameter_settings.hpp"
#include "sph/model/effect_terms.hpp"

namespace sph::apps {

namespace {

// CLI11's check of an integer option in `range` ("INT in [1 - 3]" in --help).
CLI::Range IntRange(const ValidRange& range) {
  return CLI::Range(static_cast<int>(range.lo), static_cast<int>(range.hi));
}

// --fix, --prior and the robust loss.
void AddFitSettingOptions(CLI::App& app, CalibrateOptions& o) {
  const std::string told = "Fix, inform and weight (sph/core/parameter_settings.hpp)";
  app.add_option("--fix", o.fix,
                 "Hold a parameter instead of fitting it: NAME at its start value (the seven errors: 0), or "
                 "NAME_UNIT=VALUE, e.g. d_prime_mm=-0.062 (units deg, arcsec, urad, mm, um); a parameter is one of "
                 "the seven errors or an effect's (theta_encoder.c2); repeatable; overrides the file's 'fix'")
      ->group(told);
  app.add_option("--prior", o.prior,
                 "A Gaussian prior from an independent measurement: NAME_UNIT=VALUE,U with U its standard "
                 "uncertainty, e.g. alpha_deg=0.02,0.0005; listed in the uncertainty budget as an input of its own; "
                 "repeatable; overrides the file's 'prior'")
      ->group(told);
  auto* robust =
      app.add_option("--robust-loss", o.robust_loss,
                     "Fit with a robust loss instead of least squares and the outlier rule, every reading kept at a "
                     "weight: huber or cauchy (with --no-trace or --effects)")
          ->check(CLI::IsMember({"huber", "cauchy"}))
          ->group(told);
  app.add_option("--robust-scale-sigma", o.workflow.fit.robust_scale_sigma,
                 "The robust loss' scale in units of the readings' noise (1.4826 median absolute deviation of the "
                 "residuals); default: huber 1.345, cauchy 2.385")
      ->check(CLI::Range(0.01, 100.0))
      ->needs(robust)
      ->group(told);
}

// The trace's options, the Type B inputs and the coverage.
void AddTraceOptions(CLI::App& app, CalibrateOptions& o) {
  std::string ids;
  for (const EffectInfo& e : kEffectInfo) ids += (ids.empty() ? "" : ", ") + std::string(e.id);
  auto* no_trace = app.add_flag_callback(
      "--no-trace", [&o] { o.workflow.trace = false; },
      "Fit the seven errors only; do not trace the residual to further effects");
  app.add_option("--effects", o.effects, "Fit exactly these effects (comma-separated), no selection: " + ids)
      ->delimiter(',')
      ->excludes(no_trace)
      ->check(CLI::IsMember([] {
        std::vector<std::string> v;
        for (const EffectInfo& e : kEffectInfo) v.emplace_back(e.id);
        return v;
      }()));
  app.add_flag("--hold-confounded", o.workflow.trace_options.hold_confounded,
               "When the effect the trace would add cannot be told from another (by this design, or about equal "
               "scores), add neither and report both; default: add the one that explains more and name the other")
      ->excludes(no_trace);
  app.add_option("--validate", o.workflow.validate_path,
                 "Another points file of the same machine (another sphere or position): report its least-squares "
                 "sphericity compensated before and after")
      ->excludes(no_trace);
  app.add_option("--compare", o.workflow.compare_path,
                 "An earlier calibration file of this machine (-o): compare each of the seven errors and each "
                 "effect parameter both hold, previous, now, difference, its U (k = 2) and En = difference / U, "
                 "in the reports; the exit code stays the calibration's");
  app.add_option("--sphere-form", o.workflow.sphere_form_path,
                 "A calibration file holding the reference sphere's form (sph_calibrate -o of a run that separated "
                 "it): the form enters the fit as known within its covariance, and the report says how the readings "
                 "agree with it; the points' R0 must be the file's")
      ->excludes(no_trace);
  app.add_option("--plot-dir", o.plot_dir,
                 "Write residual_map.png, residual_time.png and, when the sphere's form is fitted, "
                 "sphere_form_map.png (gnuplot) with their data into this folder")
      ->excludes(no_trace);
  AddPlotTimeoutOption(app, o.plot_timeout_s);
  app.add_option_function<int>(
         "--harmonics",
         [&o](const int& h) {
           o.workflow.trace_options.harmonics = {h, h};
         },
         "Highest harmonic order searched of the harmonic effects; 0: chosen on each axis from the "
         "seven-error residual (4, or one above its highest significant harmonic), at most what the "
         "pattern resolves ((n - 1) / 2 for n distinct angles, at most 12)")
      ->default_str(std::to_string(o.workflow.trace_options.harmonics.theta))
      ->check(IntRange(ranges::kHarmonicOrder));
  app.add_option("--phi-wobble-pivot-mm", o.workflow.trace_options.phi_wobble_pivot_mm,
                 "Distance along the Phi axis from its frame's origin to the bearing it tilts about (phi_wobble), "
                 "from the machine's drawing [mm]")
      ->capture_default_str()
      ->check(InRange(ranges::kPivotMm));
  app.add_option("--drift-order", o.workflow.trace_options.drift_order, "Highest power of time of probe_drift")
      ->capture_default_str()
      ->check(IntRange(ranges::kDriftOrder));
  AddSeedOption(app, o.workflow.trace_options.seed, "Seed of the cross-validation folds")->capture_default_str();
  AddConditionOptions(app, o.workflow.conditions, "(overrides the file's ");
  AddFitSettingOptions(app, o);
  app.add_option("--coverage", o.workflow.coverage,
                 "Coverage probability of the expanded uncertainties U = k u (k from the effective degrees of "
                 "freedom); default: k = 2")
      ->check(InRange(ranges::kCoverageProbability));
}

}  // namespace

void SetupCalibrateApp(CLI::App& app, CalibrateOptions& o) {
  app.description(
      "Calibrate the seven geometric errors of a spherical coordinate measuring system from points "
      "measured on a reference sphere (format: docs/formats/points-files.md).");
  app.add_option("points", o.points_path, "Points file (sph-points 1)")->required();
  app.add_option("--sphere-radius-mm", o.workflow.sphere_radius_mm,
                 "Reference sphere radius R0 [mm] (overrides the file's sphere_radius_mm)")
      ->check(InRange(ranges::kSphereRadiusMm));
  app.add_option("--probe-offset-mm", o.workflow.probe_offset_mm,
                 "Nominal probe zero distance d [mm] (overrides the file's probe_offset_mm)")
      ->check(InRange(ranges::kProbeOffsetMm));
  app.add_option("--json", o.json_path, "Write the report as JSON to this file ('-' for stdout)");
  app.add_option("--report", o.report_path,
                 "Write the report as one self-contained HTML document (printable: A4) to this file ('-' for stdout)");
  app.add_option("-o,--output", o.output_path,
                 "Write the calibration file (JSON) that compensation loads; written only when usable");
  app.add_option("--max-std-um", o.workflow.fit.max_std_um,
                 "A parameter whose standard uncertainty, as a displacement of the probed point (angles times "
                 "R0), exceeds this is undetermined [um]")
      ->capture_default_str()
      ->check(InRange(ranges::kStdUm));
  app.add_option("--max-iterations", o.workflow.fit.max_iterations, "Levenberg-Marquardt iteration limit")
      ->capture_default_str()
      ->check(IntRange(ranges::kMaxIterations));
  app.add_flag("-q,--quiet", o.quiet, "No text report on stdout (warnings still go to stderr)");
  AddProgressOptions(app, o.progress);
  AddTraceOptions(app, o);
}

namespace {

// The run's paths, checked before anything is read: no output replaces an input or another output.
RunPaths PathsOf(const CalibrateOptions& o, bool text) {
  RunPaths paths;
  paths.Input("points", o.points_path)
      .Input("--validate", o.workflow.validate_path)
      .Input("--compare", o.workflow.compare_path)
      .Input("--sphere-form", o.workflow.sphere_form_path)
      .Output("the text report (-q leaves it out)", text ? "-" : "")
      .Output("--json", o.json_path)
      .Output("--report", o.report_path)
      .Output("--output", o.output_path);
  if (!o.plot_dir.empty()) {
    for (const std::string& f : kTracePlotFiles) paths.Output("--plot-dir", o.plot_dir + "/" + f);
  }
  return paths;
}

// The calibration file staged to o.output_path, or the reason it is not written on err.
void StageCalibrationFile(const CalibrateOptions& o, const CalibrationWorkflowResult& run, OutputFiles& files,
                          std::ostream& err) {
  if (!run.usability.usable) {
    err << "sph_calibrate: not writing " << o.output_path << ": the calibration is not usable\n";
    return;
  }
  bool drift_left_out = false;
  const CalibrationFile file = run.MakeCalibrationFile(&drift_left_out);
  if (drift_left_out) {
    err << "sph_calibrate: note: " << o.output_path
        << " leaves out probe_drift: a drift belongs to the run it was measured in\n";
  }
  files.Stage(o.output_path, [&](std::ostream& f) { WriteCalibration(f, file); });
}

// The workflow's options: the app's as parsed, the texts of --fix, --prior, --robust-loss and
// --effects read.
CalibrationWorkflowOptions WorkflowOf(const CalibrateOptions& o) {
  CalibrationWorkflowOptions workflow = o.workflow;
  workflow.program = "sph_calibrate " SPH_VERSION;
  for (const std::string& text : o.fix) workflow.fit.fixed.push_back(ParseFixedParameter(text, "--fix " + text));
  for (const std::string& text : o.prior) {
    workflow.fit.priors.push_back(ParseParameterPrior(text, "--prior " + text));
  }
  if (!o.robust_loss.empty()) {
    workflow.fit.robust_loss = o.robust_loss == "cauchy" ? RobustLoss::kCauchy : RobustLoss::kHuber;
  }
  for (const std::string& id : o.effects) {
    EffectFromId(id, &workflow.effects.emplace_back());  // an id the option checked
  }
  return workflow;
}

}  // namespace

int RunCalibrate(const CalibrateOptions& o, std::ostream& out, std::ostream& err) {
  const std::string prog = "sph_calibrate";
  const PlotFolder plot_folder(o.plot_dir);  // removed again when a failed run leaves it empty
  try {
    const bool text = !o.quiet && o.json_path != "-" && o.report_path != "-";
    PathsOf(o, text);
    Progress progress(prog, err, o.progress);
    CalibrationWorkflowOptions workflow = WorkflowOf(o);
    workflow.on_stage = [&](const std::string& stage) { progress.Stage(stage); };
    workflow.on_warning = [&](const std::string& warning) {
      progress.Finish();
      err << prog << ": warning: " << warning << "\n";
    };
    workflow.trace_options.progress = [&](int round, int done, int total) {
      progress.Update("tracing the residual, round " + std::to_string(round) + ": candidates", done, total);
    };
    const CalibrationWorkflowResult run = RunCalibrationWorkflow(o.points_path, workflow);
    progress.Finish();  // the report follows on stdout, maybe the same terminal
    OutputFiles files(out);
    if (!o.json_path.empty()) {
      const std::string json = run.JsonReport();
      files.Stage(o.json_path, [&](std::ostream& f) { f << json; });
    }
    if (!o.report_path.empty()) {
      const std::string report = run.HtmlReport();
      files.Stage(o.report_path, [&](std::ostream& f) { f << report; });
    }
    if (!o.output_path.empty()) StageCalibrationFile(o, run, files, err);
    if (run.trace && !o.plot_dir.empty()) {
      plot_folder.Make();
      PlotTrace(o.plot_dir, run.points, run.settings, *run.trace, o.plot_timeout_s, files);
    }
    if (text) run.WriteTextReport(out);
    if (!text) {  // the report that says why is not shown: stderr does
      if (o.quiet) {
        for (const auto& w : run.Reported().warnings) err << prog << ": warning: " << w << "\n";
      }
      for (const std::string& why : run.usability.reasons) err << prog << ": not usable: " << why << "\n";
    }
    files.Commit();
    return run.usability.usable ? kExitOk : kExitNotUsable;
  } catch (const std::exception& e) {
    err << prog << ": error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace sph::apps
