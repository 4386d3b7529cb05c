#include "calibrate_cmd.hpp"

#include "app_common.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/calib/report.hpp"
#include "sph/core/atomic_file.hpp"
#include "sph/core/calibration_file.hpp"
#include "sph/core/error.hpp"
#include "sph/core/points_file.hpp"

namespace sph::apps {

void SetupCalibrateApp(CLI::App& app, CalibrateOptions& o) {
  app.description("Calibrate the seven geometric errors of a spherical coordinate measuring system from points "
                  "measured on a reference sphere (format: data/README.md).");
  app.add_option("points", o.points_path, "Points file (sph-points 1)")->required();
  app.add_option("--sphere-radius-mm", o.sphere_radius_mm,
                 "Reference sphere radius R0 [mm] (overrides the file's sphere_radius_mm)")
      ->check(Positive());
  app.add_option("--probe-offset-mm", o.probe_offset_mm,
                 "Nominal probe zero distance d [mm] (overrides the file's probe_offset_mm)")
      ->check(Positive());
  app.add_option("--json", o.json_path, "Write the report as JSON to this file ('-' for stdout)");
  app.add_option("-o,--output", o.output_path,
                 "Write the calibration file (JSON) that compensation loads; written only when usable");
  app.add_option("--max-std-um", o.max_std_um,
                 "A parameter whose standard uncertainty, as a displacement of the probed point (angles times "
                 "R0), exceeds this is undetermined [um]")
      ->capture_default_str()
      ->check(Positive());
  app.add_option("--max-iterations", o.max_iterations, "Levenberg-Marquardt iteration limit")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_flag("-q,--quiet", o.quiet, "No text report on stdout (warnings still go to stderr)");
}

int RunCalibrate(const CalibrateOptions& o, std::ostream& out, std::ostream& err) {
  const std::string prog = "sph_calibrate";
  try {
    const PointsData points = ReadPointsFile(o.points_path);
    CalibrationOptions copts;
    const auto radius = o.sphere_radius_mm ? o.sphere_radius_mm : points.header.sphere_radius_mm;
    const auto offset = o.probe_offset_mm ? o.probe_offset_mm : points.header.probe_offset_mm;
    if (!radius) {
      throw Error(o.points_path + ": the reference sphere radius R0 is not given: add a header line "
                  "'# sphere_radius_mm: <R0>' to the file or pass --sphere-radius-mm");
    }
    if (!offset) {
      throw Error(o.points_path + ": the nominal probe zero distance d is not given: add a header line "
                  "'# probe_offset_mm: <d>' to the file or pass --probe-offset-mm");
    }
    copts.sphere_radius_mm = *radius;
    copts.probe_offset_mm = *offset;
    copts.max_std_um = o.max_std_um;
    copts.max_iterations = o.max_iterations;
    const CalibrationResult result = Calibrate(points, copts);

    ReportContext ctx;
    ctx.program = prog + " " SPH_VERSION;
    ctx.points_path = o.points_path;
    ctx.sphere_radius_mm = *radius;
    ctx.probe_offset_mm = *offset;
    ctx.max_std_um = o.max_std_um;
    ctx.metadata = points.header.metadata;
    if (!o.quiet && o.json_path != "-") WriteTextReport(out, result, ctx);
    if (o.quiet) {
      for (const auto& w : result.warnings) err << prog << ": warning: " << w << "\n";
    }
    if (!o.json_path.empty()) {
      const std::string json = JsonReport(result, ctx);
      WriteFileAtomically(o.json_path, [&](std::ostream& f) { f << json; });
    }
    if (!o.output_path.empty()) {
      if (result.Usable()) {
        WriteCalibrationFile(o.output_path, MakeCalibrationFile(result, ctx));
      } else {
        err << prog << ": not writing " << o.output_path << ": the calibration is not usable\n";
      }
    }
    return result.Usable() ? kExitOk : kExitNotUsable;
  } catch (const std::exception& e) {
    err << prog << ": error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace sph::apps
