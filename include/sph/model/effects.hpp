// The forward model of an SCMS with the effects of sph/model/effect_terms.hpp in their places.
//
// The chain (sph/model/scms_model.hpp, stages of Eq. (1)) with the effects in their places:
//   s = Rz(-phi_true) DH(beta, b, c, pi/2 + eps) [0, 0, r_true - (d + d')]   (ProbeToPhiFrame)
//   s = L e_z + Rx(wx) Ry(wy) (s - L e_z) + (px, py, pz)                      (phi_wobble, Phi axis motions)
//   m = Tx(a) Rx(pi/2 + alpha) s - (dx, dy, dz)                              (PhiFrameToMachine, spindle motion)
//   m = Ry(-ty) Rx(-tx) m                                                     (Theta spindle tilt)
//   p = Rz(theta_true) m                                                      (MachineToSphere)
// The rotor of each axis is displaced by its motion after it tilted about its pivot: the Phi axis'
// at L along its axis (phi_wobble_pivot_mm), the Theta spindle's at the axes' common point. A tilt
// of the Theta spindle about another point on its axis is this tilt and a radial motion. r_true is
// the reading with the probe's terms; probe_incidence's angle is that of the chain at the reading
// without them, r_read - (d + d'), against the sphere's normal there (IncidenceError()).
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

#include "sph/model/effect_terms.hpp"
#include "sph/model/fixed_vector.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/reading.hpp"
#include "sph/model/scms_model.hpp"
#include "sph/model/units.hpp"

namespace sph {

/// The effects of a model and their normalisation: what the forward model applies to a reading.
/// The parameter blocks are passed separately, one per term, in term order. Held without the heap
/// (at most one term per effect), so that firmware can hold a calibration's effects.
struct EffectTerms {
  FixedVector<EffectTerm, kNumEffects> terms;
  EffectReference reference;
  /// Where the Phi axis pivots when it tilts (phi_wobble): the distance from the Phi frame's origin
  /// along the axis to the bearing [mm], a constant of the machine taken from its drawing, not
  /// fitted. 0: the tilt turns about the frame's origin.
  double phi_wobble_pivot_mm = 0.0;

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

/// The effects of a fit and the sphere's own form (the form's coefficients apart: they do not move
/// the probed point, they move the surface it meets, sph/model/form_model.hpp).
struct EffectModel : EffectTerms {
  FormModel form;
};

/// One reading as the effect model uses it: the readings (rad, mm, s), their sin and cos, and the
/// direction in which each axis approached it (MotionDirection; 0 when not known: a reversal term
/// then shifts the reading by nothing, the mean of the two directions). A: its scalar (double, or
/// float where the whole evaluation is in float).
template <typename A>
struct BasicEffectReading {
  A theta_rad = A(0.0);
  A phi_rad = A(0.0);
  A r_mm = A(0.0);
  A t_s = A(0.0);
  SinCos<A> theta{A(0.0), A(1.0)};
  SinCos<A> phi{A(0.0), A(1.0)};
  MotionDirection direction;

