// The effects a real SCMS shows beyond the seven geometric errors: what each one is, its
// components and their names. The forward model that applies them is sph/model/effects.hpp.
//
// Each effect is a term with its own parameter block. Its components are harmonics of a reading
// (cos k x, sin k x) or powers of a normalised reading; which components a term has is data, so
// that a term can leave out what a measurement cannot determine (EffectTerm::components).
//
//   theta_encoder        theta_true = theta_read + sum_k c_k cos(k theta) + s_k sin(k theta)      [rad]
//   phi_encoder          phi_true   = phi_read   + sum_k c_k cos(k phi)   + s_k sin(k phi)        [rad]
//   theta_radial_motion  the Theta spindle, and the sphere with it, is displaced in the machine frame
//                        by (dx, dy)(theta) = sum_k (x_ck cos k theta + x_sk sin k theta, y_..)  [mm]
//   theta_axial_motion   the same along the Theta axis: dz(theta) = sum_k c_k cos k theta + ..    [mm]
//   theta_tilt_motion    the Theta spindle, and the sphere with it, tilts by (tx, ty)(theta) about
//                        the machine x and y axes through the axes' common point: a point fixed to
//                        the sphere at machine position q goes to Rx(tx) Ry(ty) q            [rad]
//   phi_wobble           the Phi axis tilts by (wx, wy)(phi) = sum_k harmonics of phi about the x and
//                        y axes of its frame, pivoting at the point L along the axis (the bearing;
//                        EffectModel::phi_wobble_pivot_mm, from the machine's drawing):
//                        s -> L e_z + Rx(wx) Ry(wy) (s - L e_z), a shift of L (-wy, wx) at first order [rad]
//   phi_radial_motion    the Phi axis, and the probe with it, is displaced across the axis in the Phi
//                        frame by (dx, dy)(phi) = sum_k harmonics of phi                       [mm]
//   phi_axial_motion     the same along the Phi axis: dz(phi)                                    [mm]
//   probe_gain           r_true = r_read + k1 u,               u = (r_read - r_ref) / r_half      [mm]
//   probe_nonlinearity   r_true = r_read + q2 u^2 + q3 u^3                                        [mm]
//   probe_drift          r_true = r_read + v1 tau (+ v2 tau^2), tau = (t - t_start) / t_span       [mm]
//   probe_incidence      r_true = r_read + i1 sin^2 psi (+ i2 sin^4 psi), psi the angle between the probe's
//                        beam and the normal of the reference sphere where the beam meets it: optical
//                        and capacitive probes read differently on a tilted surface. On an eccentric
//                        sphere psi changes along the scan (sin psi up to about e / R0). psi is taken
//                        at the point of the reading without the probe's terms and with the fitted
//                        centre: it is a function of the fitted state, not of the reading alone, so
//                        EffectScmsPoint() needs the sphere's centre for it. i1, i2: the reading
//                        error at psi = 90 deg, a constant of the probe at any eccentricity      [mm]
//   theta_reversal       theta_true = theta_read + b dir_theta / 2, dir the direction in which the axis
//                        approached the reading (+1 positive, -1 negative; MotionDirection): b is the
//                        reversal value of ISO 230-2, the mean position approached in the positive
//                        direction less that approached in the negative one (a drive whose load lags
//                        behind its encoder by a lost motion l has b = -l). One value, not an offset
//                        per direction: their mean is the axis' zero, which the sphere's centre
//                        (Theta) or the seven errors (Phi) already hold                           [rad]
//   phi_reversal         phi_true = phi_read + b dir_phi / 2, the same of the Phi axis               [rad]
//
// The once-per-turn part of a radial motion is not an error motion (ISO 230-7) but a parameter of
// the set-up: of the Theta spindle's, one combination is the sphere's centre itself; of the Phi
// axis', the probe line's offset c and zero d'. One combination of the once-per-turn tilt of the
// Theta spindle turns the sphere about the axes' common point, which only moves its centre. So
// these terms start at k = 2 (EffectInfo::first_order).
//
// The probe terms are expressed as the displacement they cause at the end of the range (u = 1)
// or of the run (tau = 1), so that every parameter is an angle (rad) or a length (mm) and can be
// judged as a displacement of the probed point like the seven errors (angles times R0). r_ref,
// r_half, t_start and t_span come from the calibration data (EffectReferenceOf) and are stored
// with the calibration, so that the terms mean the same when they are applied to other data.
//
// Header-only, Eigen only.
#ifndef SPH_MODEL_EFFECT_TERMS_HPP_
#define SPH_MODEL_EFFECT_TERMS_HPP_

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "sph/model/fixed_vector.hpp"
#include "sph/model/scms_model.hpp"

