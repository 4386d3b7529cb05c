// Effects beyond the seven geometric errors: the library of physical effects a real SCMS shows
// and the forward model that includes them.
//
// Each effect is a term with its own parameter block. Its components are harmonics of a reading
// (cos k x, sin k x) or powers of a normalised reading; which components a term has is data, so
// that a term can leave out what a measurement cannot determine (EffectTerm::components).
//
//   theta_encoder        theta_true = theta_read + sum_k c_k cos(k theta) + s_k sin(k theta)      [rad]
//   phi_encoder          phi_true   = phi_read   + sum_k c_k cos(k phi)   + s_k sin(k phi)        [rad]
//   theta_radial_motion  the Theta spindle, and the sphere with it, is displaced in the machine frame
//                        by (dx, dy)(theta) = sum_k (x_ck cos k theta + x_sk sin k theta, y_..)  [mm]
//                        k >= 2 by default: the once-per-turn part is the sphere's centring, not an
//                        error motion (ISO 230-7), and one of its two combinations is the centre itself.
//   theta_axial_motion   the same along the Theta axis: dz(theta) = sum_k c_k cos k theta + ..    [mm]
//   phi_wobble           the Phi axis tilts by (wx, wy)(phi) = sum_k harmonics of phi about the x and
//                        y axes of its frame: s -> Rx(wx) Ry(wy) s                                [rad]
//   probe_gain           r_true = r_read + k1 u,               u = (r_read - r_ref) / r_half      [mm]
//   probe_nonlinearity   r_true = r_read + q2 u^2 + q3 u^3                                        [mm]
//   probe_drift          r_true = r_read + v1 tau (+ v2 tau^2), tau = (t - t_start) / t_span       [mm]
//
// The probe terms are expressed as the displacement they cause at the end of the range (u = 1)
// or of the run (tau = 1), so that every parameter is an angle (rad) or a length (mm) and can be
// judged as a displacement of the probed point like the seven errors (angles times R0). r_ref,
// r_half, t_start and t_span come from the calibration data (EffectReferenceOf) and are stored
// with the calibration, so that the terms mean the same when they are applied to other data.
//
// The chain (sph/model/scms_model.hpp, stages of Eq. (1)) with the effects in their places:
//   s = Rz(-phi_true) DH(beta, b, c, pi/2 + eps) [0, 0, r_true - (d + d')]   (ProbeToPhiFrame)
//   s = Rx(wx) Ry(wy) s                                                       (phi_wobble)
//   m = Tx(a) Rx(pi/2 + alpha) s - (dx, dy, dz)                              (PhiFrameToMachine, spindle motion)
//   p = Rz(theta_true) m                                                      (MachineToSphere)
// With no terms EffectScmsPoint() equals ScmsPoint() bit for bit. Header-only, Eigen only,
// templated on the scalar (double, ceres::Jet).
#ifndef SPH_MODEL_EFFECTS_HPP_
#define SPH_MODEL_EFFECTS_HPP_

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "sph/model/form_model.hpp"
#include "sph/model/scms_model.hpp"
#include "sph/model/units.hpp"

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
};
inline constexpr int kNumEffects = 8;

/// Static description of an effect.
struct EffectInfo {
  const char* id;           ///< identifier in options, files and reports
  const char* description;  ///< the physics, one line
  Quantity quantity;        ///< of every parameter: kAngle (rad) or kLength (mm)
  const char* variable;     ///< the reading its terms are functions of: theta, phi, r or t
  int axes;                 ///< 2 for effects with x and y components, else 1
  bool harmonic;            ///< components are harmonics (else powers)
};

inline constexpr std::array<EffectInfo, kNumEffects> kEffectInfo{{
    {"theta_encoder", "angular positioning error of the Theta axis (harmonics of theta)", Quantity::kAngle, "theta", 1,
     true},
    {"phi_encoder", "angular positioning error of the Phi axis (harmonics of phi)", Quantity::kAngle, "phi", 1, true},
    {"theta_radial_motion", "synchronous radial error motion of the Theta spindle, fixed in the machine frame",
     Quantity::kLength, "theta", 2, true},
    {"theta_axial_motion", "synchronous axial error motion of the Theta spindle", Quantity::kLength, "theta", 1, true},
    {"phi_wobble", "tilt error motion of the Phi axis (harmonics of phi)", Quantity::kAngle, "phi", 2, true},
    {"probe_gain", "scale error of the probe reading r", Quantity::kLength, "r", 1, false},
    {"probe_nonlinearity", "quadratic and cubic error of the probe over its range", Quantity::kLength, "r", 1, false},
    {"probe_drift", "offset of the probe drifting with acquisition time", Quantity::kLength, "t", 1, false},
}};

inline const EffectInfo& InfoOf(Effect e) { return kEffectInfo[static_cast<std::size_t>(e)]; }

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

/// An effect in a model, with the components it has; its parameter block holds one value per
/// component, in this order (rad or mm, EffectInfo::quantity).
struct EffectTerm {
  Effect effect = Effect::kThetaEncoder;
  std::vector<EffectComponent> components;

