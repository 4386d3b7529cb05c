#include "calibrate_cmd.hpp"

#include <exception>

#include <CLI/CLI.hpp>

#include "app_common.hpp"
#include "calibrate_plots.hpp"
#include "sph/core/error.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/firmware_export.hpp"
#include "sph/io/output_files.hpp"
#include "sph/io/parameter_settings.hpp"
#include "sph/model/effect_terms.hpp"

namespace sph::apps {

namespace {

// The run's paths, checked before anything is read: no output replaces an input or another output.
RunPaths PathsOf(const CalibrateOptions& o, bool text) {
  RunPaths paths;
  paths.Input("points", o.points_path)
      .Input("--validate", o.workflow.validate_path)
      .Input("--compare", o.workflow.compare_path)
      .Input("--dcc-settings", o.dcc_settings_path);
  for (const std::string& f : o.workflow.sphere_form_paths) paths.Input("--sphere-form", f);
  paths.Output("the text report (-q leaves it out)", text ? "-" : "")
      .Output("--json", o.json_path)
      .Output("--report", o.report_path)
      .Output("--dcc", o.dcc_path)
      .Output("--output", o.output_path)
      .Output("--firmware-blob", o.firmware_blob_path)
      .Output("--firmware-c", o.firmware_c_path);
  if (!o.plot_dir.empty()) {
    for (const std::string& f : kTracePlotFiles) paths.Output("--plot-dir", o.plot_dir + "/" + f);
  }
  return paths;
}

// The calibration file staged to o.output_path and the firmware's to theirs, or the reason they are
// not written on err.
void StageCalibrationFile(const CalibrateOptions& o, const CalibrationWorkflowResult& run, OutputFiles& files,
                          std::ostream& err) {
  std::string names;
  for (const std::string* p : {&o.output_path, &o.firmware_blob_path, &o.firmware_c_path}) {
    if (!p->empty()) names += (names.empty() ? "" : ", ") + *p;
  }
  if (!run.usability.usable) {
    err << "sph_calibrate: not writing " << names << ": the calibration is not usable\n";
    return;
  }
  bool drift_left_out = false;
  const CalibrationFile file = run.MakeCalibrationFile(&drift_left_out);
  if (drift_left_out) {
    err << "sph_calibrate: note: " << names << " leave" << (names.find(", ") == std::string::npos ? "s" : "")
        << " out probe_drift: a drift belongs to the run it was measured in\n";
  }
  if (!o.output_path.empty()) files.Stage(o.output_path, [&](std::ostream& f) { WriteCalibration(f, file); });
  StageFirmwareExport(ToCalibration(file), {o.firmware_blob_path, o.firmware_c_path}, o.points_path, files);
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
  for (const std::string& text : o.target_u) {
    const FixedParameter f = ParseFixedParameter(text, "--target-u " + text);
    if (!f.value || !(*f.value > 0.0)) {
      throw Error("--target-u " + text +
                  ": expected NAME_UNIT=U, U the largest expanded uncertainty (> 0) the use "
                  "allows, e.g. alpha_urad=5");
    }
    workflow.requirement.target_u.push_back({f.name, *f.value, text});
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
    const bool text = !o.quiet && o.json_path != "-" && o.report_path != "-" && o.dcc_path != "-";
    PathsOf(o, text);
    const dcc::Settings settings =
        o.dcc_settings_path.empty() ? dcc::Settings{} : dcc::ReadSettings(o.dcc_settings_path);
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
    if (!o.dcc_path.empty()) {
      const std::string certificate = run.Dcc(settings);
      files.Stage(o.dcc_path, [&](std::ostream& f) { f << certificate; });
    }
    if (!o.output_path.empty() || !o.firmware_blob_path.empty() || !o.firmware_c_path.empty()) {
      StageCalibrationFile(o, run, files, err);
    }
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
