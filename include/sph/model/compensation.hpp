// Compensation: raw SCMS readings to coordinates in the sphere frame, with a calibration.
// Header-only, Eigen only, no exceptions: what instrument host software links.
//
//   p_sphere = ScmsPoint(g; theta, phi, r, d)          (sph/model/scms_model.hpp, the paper's Eq. (1))
//
// with g the seven geometric errors of the calibration and d its nominal probe zero distance. The
// readings come as the machine gives them: theta_deg, phi_deg [deg], r_mm [mm]; the result is in mm,
// in the frame that turns with Theta (the frame in which the measured sphere is at rest).
//
// Loading: the calibration file is JSON (format sph-calibration 1, sph/core/calibration_file.hpp).
// Its reader stays in sph::core, which has no Ceres either (sph::LoadCalibration() fills this
// struct): reading a file is a library-boundary job (it reports bad files by throwing sph::Error
// with the file and field), and one validated reader of the format is better than two. A host that
// cannot link sph::core fills Calibration from its own configuration store; the struct is plain data.
#ifndef SPH_MODEL_COMPENSATION_HPP_
#define SPH_MODEL_COMPENSATION_HPP_

#include <cmath>
#include <cstddef>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "sph/model/scms_model.hpp"
#include "sph/model/units.hpp"

namespace sph {

/// Covariance of the seven geometric errors, internal units (rad, mm), in ScmsParam order.
using ScmsCovariance = Eigen::Matrix<double, kNumScmsParams, kNumScmsParams>;

/// What compensation needs from a calibration, in internal units.
/// Class invariant for Compensate(): IsValid().
struct Calibration {
  ScmsGeometry geometry{};       ///< the seven errors (rad, mm), ScmsParam order
  double probe_offset_mm = 0.0;  ///< nominal probe zero distance d the errors refer to
  /// Covariance of the seven errors (rad, mm), when the calibration computed one; it lets a
  /// measurement state how much of its result the calibration's own uncertainty can explain.
  std::optional<ScmsCovariance> covariance;

  /// d positive and every value finite.
  bool IsValid() const {
    if (!(probe_offset_mm > 0.0) || !std::isfinite(probe_offset_mm)) return false;
    for (const double v : geometry) {
      if (!std::isfinite(v)) return false;
    }
    return !covariance || covariance->allFinite();
  }
};

/// One raw reading as the machine gives it.
struct RawReading {
  double theta_deg = 0.0;  ///< Theta axis reading [deg]
  double phi_deg = 0.0;    ///< Phi axis reading [deg]
  double r_mm = 0.0;       ///< probe reading [mm]
};

namespace internal {
/// Compensate() with the angle errors' trig given (ErrorTrigOf(cal.geometry)), for batches.
/// `Reading` has members theta_deg, phi_deg [deg] and r_mm [mm].
template <typename Reading>
Eigen::Vector3d CompensateWith(const Calibration& cal, const ScmsErrorTrig<double>& trig, const Reading& r) {
  return ScmsPoint(cal.geometry.data(), trig, SinCosOf(r.theta_deg * kRadPerDeg), SinCosOf(r.phi_deg * kRadPerDeg),
                   r.r_mm, cal.probe_offset_mm);
}
}  // namespace internal

/// The compensated point [mm] of one reading (theta_deg, phi_deg in deg, r_mm in mm).
inline Eigen::Vector3d Compensate(const Calibration& cal, double theta_deg, double phi_deg, double r_mm) {
  return ScmsPoint(cal.geometry, theta_deg * kRadPerDeg, phi_deg * kRadPerDeg, r_mm, cal.probe_offset_mm);
}

/// The compensated point [mm] of one reading.
inline Eigen::Vector3d Compensate(const Calibration& cal, const RawReading& reading) {
  return Compensate(cal, reading.theta_deg, reading.phi_deg, reading.r_mm);
}

/// Batch without allocation: points_mm[i] = Compensate(cal, readings[i]) for i < count.
inline void Compensate(const Calibration& cal, const RawReading* readings, std::size_t count,
                       Eigen::Vector3d* points_mm) {
  const ScmsErrorTrig<double> trig = ErrorTrigOf(cal.geometry.data());  // once for the batch
  for (std::size_t i = 0; i < count; ++i) points_mm[i] = internal::CompensateWith(cal, trig, readings[i]);
}

/// Batch over any container of readings with members theta_deg, phi_deg and r_mm (RawReading,
/// sph::Sample of a points file, ...); the points [mm] in the same order.
template <typename Readings>
std::vector<Eigen::Vector3d> CompensateAll(const Calibration& cal, const Readings& readings) {
  std::vector<Eigen::Vector3d> points_mm;
  points_mm.reserve(readings.size());
  const ScmsErrorTrig<double> trig = ErrorTrigOf(cal.geometry.data());  // once for the batch
  for (const auto& r : readings) points_mm.push_back(internal::CompensateWith(cal, trig, r));
  return points_mm;
}

}  // namespace sph

#endif  // SPH_MODEL_COMPENSATION_HPP_