  int size() const { return static_cast<int>(components.size()); }
  const EffectInfo& info() const { return InfoOf(effect); }

  /// Name of parameter i: "theta_encoder.c2", "theta_radial_motion.y_s3", "probe_drift.t1", ...
  std::string ParamName(std::size_t i) const {
    const EffectComponent& c = components[i];
    std::string s = std::string(info().id) + ".";
    if (info().axes == 2) s += c.axis == 0 ? "x_" : "y_";
    if (info().harmonic) {
      s += c.sine ? "s" : "c";
    } else {
      s += effect == Effect::kProbeDrift ? "t" : "u";
    }
    return s + std::to_string(c.order);
  }
};

/// The default term of an effect: harmonics k = 1..harmonics (radial motion: 2..harmonics, see
/// the file comment), cos and sin, every axis; probe_gain u^1; probe_nonlinearity u^2 and u^3;
/// probe_drift tau^1..tau^drift_order.
inline EffectTerm DefaultTerm(Effect e, int harmonics = 4, int drift_order = 1) {
  EffectTerm t;
  t.effect = e;
  const EffectInfo& info = InfoOf(e);
  if (info.harmonic) {
    for (int axis = 0; axis < info.axes; ++axis) {
      for (int k = e == Effect::kThetaRadialMotion ? 2 : 1; k <= harmonics; ++k) {
        t.components.push_back({k, axis, false});
        t.components.push_back({k, axis, true});
      }
    }
  } else if (e == Effect::kProbeGain) {
    t.components.push_back({1, 0, false});
  } else if (e == Effect::kProbeNonlinearity) {
    t.components.push_back({2, 0, false});
    t.components.push_back({3, 0, false});
  } else {
    for (int k = 1; k <= drift_order; ++k) t.components.push_back({k, 0, false});
  }
  return t;
}

/// Highest harmonic order and highest power of time that parameter names may carry.
inline constexpr int kMaxEffectHarmonic = 12;
/// The largest magnitude files and options accept for one parameter of an effect: 3600 arcsec
/// (1 deg) for an angle, 1000 um for a length. Larger is not an error of a working machine.
inline constexpr double kMaxEffectArcsec = 3600.0;
inline constexpr double kMaxEffectUm = 1000.0;
inline constexpr int kMaxDriftOrder = 3;

/// The component of effect `e` whose parameter is called `name` ("theta_encoder.c2", ...), or false.
inline bool FindComponent(Effect e, const std::string& name, EffectComponent* out) {
  const EffectTerm all = DefaultTerm(e, kMaxEffectHarmonic, kMaxDriftOrder);
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
};

/// The reference of a set of readings (members r_mm and t_s): mid-range and half range of r,
/// start and length of the run. Ranges of zero length are replaced by 1 so that u and tau exist.
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
  return ref;
}

/// The effects of a model and their normalisation, and the sphere's own form. The parameter blocks
/// are passed separately, one per term, in term order (the form's coefficients apart: they do not
/// move the probed point, they move the surface it meets, sph/model/form_model.hpp).
struct EffectModel {
  std::vector<EffectTerm> terms;
  EffectReference reference;
  FormModel form;

  bool Empty() const { return terms.empty(); }
  int NumParams() const {
    int n = 0;
    for (const EffectTerm& t : terms) n += t.size();
    return n;
  }
  /// Index of the term of effect e, or -1.
  int Find(Effect e) const {
    for (std::size_t i = 0; i < terms.size(); ++i) {
      if (terms[i].effect == e) return static_cast<int>(i);
    }
    return -1;
  }
};

/// One reading as the effect model uses it: the readings (rad, mm, s) and their sin and cos.
struct EffectReading {
  double theta_rad = 0.0;
  double phi_rad = 0.0;
  double r_mm = 0.0;
  double t_s = 0.0;
  SinCos<double> theta{0.0, 1.0};
  SinCos<double> phi{0.0, 1.0};

  EffectReading() = default;
  EffectReading(double theta_deg, double phi_deg, double r, double t)
      : theta_rad(theta_deg * kRadPerDeg),
        phi_rad(phi_deg * kRadPerDeg),
        r_mm(r),
        t_s(t),
        theta(SinCosOf(theta_rad)),
        phi(SinCosOf(phi_rad)) {}
};

/// The value of component `c` of a term of effect `e` at reading x: cos(k x) or sin(k x) of the
/// reading the effect follows, or the power of u or tau.
inline double EffectBasis(const EffectTerm& term, const EffectComponent& c, const EffectReference& ref,
                          const EffectReading& x) {
  const EffectInfo& info = term.info();
  if (info.harmonic) {
    const double angle = std::strcmp(info.variable, "theta") == 0 ? x.theta_rad : x.phi_rad;
    return c.sine ? std::sin(c.order * angle) : std::cos(c.order * angle);
  }
  const double v = term.effect == Effect::kProbeDrift ? (x.t_s - ref.t_start_s) / ref.t_span_s
                                                      : (x.r_mm - ref.r_ref_mm) / ref.r_half_range_mm;
  return std::pow(v, c.order);
}

