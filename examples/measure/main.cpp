// measure_host POINTS CALIBRATION REPORT_JSON
//
// Measures the sphere of the points file POINTS as `sph_measure POINTS -c CALIBRATION --json
// REPORT_JSON` does, through one library call, and writes the same report.
#include <exception>
#include <iostream>
#include <string>

#include "sph/measure/measure_workflow.hpp"
#include "sph/io/output_files.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: measure_host POINTS CALIBRATION REPORT_JSON\n";
    return 2;
  }
  try {
    sph::MeasurementWorkflowOptions options;  // the defaults: 200 calibration draws, the noise floor, the check
    options.calibration_path = argv[2];
    options.on_warning = [](const std::string& warning) { std::cerr << "warning: " << warning << "\n"; };
    const sph::MeasurementWorkflowResult run = sph::RunMeasurementWorkflow(argv[1], options);
    const std::string report = run.JsonReport();
    sph::WriteFileAtomically(argv[3], [&](std::ostream& out) { out << report; });
    std::cout << "sphericity (minimum zone): " << run.evaluation.mz.width * 1000.0 << " um\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
}