  BasicEffectReading() = default;
  /// From a reading as the machine gives it (a points file's row is one), its time [s] and the
  /// direction of approach of its axes.
  BasicEffectReading(const RawReading& reading, double time_s, MotionDirection approach = {})
      : theta_rad(A(reading.theta_rad())),
        phi_rad(A(reading.phi_rad())),
        r_mm(A(reading.r_mm)),
        t_s(A(time_s)),
        theta(SinCosOf(theta_rad)),
        phi(SinCosOf(phi_rad)),
        direction(approach) {}
  /// The same from its parts: axis angles in deg, probe in mm, time in s.
  BasicEffectReading(A theta_deg, A phi_deg, A probe_mm, A time_s)
      : theta_rad(theta_deg * A(kRadPerDeg)),
        phi_rad(phi_deg * A(kRadPerDeg)),
        r_mm(probe_mm),
        t_s(time_s),
        theta(SinCosOf(theta_rad)),
        phi(SinCosOf(phi_rad)) {}
};
using EffectReading = BasicEffectReading<double>;

/// The value of component `c` of a term of effect `e` at reading x: cos(k x) or sin(k x) of the
/// reading the effect follows, the power of u or tau, or half the direction of approach of a
/// reversal term's axis (+-1/2, 0 unknown). NaN for probe_incidence, whose sin^2 psi is no function
/// of the reading alone (EffectScmsPoint() computes it).
template <typename A>
A EffectBasis(const EffectTerm& term, const EffectComponent& c, const EffectReference& ref,
              const BasicEffectReading<A>& x) {
  const EffectInfo& info = term.info();
  if (term.effect == Effect::kProbeIncidence) return std::numeric_limits<A>::quiet_NaN();
  if (term.effect == Effect::kThetaReversal) return A(0.5) * A(x.direction.theta);
  if (term.effect == Effect::kPhiReversal) return A(0.5) * A(x.direction.phi);
  if (info.harmonic) {
    const A angle = std::strcmp(info.variable, "theta") == 0 ? x.theta_rad : x.phi_rad;
    return c.sine ? std::sin(A(c.order) * angle) : std::cos(A(c.order) * angle);
  }
  const A v = term.effect == Effect::kProbeDrift ? (x.t_s - A(ref.t_start_s)) / A(ref.t_span_s)
                                                 : (x.r_mm - A(ref.r_ref_mm)) / A(ref.r_half_range_mm);
  return A(std::pow(v, c.order));
}

/// The basis values of every component of every term of `model` at one reading, in term and then
/// component order: what EffectScmsPoint() evaluates. A fit, which evaluates each reading many
/// times, computes them once.
inline std::vector<double> EffectBasisOf(const EffectTerms& model, const EffectReading& x) {
  std::vector<double> out;
  out.reserve(static_cast<std::size_t>(model.NumParams()));
  for (const EffectTerm& term : model.terms) {
    for (const EffectComponent& c : term.components) out.push_back(EffectBasis(term, c, model.reference, x));
  }
  return out;
}

/// d r_true / d r_read at the reading r_mm: how the probe's gain and nonlinearity (terms of u =
/// (r - r_ref) / r_half) stretch a change of the reading, its noise included; values: one block per
/// term of `model`. probe_incidence's change with the reading, through the point where its angle
/// is taken, is of order i (e / R0)^2 / R0 (3e-5 for i1 = 30 um, e = 2 mm, R0 = 20 mm) and left out.
template <typename Values>
double ReadingSlope(const EffectTerms& model, const Values& values, double r_mm) {
  const EffectReference& ref = model.reference;
  const double u = (r_mm - ref.r_ref_mm) / ref.r_half_range_mm;
  double slope = 1.0;
  for (std::size_t t = 0; t < model.terms.size() && t < values.size(); ++t) {
    const EffectTerm& term = model.terms[t];
    if (term.effect != Effect::kProbeGain && term.effect != Effect::kProbeNonlinearity) continue;
    for (std::size_t i = 0; i < term.components.size(); ++i) {
      const int k = term.components[i].order;
      slope += values[t][i] * k * std::pow(u, k - 1) / ref.r_half_range_mm;
    }
  }
  return slope;
}

namespace internal {

/// T itself, where a parameter must not take part in deducing T.
template <typename T>
struct NonDeduced {
  using type = T;
};

/// sum_i p[i] * basis[i] over the components of `term` on `axis`; basis: the term's values of
/// EffectBasisOf(), or nullptr to compute them here.
template <typename T, typename A>
T EffectSum(const EffectTerm& term, const T* p, const A* basis, const EffectReference& ref,
            const BasicEffectReading<A>& x, int axis) {
  T sum(0.0);
  for (std::size_t i = 0; i < term.components.size(); ++i) {
    const EffectComponent& c = term.components[i];
    if (c.axis != axis) continue;
    sum += p[i] * (basis ? basis[i] : EffectBasis(term, c, ref, x));
  }
  return sum;
}

/// What the effects of a model make of one reading: the places where they enter the chain.
template <typename T>
struct EffectInputs {
  T dtheta{0.0}, dphi{0.0}, wx{0.0}, wy{0.0}, tx{0.0}, ty{0.0}, dr{0.0};
  Vec3<T> motion{T(0.0), T(0.0), T(0.0)}, phi_motion{T(0.0), T(0.0), T(0.0)};
  bool theta_enc = false, phi_enc = false, wobble = false, tilt = false, phi_moves = false;
  int incidence = -1;  ///< the term of probe_incidence, or -1

