// Compensation: raw SCMS readings to coordinates in the sphere frame, with a calibration.
// Header-only, Eigen only, no exceptions: what instrument host software links.
//
//   p_sphere = ScmsPoint(g; theta, phi, r, d)          (sph/model/scms_model.hpp, the paper's Eq. (1))
//
// or, when the calibration has further effects of the machine (encoder errors, spindle motions,
// probe gain, ...), EffectScmsPoint(g, effects; reading) of sph/model/effects.hpp. A probe drift
// belongs to the run it was measured in and is never part of a calibration.
//
// with g the seven geometric errors of the calibration and d its nominal probe zero distance. The
// readings come as the machine gives them: theta_deg, phi_deg [deg], r_mm [mm]; the result is in mm,
// in the frame that turns with Theta (the frame in which the measured sphere is at rest).
//
// Loading: the calibration file is JSON (format sph-calibration 1, sph/io/calibration_file.hpp).
// Its reader stays in sph::core, which has no Ceres either (sph::LoadCalibration() fills this
// struct): reading a file is a library-boundary job (it reports bad files by throwing sph::Error
// with the file and field), and one validated reader of the format is better than two. A host that
// cannot link sph::core fills Calibration from its own configuration store (the struct is plain data,
// held without the heap), or reads the calibration's firmware blob (sph/model/calibration_blob.hpp;
// from C: sph/c/compensation.h). What Compensate() applies and what not: docs/library.md.
#ifndef SPH_MODEL_COMPENSATION_HPP_
#define SPH_MODEL_COMPENSATION_HPP_

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "sph/model/effects.hpp"
#include "sph/model/fixed_vector.hpp"
#include "sph/model/reading.hpp"
#include "sph/model/scms_model.hpp"
#include "sph/model/units.hpp"

namespace sph {

/// The smallest half range of the probe that probe terms may be normalised by [mm] (1 um): below
/// it u = (r - r_ref) / r_half would blow rounding up into the correction.
inline constexpr double kMinProbeHalfRangeMm = 1e-3;

/// Covariance of the seven geometric errors, internal units (rad, mm), in ScmsParam order.
using ScmsCovariance = Eigen::Matrix<double, kNumScmsParams, kNumScmsParams>;

/// The parameter blocks of a calibration's effects, one per term, held without the heap.
template <typename T>
using EffectValues = FixedVector<FixedVector<T, kMaxTermComponents>, kNumEffects>;

/// What compensation needs from a calibration, in internal units. Plain data held without the heap
/// (a few kB, bounded by the effect catalogue), so that firmware can hold one. T: the scalar of
/// the seven errors and the effects' values (double; float for firmware without double hardware).
/// Class invariant for Compensate(): IsValid().
template <typename T>
struct BasicCalibration {
  std::array<T, kNumScmsParams> geometry{};  ///< the seven errors (rad, mm), ScmsParam order
  T probe_offset_mm = T(0.0);                ///< nominal probe zero distance d the errors refer to
  /// Covariance of the seven errors (rad, mm), when the calibration computed one; it lets a
  /// measurement state how much of its result the calibration's own uncertainty can explain.
  std::optional<ScmsCovariance> covariance;
  /// Further effects of the machine (no probe_drift) and their values, one block per term (rad, mm).
  EffectTerms effects;
  EffectValues<T> effect_values;