/// The basis values of every component of every term of `model` at one reading, in term and then
/// component order: what EffectScmsPoint() evaluates. A fit, which evaluates each reading many
/// times, computes them once.
inline std::vector<double> EffectBasisOf(const EffectModel& model, const EffectReading& x) {
  std::vector<double> out;
  out.reserve(static_cast<std::size_t>(model.NumParams()));
  for (const EffectTerm& term : model.terms) {
    for (const EffectComponent& c : term.components) out.push_back(EffectBasis(term, c, model.reference, x));
  }
  return out;
}

namespace internal {

/// sum_i p[i] * basis[i] over the components of `term` on `axis`; basis: the term's values of
/// EffectBasisOf(), or nullptr to compute them here.
template <typename T>
T EffectSum(const EffectTerm& term, const T* p, const double* basis, const EffectReference& ref, const EffectReading& x,
            int axis) {
  T sum(0.0);
  for (std::size_t i = 0; i < term.components.size(); ++i) {
    const EffectComponent& c = term.components[i];
    if (c.axis != axis) continue;
    sum += p[i] * (basis ? basis[i] : EffectBasis(term, c, ref, x));
  }
  return sum;
}

}  // namespace internal

/// The point in the sphere frame [mm] of one reading under the seven errors g (rad, mm; et =
/// ErrorTrigOf(g)) and the effects of `model` with parameter blocks `blocks` (one per term).
/// d: nominal probe zero distance [mm]. basis: EffectBasisOf(model, x), or nullptr to compute it.
template <typename T>
Vec3<T> EffectScmsPoint(const T* g, const ScmsErrorTrig<T>& et, const EffectModel& model, const T* const* blocks,
                        const EffectReading& x, double d, const double* basis = nullptr) {
  T dtheta(0.0), dphi(0.0), wx(0.0), wy(0.0), dr(0.0);
  Vec3<T> motion(T(0.0), T(0.0), T(0.0));
  bool theta_enc = false, phi_enc = false, wobble = false;
  const EffectReference& ref = model.reference;
  for (std::size_t i = 0; i < model.terms.size(); ++i) {
    const EffectTerm& term = model.terms[i];
    const T* p = blocks[i];
    const double* b = basis;
    if (basis) basis += term.components.size();
    switch (term.effect) {
      case Effect::kThetaEncoder:
        dtheta += internal::EffectSum(term, p, b, ref, x, 0);
        theta_enc = true;
        break;
      case Effect::kPhiEncoder:
        dphi += internal::EffectSum(term, p, b, ref, x, 0);
        phi_enc = true;
        break;
      case Effect::kThetaRadialMotion:
        motion[0] += internal::EffectSum(term, p, b, ref, x, 0);
        motion[1] += internal::EffectSum(term, p, b, ref, x, 1);
        break;
      case Effect::kThetaAxialMotion:
        motion[2] += internal::EffectSum(term, p, b, ref, x, 0);
        break;
      case Effect::kPhiWobble:
        wx += internal::EffectSum(term, p, b, ref, x, 0);
        wy += internal::EffectSum(term, p, b, ref, x, 1);
        wobble = true;
        break;
      case Effect::kProbeGain:
      case Effect::kProbeNonlinearity:
      case Effect::kProbeDrift:
        dr += internal::EffectSum(term, p, b, ref, x, 0);  // r_true - r_read
        break;
    }
  }
  const T z = (T(x.r_mm) + dr) - (T(d) + g[kDPrime]);
  Vec3<T> s = phi_enc ? ProbeToPhiFrame(g, et, SinCosOf(T(x.phi_rad) + dphi), z) : ProbeToPhiFrame(g, et, x.phi, z);
  if (wobble) {
    // Rx(wx) Ry(wy) s.
    const SinCos<T> tx = SinCosOf(wx), ty = SinCosOf(wy);
    const T vx = ty.cos * s[0] + ty.sin * s[2];
    const T vz = ty.cos * s[2] - ty.sin * s[0];
    s = Vec3<T>(vx, tx.cos * s[1] - tx.sin * vz, tx.sin * s[1] + tx.cos * vz);
  }
  const Vec3<T> m = PhiFrameToMachine(g, et, s) - motion;
  return theta_enc ? MachineToSphere(SinCosOf(T(x.theta_rad) + dtheta), m) : MachineToSphere(x.theta, m);
}

/// EffectScmsPoint() in double with the parameter blocks as vectors (one per term).
inline Eigen::Vector3d EffectScmsPoint(const ScmsGeometry& g, const EffectModel& model,
                                       const std::vector<std::vector<double>>& params, const EffectReading& x,
                                       double d) {
  std::vector<const double*> blocks;
  for (const auto& p : params) blocks.push_back(p.data());
  return EffectScmsPoint(g.data(), ErrorTrigOf(g.data()), model, blocks.data(), x, d);
}

}  // namespace sph

#endif  // SPH_MODEL_EFFECTS_HPP_
