// sph_calibrate's command line: its options declared, each with its check and help.
#include <CLI/CLI.hpp>

#include "app_common.hpp"
#include "calibrate_cmd.hpp"
#include "progress.hpp"
#include "sph/model/effect_terms.hpp"

namespace sph::apps {

namespace {

// CLI11's check of an integer option in `range` ("INT in [1 - 3]" in --help).
CLI::Range IntRange(const ValidRange& range) {
  return CLI::Range(static_cast<int>(range.lo), static_cast<int>(range.hi));
}

// --fix, --prior and the robust loss.
void AddFitSettingOptions(CLI::App& app, CalibrateOptions& o) {
  const std::string told = "Fix, inform and weight (sph/io/parameter_settings.hpp)";
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
  app.add_flag("--accept-rejected", o.workflow.accept_rejected,
               "Accept the statements of the lab (--prior, --fix, the header's, --sphere-form and its orientation, "
               "--sphere-form-rms-um) that the readings reject: the calibration is then not unusable for them, the "
               "trace adds nothing on top of them, and the calibration file says they were accepted against the "
               "readings")
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
      ->check(InRange(ranges::kRobustScaleSigma))
      ->needs(robust)
      ->group(told);
}

// What the trace's effects are searched with: harmonic orders, the Phi wobble's pivot, the drift's
// order and the cross-validation's seed.
void AddEffectModelOptions(CLI::App& app, CalibrateOptions& o) {
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
  app.add_option("--sphere-form", o.workflow.sphere_form_paths,
                 "A calibration file holding a sphere's form (sph_calibrate -o of a run that separated it): the "
                 "form enters the fit as known within its covariance, and the report says how the readings agree "
                 "with it. Repeatable, one file per sphere of the points (sphere_radius_mm@<setup>), each matched "
                 "to the sphere whose radius is its R0 within their uncertainties")
      ->excludes(no_trace);
  app.add_option("--plot-dir", o.plot_dir,
                 "Write residual_map.png, residual_time.png and, when the sphere's form is fitted, "
                 "sphere_form_map.png (gnuplot) with their data into this folder")
      ->excludes(no_trace);
  AddPlotTimeoutOption(app, o.plot_timeout_s);
  AddEffectModelOptions(app, o);
  AddConditionOptions(app, o.workflow.conditions, "(overrides the file's ");
  app.get_option("--sphere-form-rms-um")->excludes(no_trace);  // a prior on the form, which --no-trace has not
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
  AddDccOptions(app, o.dcc_path, o.dcc_settings_path);
  app.add_option("-o,--output", o.output_path,
                 "Write the calibration file (JSON) that compensation loads; written only when usable");
  app.add_option("--firmware-blob", o.firmware_blob_path,
                 "Write the calibration as the blob that firmware loads through sph/c/compensation.h (binary, "
                 "CRC-checked); written only when usable");
  app.add_option("--firmware-c", o.firmware_c_path,
                 "Write that blob as a C source of constants (the array sph_calibration_blob); written only when "
                 "usable");
  app.add_option("--max-std-um", o.workflow.fit.max_std_um,
                 "A parameter whose standard uncertainty, as a displacement of the probed point (angles times "
                 "R0), exceeds this is undetermined [um]; given, it is the requirement the calibration is usable "
                 "against, in place of the default (each of the seven errors within twice what the reference "
                 "pattern predicts for this set-up at the readings' noise)")
      ->capture_default_str()
      ->check(InRange(ranges::kStdUm))
      ->each([&o](const std::string&) { o.workflow.requirement.max_std_stated = true; });
  app.add_option("--target-u", o.target_u,
                 "The requirement the calibration is usable against: NAME_UNIT=U, the largest expanded uncertainty "
                 "U (k as the budget's) of a parameter the use allows, e.g. alpha_urad=5 or "
                 "theta_encoder.c2_arcsec=0.5; repeatable; in place of the default requirement");
  app.add_option("--max-iterations", o.workflow.fit.max_iterations, "Levenberg-Marquardt iteration limit")
      ->capture_default_str()
      ->check(IntRange(ranges::kMaxIterations));
  app.add_flag("-q,--quiet", o.quiet, "No text report on stdout (warnings still go to stderr)");
  AddProgressOptions(app, o.progress);
  AddTraceOptions(app, o);
}

}  // namespace sph::apps
