// What a points file states about its set-up, checked against what uses it: the probe's measuring
// range against the readings, the probe offset against a calibration's, and the sphere a setup
// measured. The one place these are judged, for every program and host that reads points.
#ifndef SPH_IO_SETUP_CHECKS_HPP_
#define SPH_IO_SETUP_CHECKS_HPP_

#include <optional>
#include <string>

#include "sph/io/points_file.hpp"

namespace sph {

/// Throws sph::Error when readings of `points` lie outside the probe's measuring range, readings 0
/// to probe_range_mm (a probe reports nothing beyond its range: the range or the readings are not
/// this probe's). The message names the first such reading at its line, counts them and says where
/// the range was stated (`range_from`: "probe_range_mm", "--probe-range-mm").
void CheckReadingsInProbeRange(const PointsData& points, double probe_range_mm, const std::string& range_from);

/// Throws sph::Error when the header of `points` states a probe offset d (probe_offset_mm) other
/// than `calibration_probe_offset_mm` (beyond a relative 1e-9): the errors of a calibration refer
/// to its own d, and compensating readings of another probe set-up with them is meaningless.
/// `calibration` names the calibration in the message (a file; may be empty).
void CheckProbeOffsetMatches(const PointsData& points, double calibration_probe_offset_mm,
                             const std::string& calibration);

/// The radius the header states for the sphere measured in `setup`, and the key that states it.
struct StatedSphereRadius {
  double radius_mm = 0.0;
  std::string key;  ///< "sphere_radius_mm@2" for another sphere, else "sphere_radius_mm"
};

/// The sphere of `setup`: sphere_radius_mm@<setup> when the setup measured another sphere, else
/// the reference sphere's sphere_radius_mm; nothing when the header states neither.
std::optional<StatedSphereRadius> SphereRadiusOfSetup(const PointsHeader& header, int setup);

}  // namespace sph

#endif  // SPH_IO_SETUP_CHECKS_HPP_
