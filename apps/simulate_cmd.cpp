#include "simulate_cmd.hpp"

#include <CLI/CLI.hpp>

#include "app_common.hpp"
#include "sph/core/error.hpp"
#include "sph/io/output_files.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/simulation/simulation_options.hpp"

namespace sph::apps {

void SetupSimulateApp(CLI::App& app, SimulateOptions& o) {
  app.description(
      "Simulate the readings of an SCMS measuring a reference sphere, by intersecting the probe ray "
      "with the sphere. Defaults are the paper's study (Table 1 truth, 24 x 12 grid, 2 mm eccentricity).");
  app.option_defaults()->always_capture_default();
  app.add_option("-o,--output", o.output_path, "Points file to write ('-' for stdout)");
  app.add_option("--truth", o.truth_path, "Also write the truth (JSON) to this file");
  AddMachineOptions(app, o.machine);
  app.add_option("--center-mm", o.centers_mm, "Sphere centre x,y,z [mm]; repeat for several setups");
  AddSeedOption(app, o.seed, "Random seed");
  app.add_option("--sample-period-s", o.sample_period_s, "Time between samples [s]")
      ->check(InRange(ranges::kSamplePeriodS));
  app.add_option("--effect-arcsec", o.effects_arcsec,
                 "An angle effect's parameter, id.param=value [arcsec], e.g. theta_encoder.c2=10; repeatable")
      ->group("Effects (not declared in the points file)");
  app.add_option("--effect-um", o.effects_um,
                 "A length effect's parameter, id.param=value [um], e.g. probe_drift.t1=0.5; repeatable")
      ->group("Effects (not declared in the points file)");
  app.add_option("--probe-range-mm", o.probe_range_mm,
                 "The probe's measuring range, readings 0 to it [mm]: probe_gain and probe_nonlinearity are given at "
                 "its ends (else at the ends of the readings); written into the header as probe_range_mm")
      ->check(InRange(ranges::kProbeRangeMm))
      ->group("Effects (not declared in the points file)");
  app.add_option("--phi-wobble-pivot-mm", o.phi_wobble_pivot_mm,
                 "Distance along the Phi axis from its frame's origin to the bearing phi_wobble tilts about [mm]")
      ->check(InRange(ranges::kPivotMm))
      ->group("Effects (not declared in the points file)");
  const std::string sphere = "The sphere on its mount and its form";
  app.add_option("--mount-rotation-deg", o.mount_rotations_deg,
                 "SETUP:rx,ry,rz: the rotation vector (axis times angle) [deg] that takes the sphere's body frame into "
                 "the frame turning with Theta, in that setup (each " +
                     ranges::kMountRotationDeg.Text() + "); written into the file's header; repeatable")
      ->group(sphere);
  app.add_option("--mount-unknown", o.mount_unknown,
                 "SETUP: the header says 'unknown' for that setup's rotation (simulated as given); repeatable")
      ->group(sphere);
  app.add_option("--other-sphere-radius-mm", o.sphere_radii_mm,
                 "SETUP:R: that setup measures another sphere, of radius R [mm], perfect (the form options shape the "
                 "reference sphere); written into the file's header as sphere_radius_mm@SETUP; repeatable")
      ->group(sphere);
  AddFormOptions(app, o.form, sphere);
  app.add_option("--scan-order", o.scan_orders,
                 std::string("ORDER or SETUP:ORDER: the time order of the pattern (") + ScanOrderNames() +
                     "; default rings: phi ring by ring, theta within); repeatable")
      ->group(sphere);
  app.add_option("--outlier-fraction", o.outlier_fraction, "Share of readings with a gross error in r")
      ->check(InRange(ranges::kOutlierFraction))
      ->group("Effects (not declared in the points file)");
  app.add_option("--outlier-um", o.outlier_um, "Size of the gross error (random sign) [um]")
      ->check(InRange(ranges::kOutlierUm))
      ->group("Effects (not declared in the points file)");
}

int RunSimulate(const SimulateOptions& o, std::ostream& err) {
  try {
    RunPaths()
        .Input("--angles", o.machine.angles_path)
        .Output("--output", o.output_path)
        .Output("--truth", o.truth_path);
    const SimulationRun run = RunSimulation(o);
    OutputFiles files;
    if (!o.truth_path.empty()) files.Stage(o.truth_path, [&](std::ostream& f) { f << run.truth_json; });
    files.Stage(o.output_path, [&](std::ostream& f) { WritePoints(f, run.points); });
    files.Commit();
    return kExitOk;
  } catch (const std::exception& e) {
    err << "sph_simulate: error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace sph::apps