  /// d positive, every value finite, at most one term per effect, no probe_drift, one block of the
  /// right size per term and a positive normalisation.
  bool IsValid() const {
    using std::isfinite;
    if (!(probe_offset_mm > T(0.0)) || !isfinite(probe_offset_mm)) return false;
    for (const T v : geometry) {
      if (!isfinite(v)) return false;
    }
    if (effects.terms.size() > static_cast<std::size_t>(kNumEffects) || effect_values.size() != effects.terms.size()) {
      return false;
    }
    for (std::size_t t = 0; t < effects.terms.size(); ++t) {
      const EffectTerm& term = effects.terms[t];
      if (term.effect == Effect::kProbeDrift || effects.Find(term.effect) != static_cast<int>(t)) return false;
      if (effect_values[t].size() != term.components.size()) return false;
      for (const T v : effect_values[t]) {
        if (!isfinite(v)) return false;
      }
    }
    const EffectReference& ref = effects.reference;
    if (!effects.Empty() && !(ref.r_half_range_mm >= kMinProbeHalfRangeMm && isfinite(ref.r_half_range_mm) &&
                              isfinite(ref.r_ref_mm) && ref.t_span_s > 0.0 && isfinite(ref.t_span_s))) {
      return false;
    }
    return !covariance || covariance->allFinite();
  }
};

/// The calibration of the host: double throughout.
using Calibration = BasicCalibration<double>;

/// `cal` with its seven errors, d and the effects' values rounded to the scalar T (float, for a
/// target whose floating-point unit has single precision only); the rest as it is.
template <typename T, typename S>
BasicCalibration<T> CalibrationOf(const BasicCalibration<S>& cal) {
  BasicCalibration<T> out;
  for (std::size_t i = 0; i < cal.geometry.size(); ++i) out.geometry[i] = T(cal.geometry[i]);
  out.probe_offset_mm = T(cal.probe_offset_mm);
  out.covariance = cal.covariance;
  out.effects = cal.effects;
  for (const auto& block : cal.effect_values) {
    out.effect_values.emplace_back();
    for (const S v : block) out.effect_values.back().push_back(T(v));
  }
  return out;
}

namespace internal {
/// What compensation computes once per calibration: the angle errors' trig and the effects'
/// parameter blocks (no allocation: at most one term per effect).
template <typename T>
struct BasicCompensationContext {
  ScmsErrorTrig<T> trig;
  std::array<const T*, kNumEffects> blocks{};
  bool valid;  ///< cal.IsValid(): otherwise every point is NaN (no exceptions here)