namespace sph {

/// The effects of the library, in the order of kEffectInfo.
enum class Effect : int {
  kThetaEncoder = 0,
  kPhiEncoder,
  kThetaRadialMotion,
  kThetaAxialMotion,
  kPhiWobble,
  kProbeGain,
  kProbeNonlinearity,
  kProbeDrift,
  kPhiRadialMotion,
  kPhiAxialMotion,
  kThetaTiltMotion,
  kProbeIncidence,
  kThetaReversal,
  kPhiReversal,
};
inline constexpr int kNumEffects = 14;

/// Static description of an effect.
struct EffectInfo {
  const char* id;           ///< identifier in options, files and reports
  const char* description;  ///< the physics, one line
  Quantity quantity;        ///< of every parameter: kAngle (rad) or kLength (mm)
  /// the reading its terms are functions of: theta, phi, r or t; psi for probe_incidence, the
  /// angle between the beam and the surface's normal (a function of the fitted state too); for a
  /// reversal term the axis it shifts (its basis is the direction of approach, not the angle)
  const char* variable;
  int axes;       ///< 2 for effects with x and y components, else 1
  bool harmonic;  ///< components are harmonics (else powers)
  /// The name of ISO 230-1 / ISO 230-7 for it, with the Theta axis as the C axis (about machine z)
  /// and the Phi axis as the B axis (about machine y; the Phi frame's x, y, z are machine x, z,
  /// -y); "" where ISO 230 has none (the probe's own errors).
  const char* iso_name;
  /// Lowest harmonic order of its components (1, or 2 where the once-per-turn part is another
  /// parameter: see DefaultTerm()).
  int first_order;
};

inline constexpr std::array<EffectInfo, kNumEffects> kEffectInfo{{
    {"theta_encoder", "angular positioning error of the Theta axis (harmonics of theta)", Quantity::kAngle, "theta", 1,
     true, "ECC (angular positioning error of C)", 1},
    {"phi_encoder", "angular positioning error of the Phi axis (harmonics of phi)", Quantity::kAngle, "phi", 1, true,
     "EBB (angular positioning error of B)", 1},
    {"theta_radial_motion", "synchronous radial error motion of the Theta spindle, fixed in the machine frame",
     Quantity::kLength, "theta", 2, true, "EXC, EYC (radial error motion of C)", 2},
    {"theta_axial_motion", "synchronous axial error motion of the Theta spindle", Quantity::kLength, "theta", 1, true,
     "EZC (axial error motion of C)", 1},
    {"phi_wobble", "tilt error motion of the Phi axis (harmonics of phi), about a pivot on the axis", Quantity::kAngle,
     "phi", 2, true, "EAB, ECB (tilt error motion of B)", 1},
    {"probe_gain", "scale error of the probe reading r", Quantity::kLength, "r", 1, false, "", 1},
    {"probe_nonlinearity", "quadratic and cubic error of the probe over its range", Quantity::kLength, "r", 1, false,
     "", 2},
    {"probe_drift", "offset of the probe drifting with acquisition time", Quantity::kLength, "t", 1, false, "", 1},
    {"phi_radial_motion", "synchronous radial error motion of the Phi axis, fixed in the Phi axis frame",
     Quantity::kLength, "phi", 2, true, "EXB, EZB (radial error motion of B)", 2},
    {"phi_axial_motion", "synchronous axial error motion of the Phi axis", Quantity::kLength, "phi", 1, true,
     "EYB (axial error motion of B)", 1},
    {"theta_tilt_motion", "tilt error motion of the Theta spindle about the machine x and y axes", Quantity::kAngle,
     "theta", 2, true, "EAC, EBC (tilt error motion of C)", 2},
    {"probe_incidence", "reading error of the probe against the angle between its beam and the surface normal",
     Quantity::kLength, "psi", 1, false, "", 1},
    {"theta_reversal",
     "reversal value of the Theta axis: half of it added for a positive approach, taken off for a "
     "negative one",
     Quantity::kAngle, "theta", 1, false, "B of C (reversal value, ISO 230-2)", 1},
    {"phi_reversal",
     "reversal value of the Phi axis: half of it added for a positive approach, taken off for a "
     "negative one",
     Quantity::kAngle, "phi", 1, false, "B of B (reversal value, ISO 230-2)", 1},
}};

/// Whether `e` is a reversal term (its basis: half the direction of approach of its axis).
inline bool IsReversal(Effect e) { return e == Effect::kThetaReversal || e == Effect::kPhiReversal; }

inline const EffectInfo& InfoOf(Effect e) { return kEffectInfo[static_cast<std::size_t>(e)]; }

/// Whether `e` is an error of the machine's axes (a harmonic term or a reversal), not of the probe
/// or of time.
inline bool IsAxisError(Effect e) { return InfoOf(e).harmonic || IsReversal(e); }

/// The effect with identifier `id`, or false.
inline bool EffectFromId(const std::string& id, Effect* out) {
  for (int i = 0; i < kNumEffects; ++i) {
    if (id == kEffectInfo[static_cast<std::size_t>(i)].id) {
      *out = static_cast<Effect>(i);
      return true;
    }
  }
  return false;
}

/// One component of a term: a harmonic order k (cos or sin) of one axis, or a power.
struct EffectComponent {
  int order = 1;      ///< harmonic order k, or the power of u or tau
  int axis = 0;       ///< 0, or 1 for the y component of a two-axis effect
  bool sine = false;  ///< sin(k x) rather than cos(k x); false for powers
};

/// Highest harmonic order and highest power of time that parameter names may carry.
inline constexpr int kMaxEffectHarmonic = 12;
/// The most components a term can have: the harmonics of orders 1 to kMaxEffectHarmonic, cos and
/// sin, of both axes of a two-axis effect (phi_wobble). A term's components are distinct, so the
/// catalogue bounds them; the other bounds hold with room (3 powers of time, 2 of incidence).
inline constexpr std::size_t kMaxTermComponents = 2 * 2 * kMaxEffectHarmonic;

/// The components of one term, held without the heap.
using EffectComponents = FixedVector<EffectComponent, kMaxTermComponents>;

/// An effect in a model, with the components it has; its parameter block holds one value per
/// component, in this order (rad or mm, EffectInfo::quantity).
struct EffectTerm {
  Effect effect = Effect::kThetaEncoder;
  EffectComponents components;

