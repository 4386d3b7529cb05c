// What instrument host software does with the installed core, without Ceres: load a calibration
// file, compensate readings with the header-only model, evaluate the sphere.
#include <cmath>
#include <cstdio>
#include <vector>

#include "sph/io/calibration_file.hpp"
#include "sph/measure/sphere_measurement.hpp"
#include "sph/model/compensation.hpp"

int main() {
  sph::CalibrationFile file;
  file.geometry = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -0.062};
  file.probe_offset_mm = 25.0;
  file.created_by = "consumer_core";
  sph::WriteCalibrationFile("consumer_cal.json", file);
  const sph::Calibration cal = sph::LoadCalibration("consumer_cal.json");

  // A sphere of radius 20 at the axes' common point: r = d + d' - 20 everywhere.
  std::vector<sph::RawReading> readings;
  for (int i = 0; i < 24; ++i) {
    for (int j = 0; j < 12; ++j) readings.push_back({15.0 * i, 7.5 + 15.0 * j, 25.0 - 0.062 - 20.0});
  }
  const sph::SphereEvaluation ev = sph::EvaluateSphere(sph::CompensateAll(cal, readings), "consumer");
  std::printf("radius %.9f mm, sphericity LS %.3g um, MZ %.3g um\n", ev.ls.sphere.radius, ev.sphericity_ls_mm * 1e3,
              ev.mz.width * 1e3);
  return cal.IsValid() && std::abs(ev.ls.sphere.radius - 20.0) < 1e-9 && ev.mz.width < 1e-9 ? 0 : 1;
}
