// libFuzzer target: the calibration file reader (sph::ParseCalibration) on arbitrary bytes, with
// libFuzzer's own mutations (calibration_check.hpp says what is checked).
#include <cstddef>
#include <cstdint>

#include "calibration_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return sph::fuzz::CheckCalibration(data, size);
}