  int size() const { return static_cast<int>(components.size()); }
  const EffectInfo& info() const { return InfoOf(effect); }

  /// Name of parameter i: "theta_encoder.c2", "theta_radial_motion.y_s3", "probe_drift.t1", ...;
  /// "theta_reversal.b" (the reversal value B of ISO 230-2).
  std::string ParamName(std::size_t i) const {
    const EffectComponent& c = components[i];
    std::string s = std::string(info().id) + ".";
    if (IsReversal(effect)) return s + "b";
    if (info().axes == 2) s += c.axis == 0 ? "x_" : "y_";
    if (info().harmonic) {
      s += c.sine ? "s" : "c";
    } else {
      s += effect == Effect::kProbeDrift ? "t" : effect == Effect::kProbeIncidence ? "i" : "u";
    }
    return s + std::to_string(c.order);
  }
};

/// The highest harmonic order of the harmonic effects of each axis: of theta for theta_encoder,
/// the Theta spindle's motions; of phi for phi_encoder, phi_wobble and the Phi axis' motions.
struct HarmonicOrders {
  int theta = 4;
  int phi = 4;
  /// The highest order of an effect whose terms are functions of `info.variable`.
  int Of(const EffectInfo& info) const { return std::string_view(info.variable) == "phi" ? phi : theta; }
};

/// The default term of an effect: harmonics k = EffectInfo::first_order..the highest order of its
/// axis (the first order 2 for the radial motions and the Theta tilt, see the file comment), cos
/// and sin, every axis; probe_gain u^1; probe_nonlinearity u^2 and u^3; probe_incidence sin^2 psi
/// (i1); a reversal term its value b; probe_drift tau^1..tau^drift_order.
inline EffectTerm DefaultTerm(Effect e, HarmonicOrders harmonics, int drift_order = 1) {
  EffectTerm t;
  t.effect = e;
  const EffectInfo& info = InfoOf(e);
  if (info.harmonic) {
    const int highest = harmonics.Of(info);
    for (int axis = 0; axis < info.axes; ++axis) {
      for (int k = info.first_order; k <= highest; ++k) {
        t.components.push_back({k, axis, false});
        t.components.push_back({k, axis, true});
      }
    }
  } else if (e == Effect::kProbeGain) {
    t.components.push_back({1, 0, false});
  } else if (e == Effect::kProbeNonlinearity) {
    t.components.push_back({2, 0, false});
    t.components.push_back({3, 0, false});
  } else if (e == Effect::kProbeIncidence || IsReversal(e)) {
    t.components.push_back({1, 0, false});
  } else {
    for (int k = 1; k <= drift_order; ++k) t.components.push_back({k, 0, false});
  }
  return t;
}

/// DefaultTerm() with the same highest harmonic order on both axes.
inline EffectTerm DefaultTerm(Effect e, int harmonics = 4, int drift_order = 1) {
  return DefaultTerm(e, HarmonicOrders{harmonics, harmonics}, drift_order);
}

/// The largest magnitude files and options accept for one parameter of an effect: 3600 arcsec
/// (1 deg) for an angle, 1000 um for a length. Larger is not an error of a working machine.
inline constexpr double kMaxEffectArcsec = 3600.0;
inline constexpr double kMaxEffectUm = 1000.0;
inline constexpr int kMaxDriftOrder = 3;
/// Highest power of sin^2 psi of probe_incidence (i1 sin^2 psi + i2 sin^4 psi).
inline constexpr int kMaxIncidenceOrder = 2;
/// The largest distance from the Phi frame's origin to the pivot of its tilt that files and
/// options accept [mm] (EffectModel::phi_wobble_pivot_mm), the bound of the probe offset d.
inline constexpr double kMaxPivotMm = 10000.0;

/// The component of effect `e` whose parameter is called `name` ("theta_encoder.c2", ...), or false.
inline bool FindComponent(Effect e, const std::string& name, EffectComponent* out) {
  EffectTerm all = DefaultTerm(e, kMaxEffectHarmonic, kMaxDriftOrder);
  if (e == Effect::kProbeIncidence) {
    for (int k = 2; k <= kMaxIncidenceOrder; ++k) all.components.push_back({k, 0, false});
  }
  for (std::size_t i = 0; i < all.components.size(); ++i) {
    if (all.ParamName(i) == name) {
      *out = all.components[i];
      return true;
    }
  }
  return false;
}

/// What the probe and drift terms are normalised by (see the file comment).
struct EffectReference {
  double r_ref_mm = 0.0;         ///< centre of the probe range
  double r_half_range_mm = 1.0;  ///< half the probe range (> 0)
  double t_start_s = 0.0;        ///< start of the run
  double t_span_s = 1.0;         ///< length of the run (> 0)
  /// The probe readings the calibration's data spanned [mm]: outside them a probe polynomial is
  /// extrapolated. NaN: r_ref -+ r_half.
  double r_fit_min_mm = std::numeric_limits<double>::quiet_NaN();
  double r_fit_max_mm = std::numeric_limits<double>::quiet_NaN();

