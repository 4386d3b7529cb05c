// libFuzzer target: sph::ParsePoints on arbitrary bytes. A file it accepts must be written back by
// WritePoints and read again to the same samples and header (mount rotations exactly).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "sph/core/error.hpp"
#include "sph/io/points_file.hpp"

namespace {

bool Close(double a, double b, double decimals_ulp) { return std::fabs(a - b) <= decimals_ulp + 1e-15 * std::fabs(a); }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  sph::PointsData parsed;
  try {
    parsed = sph::ParsePoints(in, "fuzz");
  } catch (const sph::Error&) {
    return 0;
  }
  if (parsed.samples.empty()) std::abort();  // ParsePoints promises at least one sample
  std::ostringstream out;
  sph::WritePoints(out, parsed);
  std::istringstream again_in(out.str());
  const sph::PointsData again = sph::ParsePoints(again_in, "fuzz-rewritten");  // must not throw
  if (again.samples.size() != parsed.samples.size() || again.has_time != parsed.has_time ||
      again.has_setup != parsed.has_setup || again.header.sphere_radius_mm != parsed.header.sphere_radius_mm ||
      again.header.probe_offset_mm != parsed.header.probe_offset_mm ||
      again.header.metadata != parsed.header.metadata ||
      again.header.mount_rotations != parsed.header.mount_rotations) {
    std::abort();
  }
  for (std::size_t i = 0; i < parsed.samples.size(); ++i) {
    const sph::Sample& a = parsed.samples[i];
    const sph::Sample& b = again.samples[i];
    // Written with 10 decimals (angles, r) and 6 (t_s): rounding of half the last decimal.
    if (!Close(a.theta_deg, b.theta_deg, 5e-11) || !Close(a.phi_deg, b.phi_deg, 5e-11) ||
        !Close(a.r_mm, b.r_mm, 5e-11) || (parsed.has_time && !Close(a.t_s, b.t_s, 5e-7)) || a.setup != b.setup) {
      std::abort();
    }
  }
  return 0;
}
