#include "sph/calib/misreading.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph {

using internal::Format;

std::string Misreading::Reason() const {
  return "likely cause: " + what + " (with " + taken_as + ", the readings fit the seven errors with rms " +
         Format("%.4g", rms_um) + " um and d' = " + Format("%.4g", d_prime_mm) + " mm, against " +
         Format("%.4g", given_rms_um) + " um as given): sph takes " + convention;
}

bool FitsAsAMisreading(const PointsData& points, const CalibrationOptions& options, const CalibrationResult& fit) {
  if (!fit.converged) return true;
  double radius_mm = options.sphere_radius_mm;
  for (const auto& [setup, other_mm] : points.header.sphere_radii_mm) radius_mm = std::min(radius_mm, other_mm);
  if (!(std::abs(fit.geometry[kDPrime]) <= 0.1 * radius_mm)) return true;
  for (int p = 0; p < kNumScmsParams; ++p) {
    const double value = fit.geometry[static_cast<std::size_t>(p)] * ReportUnitsOf(p).to_coarse;
    if (!(std::abs(value) <= kScmsParamInfo[static_cast<std::size_t>(p)].max_abs_report)) return true;
  }
  return false;
}

std::optional<Misreading> LikelyMisreading(const PointsData& points, const CalibrationOptions& options,
                                           const CalibrationResult& as_given) {
  if (points.samples.empty() || !FitsAsAMisreading(points, options, as_given)) return std::nullopt;
  std::vector<double> r;
  r.reserve(points.samples.size());
  for (const Sample& s : points.samples) r.push_back(s.r_mm);
  std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
  const double median_mm = r[r.size() / 2];
  struct Way {
    const char* what;
    std::string taken_as;
    const char* convention;
    std::function<void(Sample&)> take;
  };
  const std::vector<Way> ways = {
      {"the probe's reading runs the other way",
       "r taken as 2 x median(r) - r = " + Format("%.6g", 2 * median_mm) + " - r",
       "r growing towards the axes' common point (a reading that grows as the surface moves away from the probe)",
       [&](Sample& s) { s.r_mm = 2.0 * median_mm - s.r_mm; }},
      {"the probe's readings are in um, not mm", "r taken as r / 1000", "r in mm", [](Sample& s) { s.r_mm *= 1e-3; }},
      {"Theta is read in the other sense", "theta taken as -theta",
       "a positive theta as turning the probe about +z relative to the sphere (the sphere about -z)",
       [](Sample& s) { s.theta_deg = -s.theta_deg; }},
      {"Phi is read in the other sense", "phi taken as -phi", "a positive phi as turning the probe about +y",
       [](Sample& s) { s.phi_deg = -s.phi_deg; }},
  };
  std::optional<Misreading> best;
  for (const Way& way : ways) {
    PointsData taken = points;
    for (Sample& s : taken.samples) way.take(s);
    CalibrationResult fit;
    try {
      fit = Calibrate(taken, options);
    } catch (const Error&) {
      continue;
    }
    if (FitsAsAMisreading(taken, options, fit) || !(fit.rms_um <= 0.2 * as_given.rms_um)) continue;
    if (best && best->rms_um <= fit.rms_um) continue;
    best = Misreading{way.what, way.taken_as, way.convention, fit.rms_um, fit.geometry[kDPrime], as_given.rms_um};
  }
  return best;
}

}  // namespace sph