  /// The probed point at z on the probe line (the chain of the file comment).
  template <typename A>
  Vec3<T> PointAt(const T* g, const ScmsErrorTrig<T>& et, const EffectTerms& model, const BasicEffectReading<A>& x,
                  const T& z) const {
    Vec3<T> s = phi_enc ? ProbeToPhiFrame(g, et, SinCosOf(T(x.phi_rad) + dphi), z) : ProbeToPhiFrame(g, et, x.phi, z);
    if (wobble) {
      // L e_z + Rx(wx) Ry(wy) (s - L e_z).
      const T pivot = T(model.phi_wobble_pivot_mm);
      const T s2 = s[2] - pivot;
      const SinCos<T> cx = SinCosOf(wx), cy = SinCosOf(wy);
      const T vx = cy.cos * s[0] + cy.sin * s2;
      const T vz = cy.cos * s2 - cy.sin * s[0];
      s = Vec3<T>(vx, cx.cos * s[1] - cx.sin * vz, (cx.sin * s[1] + cx.cos * vz) + pivot);
    }
    if (phi_moves) s = Vec3<T>(s[0] + phi_motion[0], s[1] + phi_motion[1], s[2] + phi_motion[2]);
    Vec3<T> m = PhiFrameToMachine(g, et, s) - motion;
    if (tilt) {
      // Ry(-ty) Rx(-tx) m: the sphere turned with the spindle, so the point relative to it turns back.
      const SinCos<T> cx = SinCosOf(tx), cy = SinCosOf(ty);
      const T r1 = cx.cos * m[1] + cx.sin * m[2];
      const T r2 = cx.cos * m[2] - cx.sin * m[1];
      m = Vec3<T>(cy.cos * m[0] - cy.sin * r2, r1, cy.sin * m[0] + cy.cos * r2);
    }
    return theta_enc ? MachineToSphere(SinCosOf(T(x.theta_rad) + dtheta), m) : MachineToSphere(x.theta, m);
  }
};

/// The inputs of every term of `model` but probe_incidence (whose term is only located).
template <typename T, typename A>
EffectInputs<T> EffectInputsOf(const EffectTerms& model, const T* const* blocks, const BasicEffectReading<A>& x,
                               const A* basis) {
  EffectInputs<T> in;
  const EffectReference& ref = model.reference;
  for (std::size_t i = 0; i < model.terms.size(); ++i) {
    const EffectTerm& term = model.terms[i];
    const T* p = blocks[i];
    const A* b = basis;
    if (basis) basis += term.components.size();
    switch (term.effect) {
      case Effect::kThetaEncoder:
      case Effect::kThetaReversal:
        in.dtheta += EffectSum(term, p, b, ref, x, 0);
        in.theta_enc = true;
        break;
      case Effect::kPhiEncoder:
      case Effect::kPhiReversal:
        in.dphi += EffectSum(term, p, b, ref, x, 0);
        in.phi_enc = true;
        break;
      case Effect::kThetaRadialMotion:
        in.motion[0] += EffectSum(term, p, b, ref, x, 0);
        in.motion[1] += EffectSum(term, p, b, ref, x, 1);
        break;
      case Effect::kThetaAxialMotion:
        in.motion[2] += EffectSum(term, p, b, ref, x, 0);
        break;
      case Effect::kThetaTiltMotion:
        in.tx += EffectSum(term, p, b, ref, x, 0);
        in.ty += EffectSum(term, p, b, ref, x, 1);
        in.tilt = true;
        break;
      case Effect::kPhiWobble:
        in.wx += EffectSum(term, p, b, ref, x, 0);
        in.wy += EffectSum(term, p, b, ref, x, 1);
        in.wobble = true;
        break;
      case Effect::kPhiRadialMotion:
        in.phi_motion[0] += EffectSum(term, p, b, ref, x, 0);
        in.phi_motion[1] += EffectSum(term, p, b, ref, x, 1);
        in.phi_moves = true;
        break;
      case Effect::kPhiAxialMotion:
        in.phi_motion[2] += EffectSum(term, p, b, ref, x, 0);
        in.phi_moves = true;
        break;
      case Effect::kProbeGain:
      case Effect::kProbeNonlinearity:
      case Effect::kProbeDrift:
        in.dr += EffectSum(term, p, b, ref, x, 0);  // r_true - r_read
        break;
      case Effect::kProbeIncidence:
        in.incidence = static_cast<int>(i);
        break;
    }
  }
  return in;
}

/// The probe_incidence error [mm] of the inputs `in` (in.incidence >= 0): sin^2 psi at the point
/// of the reading without the probe's terms, the beam the direction of the (affine) line z -> p,
/// the normal the direction from the centre.
template <typename T, typename A>
T IncidenceError(const EffectInputs<T>& in, const T* g, const ScmsErrorTrig<T>& et, const EffectTerms& model,
                 const T* const* blocks, const BasicEffectReading<A>& x, double d, const T* center) {
  using std::sqrt;
  const T z0 = T(x.r_mm) - (T(d) + g[kDPrime]);
  const Vec3<T> p0 = in.PointAt(g, et, model, x, z0);
  const Vec3<T> beam = in.PointAt(g, et, model, x, z0 + T(1.0)) - p0;
  const T v0 = p0[0] - center[0], v1 = p0[1] - center[1], v2 = p0[2] - center[2];
  const T c = (beam[0] * v0 + beam[1] * v1 + beam[2] * v2) / sqrt(v0 * v0 + v1 * v1 + v2 * v2);
  const T sin2 = T(1.0) - c * c;
  const EffectTerm& term = model.terms[static_cast<std::size_t>(in.incidence)];
  const T* p = blocks[in.incidence];
  T error(0.0);
  for (std::size_t k = 0; k < term.components.size(); ++k) {
    T power = sin2;
    for (int j = 1; j < term.components[k].order; ++j) power *= sin2;
    error += p[k] * power;
  }
  return error;
}

}  // namespace internal

/// The point in the sphere frame [mm] of one reading under the seven errors g (rad, mm; et =
/// ErrorTrigOf(g)) and the effects of `model` with parameter blocks `blocks` (one per term).
/// d: nominal probe zero distance [mm]. basis: EffectBasisOf(model, x), or nullptr to compute it.
/// center: the sphere's centre O [mm], which a probe_incidence term needs (the normal there is
/// (p - O) / |p - O|); without it that term is left out.
/// T: the scalar of the parameters (double, float, ceres::Jet), A: of the reading (double, or float
/// with T float).
template <typename T, typename A>
Vec3<T> EffectScmsPoint(const T* g, const ScmsErrorTrig<T>& et, const EffectTerms& model, const T* const* blocks,
                        const BasicEffectReading<A>& x, double d,
                        const typename internal::NonDeduced<A>::type* basis = nullptr,
                        const typename internal::NonDeduced<T>::type* center = nullptr) {
  internal::EffectInputs<T> in = internal::EffectInputsOf(model, blocks, x, basis);
  if (in.incidence >= 0 && center) in.dr += internal::IncidenceError(in, g, et, model, blocks, x, d, center);
  return in.PointAt(g, et, model, x, (T(x.r_mm) + in.dr) - (T(d) + g[kDPrime]));
}

/// The probe_incidence error of one reading [mm], as EffectScmsPoint() adds it to the reading
/// (arguments as there; 0 without such a term).
template <typename T, typename A>
T ProbeIncidenceError(const T* g, const ScmsErrorTrig<T>& et, const EffectTerms& model, const T* const* blocks,
                      const BasicEffectReading<A>& x, double d, const T* center) {
  const internal::EffectInputs<T> in = internal::EffectInputsOf(model, blocks, x, static_cast<const A*>(nullptr));
  return in.incidence >= 0 ? internal::IncidenceError(in, g, et, model, blocks, x, d, center) : T(0.0);
}

/// EffectScmsPoint() in double with the parameter blocks as vectors (one per term); center_mm:
/// the sphere's centre, for a probe_incidence term.
template <typename Values = std::vector<std::vector<double>>>
Eigen::Vector3d EffectScmsPoint(const ScmsGeometry& g, const EffectTerms& model, const Values& params,
                                const EffectReading& x, double d, const Eigen::Vector3d* center_mm = nullptr) {
  std::vector<const double*> blocks;
  for (const auto& p : params) blocks.push_back(p.data());
  return EffectScmsPoint(g.data(), ErrorTrigOf(g.data()), model, blocks.data(), x, d, nullptr,
                         center_mm ? center_mm->data() : nullptr);
}

}  // namespace sph

#endif  // SPH_MODEL_EFFECTS_HPP_
