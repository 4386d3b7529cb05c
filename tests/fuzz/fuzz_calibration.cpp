// libFuzzer target: the calibration file reader (sph::ParseCalibration) on arbitrary bytes. What
// it accepts must be usable by compensation: finite errors, a positive probe offset, a finite
// covariance.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "sph/core/calibration_file.hpp"
#include "sph/core/error.hpp"
#include "sph/model/compensation.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  sph::CalibrationFile file;
  try {
    file = sph::ParseCalibration(in, "fuzz.json");
  } catch (const sph::Error&) {
    return 0;
  }
  if (!(file.probe_offset_mm > 0.0) || !std::isfinite(file.probe_offset_mm)) std::abort();
  for (double v : file.geometry) {
    if (!std::isfinite(v)) std::abort();
  }
  if (file.sphere_radius_mm && !std::isfinite(*file.sphere_radius_mm)) std::abort();
  if (file.covariance && !file.covariance->allFinite()) std::abort();
  const sph::Calibration cal = sph::ToCalibration(file);
  (void)sph::Compensate(cal, 15.0, 30.0, 5.0);
  return 0;
}