  double FitMin() const { return std::isnan(r_fit_min_mm) ? r_ref_mm - r_half_range_mm : r_fit_min_mm; }
  double FitMax() const { return std::isnan(r_fit_max_mm) ? r_ref_mm + r_half_range_mm : r_fit_max_mm; }
};

/// `ref` with the probe terms expressed at the ends of the probe's own measuring range, readings
/// 0 to range_mm: u = (r - range / 2) / (range / 2), so that u1 is the error at the range's end,
/// a constant of the probe, whatever part of the range a measurement used. The fit range stays.
inline EffectReference WithProbeRange(EffectReference ref, double range_mm) {
  ref.r_ref_mm = 0.5 * range_mm;
  ref.r_half_range_mm = 0.5 * range_mm;
  return ref;
}

/// The reference of a set of readings (members r_mm and t_s): mid-range and half range of r,
/// start and length of the run, and the readings' span. Ranges of zero length are replaced by 1
/// so that u and tau exist.
template <typename Readings>
EffectReference EffectReferenceOf(const Readings& readings) {
  EffectReference ref;
  if (readings.empty()) return ref;
  double r_lo = std::numeric_limits<double>::infinity(), r_hi = -r_lo, t_lo = r_lo, t_hi = -r_lo;
  for (const auto& s : readings) {
    r_lo = std::min(r_lo, s.r_mm);
    r_hi = std::max(r_hi, s.r_mm);
    t_lo = std::min(t_lo, s.t_s);
    t_hi = std::max(t_hi, s.t_s);
  }
  ref.r_ref_mm = 0.5 * (r_lo + r_hi);
  ref.r_half_range_mm = r_hi > r_lo ? 0.5 * (r_hi - r_lo) : 1.0;
  ref.t_start_s = t_lo;
  ref.t_span_s = t_hi > t_lo ? t_hi - t_lo : 1.0;
  ref.r_fit_min_mm = r_lo;
  ref.r_fit_max_mm = r_hi;
  return ref;
}

}  // namespace sph

#endif  // SPH_MODEL_EFFECT_TERMS_HPP_
