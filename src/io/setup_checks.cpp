#include "sph/io/setup_checks.hpp"

#include <algorithm>
#include <cmath>

#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"

namespace sph {

using internal::Format;

void CheckReadingsInProbeRange(const PointsData& points, double probe_range_mm, const std::string& range_from) {
  std::size_t outside = 0, first = 0;
  double r_min = 0.0, r_max = 0.0;
  for (std::size_t i = 0; i < points.samples.size(); ++i) {
    const double r = points.samples[i].r_mm;
    r_min = i == 0 ? r : std::min(r_min, r);
    r_max = i == 0 ? r : std::max(r_max, r);
    if (!(r >= 0.0 && r <= probe_range_mm) && outside++ == 0) first = i;
  }
  if (outside == 0) return;
  throw Error(points.WhereIs(first) + ": r_mm " + Format("%.10g", points.samples[first].r_mm) +
              " lies outside the probe's measuring range, 0 to " + Format("%g", probe_range_mm) + " mm (" + range_from +
              "): " + std::to_string(outside) + " of " + std::to_string(points.samples.size()) +
              " readings do (they span " + Format("%.6g", r_min) + " to " + Format("%.6g", r_max) +
              " mm); a probe reads nothing beyond its range, so the range or the readings are not this probe's");
}

void CheckProbeOffsetMatches(const PointsData& points, double calibration_probe_offset_mm,
                             const std::string& calibration) {
  const auto d = points.header.probe_offset_mm;
  if (!d || std::abs(*d - calibration_probe_offset_mm) <= 1e-9 * calibration_probe_offset_mm) return;
  throw Error(points.source + ": probe_offset_mm " + Format("%.9g", *d) + " differs from the calibration's " +
              Format("%.9g", calibration_probe_offset_mm) + (calibration.empty() ? "" : " (" + calibration + ")") +
              ": the calibration belongs to another probe set-up");
}

std::optional<StatedSphereRadius> SphereRadiusOfSetup(const PointsHeader& header, int setup) {
  const auto other = header.sphere_radii_mm.find(setup);
  if (other != header.sphere_radii_mm.end()) return StatedSphereRadius{other->second, SphereRadiusKey(setup)};
  if (header.sphere_radius_mm) return StatedSphereRadius{*header.sphere_radius_mm, kRadiusKey};
  return std::nullopt;
}

}  // namespace sph
