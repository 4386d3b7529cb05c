// What the calibration file fuzz targets check of sph::ParseCalibration on arbitrary bytes: what
// it accepts must be usable by compensation: finite errors, a positive probe offset, a finite
// covariance.
#ifndef SPH_TESTS_FUZZ_CALIBRATION_CHECK_HPP_
#define SPH_TESTS_FUZZ_CALIBRATION_CHECK_HPP_

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "sph/io/calibration_file.hpp"
#include "sph/core/error.hpp"
#include "sph/model/compensation.hpp"

namespace sph::fuzz {

inline int CheckCalibration(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  CalibrationFile file;
  try {
    file = ParseCalibration(in, "fuzz.json");
  } catch (const Error&) {
    return 0;
  }
  if (!(file.probe_offset_mm > 0.0) || !std::isfinite(file.probe_offset_mm)) std::abort();
  for (double v : file.geometry) {
    if (!std::isfinite(v)) std::abort();
  }
  if (file.sphere_radius_mm && !std::isfinite(*file.sphere_radius_mm)) std::abort();
  if (file.covariance && !file.covariance->allFinite()) std::abort();
  const Calibration cal = ToCalibration(file);
  (void)Compensate(cal, 15.0, 30.0, 5.0);
  return 0;
}

}  // namespace sph::fuzz

#endif  // SPH_TESTS_FUZZ_CALIBRATION_CHECK_HPP_
