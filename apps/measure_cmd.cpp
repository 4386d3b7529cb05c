#include "measure_cmd.hpp"

#include <exception>
#include <vector>

#include <CLI/CLI.hpp>

#include "app_common.hpp"
#include "gnuplot.hpp"
#include "sph/io/output_files.hpp"
#include "sph/internal/format.hpp"

namespace sph::apps {
namespace {

const char* const kProgram = "sph_measure";

/// Stages the form-error map: the script (--plot-script) and the image (--plot), drawn now.
void DrawFormMap(const MeasureOptions& o, const MeasurementWorkflowResult& measured, OutputFiles& files) {
  const std::string script = measured.FormMapScript(o.plot_path.empty() ? "form_map.png" : o.plot_path);
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

// The JCGM 101 check of the sphericities' budgets.
void AddMonteCarloCheckOptions(CLI::App& app, MeasurementWorkflowOptions& o) {
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
}

}  // namespace

void SetupMeasureApp(CLI::App& app, MeasureOptions& o) {
  app.description(
      "Measure a sphere: compensate raw readings with a calibration (or read x y z points), fit the "
      "least-squares sphere, evaluate least-squares and minimum-zone sphericity and their uncertainty "
      "from the calibration, and draw the form-error map.");
  app.add_option("points", o.points_path, "Points file: readings (sph-points 1), or x y z [mm] with --xyz")->required();
  app.add_flag("--xyz", o.workflow.xyz,
               "The points file holds x y z coordinates [mm], one point a line (also NIST .ds)");
  app.add_flag("--subtract-sphere-form", o.workflow.subtract_sphere_form,
               "The points are of the calibration sphere: take its form (from the calibration file) off them, in the "
               "orientation the points file's mount_rotation_deg gives");
  app.add_option("-c,--calibration", o.workflow.calibration_path, "Calibration file (JSON, from sph_calibrate -o)");
  app.add_option("--setup", o.workflow.setup, "Setup id to measure, when the points file holds several");
  app.add_option("--json", o.json_path, "Write the results as JSON to this file ('-' for stdout)");
  app.add_option("--report", o.report_path,
                 "Write the report as one self-contained HTML document (printable: A4) to this file ('-' for stdout)");
  AddDccOptions(app, o.dcc_path, o.dcc_settings_path);
  app.add_option("-o,--output", o.output_path, "Write the compensated points (x_mm y_mm z_mm) to this file");
  app.add_option("--plot", o.plot_path, "Draw the form-error map to this PNG file (needs gnuplot)");
  app.add_option("--plot-script", o.plot_script_path,
                 "Write the form-error map as a gnuplot script (data inline; run: gnuplot FILE)");
  app.add_option("--gnuplot", o.gnuplot, "The gnuplot program")->capture_default_str();
  AddPlotTimeoutOption(app, o.plot_timeout_s);
  app.add_option("--uncertainty-samples", o.workflow.uncertainty_samples,
                 "Calibration draws for the uncertainty from the calibration's covariance (0: none)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000000));
  AddSeedOption(app, o.workflow.seed, "Seed of the calibration draws")->capture_default_str();
  app.add_option("--noise-um", o.workflow.noise_um,
                 "The probe's noise sigma for the noise floor of the form values [um] (default: the calibration's "
                 "fit rms, its source.fit_rms_um)")
      ->check(InRange({0.0, 1000.0, "um", true}));
  app.add_option("--noise-floor-draws", o.workflow.noise_floor_draws,
                 "Simulated measurements of pure noise at the measured directions for the noise floor; 0: none")
      ->capture_default_str()
      ->check(CLI::Range(0, 100000));
  app.add_option("--coverage", o.workflow.coverage,
                 "Coverage probability of the expanded uncertainties U = k u (k from the effective degrees of "
                 "freedom); default: k = 2")
      ->check(InRange(ranges::kCoverageProbability));
  AddMonteCarloCheckOptions(app, o.workflow);
  app.add_option("--max-dilution", o.workflow.max_dilution,
                 "Warn when the coverage determines radius or centre this many times worse than points over the "
                 "whole sphere")
      ->capture_default_str()
      ->check(InRange({0.0, 1e6, "", true}));
  app.add_flag("-q,--quiet", o.quiet, "No text report on stdout (warnings still go to stderr)");
  AddProgressOptions(app, o.progress);
}

int RunMeasure(const MeasureOptions& o, std::ostream& out, std::ostream& err) {
  try {
    o.workflow.Check();
    const bool text = !o.quiet && o.json_path != "-" && o.report_path != "-" && o.dcc_path != "-";
    RunPaths()
        .Input("points", o.points_path)
        .Input("--calibration", o.workflow.calibration_path)
        .Input("--dcc-settings", o.dcc_settings_path)
        .Output("the text report (-q leaves it out)", text ? "-" : "")
        .Output("--json", o.json_path)
        .Output("--report", o.report_path)
        .Output("--dcc", o.dcc_path)
        .Output("--output", o.output_path)
        .Output("--plot", o.plot_path)
        .Output("--plot-script", o.plot_script_path);
    const dcc::Settings settings =
        o.dcc_settings_path.empty() ? dcc::Settings{} : dcc::ReadSettings(o.dcc_settings_path);
    Progress progress(kProgram, err, o.progress);
    MeasurementWorkflowOptions workflow = o.workflow;
    workflow.on_progress = [&](const std::string& stage, long done, long total) {
      progress.Update(stage, done, total);
    };
    workflow.on_warning = [&](const std::string& warning) {
      progress.Finish();
      err << kProgram << ": warning: " << warning << "\n";
    };
    const MeasurementWorkflowResult run = RunMeasurementWorkflow(o.points_path, workflow);
    progress.Finish();  // the report follows on stdout, maybe the same terminal
    OutputFiles files(out);
    if (!o.json_path.empty()) {
      const std::string report = run.JsonReport();
      files.Stage(o.json_path, [&](std::ostream& f) { f << report; });
    }
    if (!o.report_path.empty()) {
      const std::string report = run.HtmlReport();
      files.Stage(o.report_path, [&](std::ostream& f) { f << report; });
    }
    if (!o.dcc_path.empty()) {
      const std::string certificate = run.Dcc(settings);
      files.Stage(o.dcc_path, [&](std::ostream& f) { f << certificate; });
    }
    if (!o.output_path.empty()) files.Stage(o.output_path, [&](std::ostream& f) { run.WritePoints(f); });
    if (!o.plot_path.empty() || !o.plot_script_path.empty()) {
      DrawFormMap(o, run, files);
    }
    if (text) run.WriteTextReport(out);
    if (!text) {
      for (const auto& w : run.evaluation.warnings) err << kProgram << ": warning: " << w << "\n";
    }
    files.Commit();
    return kExitOk;
  } catch (const std::exception& e) {
    err << kProgram << ": error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace sph::apps
