// calibrate_host POINTS VALIDATE REPORT_JSON CALIBRATION_JSON
//
// Calibrates the points file POINTS as `sph_calibrate POINTS --validate VALIDATE --json
// REPORT_JSON -o CALIBRATION_JSON` does, through one library call, and writes the same two files.
#include <exception>
#include <iostream>
#include <string>

#include "sph/calib/calibrate_workflow.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/output_files.hpp"

int main(int argc, char** argv) {
  if (argc != 5) {
    std::cerr << "usage: calibrate_host POINTS VALIDATE REPORT_JSON CALIBRATION_JSON\n";
    return 2;
  }
  try {
    sph::CalibrationWorkflowOptions options;  // the defaults: R0 and d from the points file's header
    options.validate_path = argv[2];
    options.on_warning = [](const std::string& warning) { std::cerr << "warning: " << warning << "\n"; };
    const sph::CalibrationWorkflowResult run = sph::RunCalibrationWorkflow(argv[1], options);
    const std::string report = run.JsonReport();
    sph::WriteFileAtomically(argv[3], [&](std::ostream& out) { out << report; });
    if (!run.usability.usable) {
      for (const std::string& why : run.usability.reasons) std::cerr << "not usable: " << why << "\n";
      return 1;
    }
    sph::WriteCalibrationFile(argv[4], run.MakeCalibrationFile());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
}
