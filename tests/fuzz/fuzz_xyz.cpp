// libFuzzer target: sph::ParseXyz (coordinate files, NIST layout) on arbitrary bytes.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "sph/core/error.hpp"
#include "sph/io/xyz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const auto points = sph::ParseXyz(in, "fuzz");
    if (points.empty()) std::abort();  // "no points" is an error
    for (const auto& p : points) {
      if (!p.allFinite()) std::abort();  // every value must be finite
    }
  } catch (const sph::Error&) {
  }
  return 0;
}