  explicit BasicCompensationContext(const BasicCalibration<T>& cal)
      : BasicCompensationContext(cal, ErrorTrigOf(cal.geometry.data()), cal.IsValid()) {}
  /// With the trig of cal's angle errors and cal.IsValid() known (for single readings of a
  /// calibration that was checked once).
  BasicCompensationContext(const BasicCalibration<T>& cal, const ScmsErrorTrig<T>& known_trig, bool is_valid)
      : trig(known_trig), valid(is_valid) {
    for (std::size_t t = 0; valid && t < cal.effect_values.size(); ++t) blocks[t] = cal.effect_values[t].data();
  }
};
using CompensationContext = BasicCompensationContext<double>;

/// Compensate() with the context given, of a reading whose sines and cosines are computed (for
/// readings compensated many times, as by the calibration's uncertainty). center_mm: the measured
/// sphere's centre, for a probe_incidence term (left out without it).
template <typename T>
Vec3<T> CompensateWith(const BasicCalibration<T>& cal, const BasicCompensationContext<T>& ctx,
                       const BasicEffectReading<T>& x, const typename NonDeduced<T>::type* center_mm = nullptr) {
  if (!ctx.valid) return Vec3<T>::Constant(std::numeric_limits<T>::quiet_NaN());
  if (cal.effects.Empty()) {
    return ScmsPoint(cal.geometry.data(), ctx.trig, x.theta, x.phi, x.r_mm, cal.probe_offset_mm);
  }
  return EffectScmsPoint(cal.geometry.data(), ctx.trig, cal.effects, ctx.blocks.data(), x,
                         static_cast<double>(cal.probe_offset_mm), nullptr, center_mm);
}

/// Compensate() with the context given, for batches. `Reading` has members theta_deg, phi_deg
/// [deg] and r_mm [mm].
template <typename T, typename Reading>
Vec3<T> CompensateWith(const BasicCalibration<T>& cal, const BasicCompensationContext<T>& ctx, const Reading& r,
                       const typename NonDeduced<T>::type* center_mm = nullptr) {
  return CompensateWith(cal, ctx, BasicEffectReading<T>(T(r.theta_deg), T(r.phi_deg), T(r.r_mm), T(0.0)), center_mm);
}
}  // namespace internal

/// How many of `readings` (members r_mm) a probe term of `cal` (probe_gain, probe_nonlinearity)
/// would extrapolate: their r lies outside the probe readings the calibration was fitted over
/// (EffectReference::FitMin() to FitMax()). 0 when the calibration has no probe term.
template <typename Readings>
std::size_t ProbeExtrapolations(const Calibration& cal, const Readings& readings) {
  if (cal.effects.Find(Effect::kProbeGain) < 0 && cal.effects.Find(Effect::kProbeNonlinearity) < 0) return 0;
  const double lo = cal.effects.reference.FitMin(), hi = cal.effects.reference.FitMax();
  std::size_t n = 0;
  for (const auto& r : readings) n += r.r_mm < lo || r.r_mm > hi ? 1 : 0;
  return n;
}

/// The compensated point [mm] of one reading (theta_deg, phi_deg in deg, r_mm in mm).
inline Eigen::Vector3d Compensate(const Calibration& cal, double theta_deg, double phi_deg, double r_mm) {
  return internal::CompensateWith(cal, internal::CompensationContext(cal), RawReading{theta_deg, phi_deg, r_mm});
}

/// The same in the scalar of `cal` (float: a calibration of CalibrationOf<float>()).
template <typename T>
Vec3<T> Compensate(const BasicCalibration<T>& cal, T theta_deg, T phi_deg, T r_mm) {
  return internal::CompensateWith(cal, internal::BasicCompensationContext<T>(cal),
                                  BasicEffectReading<T>(theta_deg, phi_deg, r_mm, T(0.0)));
}

/// The compensated point [mm] of one reading.
inline Eigen::Vector3d Compensate(const Calibration& cal, const RawReading& reading) {
  return Compensate(cal, reading.theta_deg, reading.phi_deg, reading.r_mm);
}

/// Batch without allocation: points_mm[i] = Compensate(cal, readings[i]) for i < count.
inline void Compensate(const Calibration& cal, const RawReading* readings, std::size_t count,
                       Eigen::Vector3d* points_mm) {
  const internal::CompensationContext ctx(cal);  // once for the batch
  for (std::size_t i = 0; i < count; ++i) points_mm[i] = internal::CompensateWith(cal, ctx, readings[i]);
}

/// Batch over any container of readings with members theta_deg, phi_deg and r_mm (RawReading,
/// sph::Sample of a points file, ...); the points [mm] in the same order.
template <typename Readings>
std::vector<Eigen::Vector3d> CompensateAll(const Calibration& cal, const Readings& readings) {
  std::vector<Eigen::Vector3d> points_mm;
  points_mm.reserve(readings.size());
  const internal::CompensationContext ctx(cal);  // once for the batch
  for (const auto& r : readings) points_mm.push_back(internal::CompensateWith(cal, ctx, r));
  return points_mm;
}

/// CompensateAll() of the readings of one sphere whose centre is about `center_mm` [mm] (the
/// least-squares centre of CompensateAll()'s points, say): what a calibration with a
/// probe_incidence term needs, the angle between the beam and the sphere's normal. An error of
/// the centre by delta changes sin^2 psi by about 2 sin(psi) delta / R: iterate once more when
/// that matters.
template <typename Readings>
std::vector<Eigen::Vector3d> CompensateAll(const Calibration& cal, const Readings& readings,
                                           const Eigen::Vector3d& center_mm) {
  std::vector<Eigen::Vector3d> points_mm;
  points_mm.reserve(readings.size());
  const internal::CompensationContext ctx(cal);
  for (const auto& r : readings) points_mm.push_back(internal::CompensateWith(cal, ctx, r, center_mm.data()));
  return points_mm;
}

}  // namespace sph

#endif  // SPH_MODEL_COMPENSATION_HPP_
