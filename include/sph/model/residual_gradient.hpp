// The residual of one reading against the reference sphere and its gradient, derived by hand.
//
//   e = |p - O| - R0,   p = Rz(theta') K [Tx(a) Rx(pi/2 + alpha) w - motion],
//   w = L e_z + W (s - L e_z) + phi_motion,
//   s = Rz(-phi') DH(beta, b, c, pi/2 + epsilon) [0, 0, z],   z = r_true - (d + d')
//
// This is Eq. (1) in the stages of sph/model/scms_model.hpp with the places where the effects of
// sph/model/effects.hpp enter it: theta' and phi' are the readings plus the encoder errors, W is
// the tilt of the Phi axis about its pivot at L (phi_wobble: Rx(wx) Ry(wy)), `phi_motion` the
// Phi axis' radial and axial motion, `motion` the Theta spindle's, K = Ry(-ty) Rx(-tx) its tilt
// (theta_tilt_motion) and r_true the probe reading plus the probe terms. Every effect parameter enters through one of
// these inputs, linearly (sum of parameter times basis function), so the gradient of e with respect
// to the inputs is all a fit needs: de/dp_k = de/d(input) * basis_k.
//
// The forward pass is the one of ScmsPoint()/EffectScmsPoint() (same operations in the same order,
// so e is bit for bit theirs); the gradient is one reverse sweep through it:
//   n = (p - O) / |p - O|           de/dO = -n,   de/dtheta' = n . dp/dtheta' = n1 p0 - n0 p1
//   gk = Rz(theta')^T n             (through K^T when the spindle tilts: de/dty = gk2 k0 - gk0 k2,
//                                    then de/dtx = gr1 r2 - gr2 r1 with r = Rx(-tx) m, gr = Ry(ty) gk)
//   gm = K^T-chain of gk            de/dmotion = -gm,   de/da = gm0,   de/dalpha = gm2 m1 - gm1 m2
//   gw = (dm/dw)^T gm = de/dphi_motion,  gs = W^T gw (when the Phi axis tilts: de/dwx, de/dwy, with
//                                    W (s - L e_z) in place of W s)
//   de/dphi' = gs0 s1 - gs1 s0,     gq = Rz(-phi')^T gs:  de/dbeta = gqy qx - gqx qy,
//   de/dc = gqx cos(beta) + gqy sin(beta),  de/db = gqz,  gu = gqy cos(beta) - gqx sin(beta),
//   de/depsilon = z (gu sin(eps) - gqz cos(eps)),  de/dz = -gu cos(eps) - gqz sin(eps) = -de/dd'.
// (m, s, q, u are the intermediate points of the stages, see ProbeToPhiFrame().) Tests check it
// against the automatic differentiation of the Ceres functors and against central differences.
//
// Header-only, Eigen only, double; no branches, so that loops over readings vectorise.
#ifndef SPH_MODEL_RESIDUAL_GRADIENT_HPP_
#define SPH_MODEL_RESIDUAL_GRADIENT_HPP_

#include <cmath>

#include "sph/model/scms_model.hpp"

namespace sph {

/// What one reading's residual depends on besides the seven errors and the centre.
struct ResidualInputs {
  SinCos<double> theta{0.0, 1.0};          ///< of theta' = theta reading + encoder error
  SinCos<double> phi{0.0, 1.0};            ///< of phi' = phi reading + encoder error
  double z = 0.0;                          ///< r_true - (d + d') [mm]: the probe point on the probe line
  double motion[3] = {0.0, 0.0, 0.0};      ///< Theta spindle displacement in the machine frame [mm]
  SinCos<double> wobble_x{0.0, 1.0};       ///< of the Phi axis tilt wx (used when kWobble)
  SinCos<double> wobble_y{0.0, 1.0};       ///< of wy
  double pivot_mm = 0.0;                   ///< L: where the Phi axis pivots, along it (used when kWobble)
  double phi_motion[3] = {0.0, 0.0, 0.0};  ///< Phi axis displacement in its own frame [mm]
  SinCos<double> tilt_x{0.0, 1.0};         ///< of the Theta spindle tilt tx (used when kTilt)
  SinCos<double> tilt_y{0.0, 1.0};         ///< of ty
};

/// The residual e [mm] and its derivatives.
struct ResidualGradient {
  double e = 0.0;
  double geometry[kNumScmsParams] = {};  ///< de/dg, ScmsParam order (per rad, per mm)
  double center[3] = {};                 ///< de/dO
  double theta = 0.0;                    ///< de/dtheta' [mm/rad]
  double phi = 0.0;                      ///< de/dphi' [mm/rad]
  double z = 0.0;                        ///< de/dz: also de/dr_true
  double motion[3] = {};                 ///< de/dmotion
  double wobble_x = 0.0;                 ///< de/dwx [mm/rad] (kWobble)
  double wobble_y = 0.0;                 ///< de/dwy [mm/rad] (kWobble)
  double phi_motion[3] = {};             ///< de/dphi_motion
  double tilt_x = 0.0;                   ///< de/dtx [mm/rad] (kTilt)
  double tilt_y = 0.0;                   ///< de/dty [mm/rad] (kTilt)
};

/// e = |p - O| - R0 and its gradient (see the file comment). g: the seven errors (rad, mm), et =
/// ErrorTrigOf(g); center: O [mm]; radius_mm: R0. kWobble: whether the Phi axis tilts (otherwise
/// in.wobble_* and in.pivot_mm are ignored and W = I exactly, as in EffectScmsPoint()); kTilt:
/// whether the Theta spindle does (otherwise K = I exactly).
template <bool kWobble = false, bool kTilt = false>
inline void SphereResidualGradient(const double* g, const ScmsErrorTrig<double>& et, const ResidualInputs& in,
                                   const double* center, double radius_mm, ResidualGradient* out) {
  // Forward: the stages of ProbeToPhiFrame(), the tilt, PhiFrameToMachine(), MachineToSphere().
  const double z = in.z;
  const double u = -et.epsilon.cos * z;
  const double qx = et.beta.cos * g[kC] - et.beta.sin * u;
  const double qy = et.beta.sin * g[kC] + et.beta.cos * u;
  const double qz = g[kB] - et.epsilon.sin * z;
  const double s0 = in.phi.cos * qx + in.phi.sin * qy;
  const double s1 = in.phi.cos * qy - in.phi.sin * qx;
  const double s2 = qz;
  double ws0 = s0, ws1 = s1, ws2 = s2, vx = 0.0, vz = 0.0;  // W (s - L e_z), s without a tilt
  double w2_pivot = s2;                                     // the axis component with L e_z back
  if constexpr (kWobble) {
    const SinCos<double>& tx = in.wobble_x;
    const SinCos<double>& ty = in.wobble_y;
    const double st2 = s2 - in.pivot_mm;
    vx = ty.cos * s0 + ty.sin * st2;
    vz = ty.cos * st2 - ty.sin * s0;
    ws0 = vx;
    ws1 = tx.cos * s1 - tx.sin * vz;
    ws2 = tx.sin * s1 + tx.cos * vz;
    w2_pivot = ws2 + in.pivot_mm;
  }
  const double w0 = ws0 + in.phi_motion[0];
  const double w1 = ws1 + in.phi_motion[1];
  const double w2 = w2_pivot + in.phi_motion[2];
  const double mt1 = -et.alpha.sin * w1 - et.alpha.cos * w2;  // Rx(pi/2 + alpha) w
  const double mt2 = et.alpha.cos * w1 - et.alpha.sin * w2;
  const double m0 = (w0 + g[kA]) - in.motion[0];
  const double m1 = mt1 - in.motion[1];
  const double m2 = mt2 - in.motion[2];
  double k0 = m0, k1 = m1, k2 = m2, r1 = 0.0, r2 = 0.0;  // K m
  if constexpr (kTilt) {
    const SinCos<double>& cx = in.tilt_x;
    const SinCos<double>& cy = in.tilt_y;
    r1 = cx.cos * m1 + cx.sin * m2;
    r2 = cx.cos * m2 - cx.sin * m1;
    k0 = cy.cos * m0 - cy.sin * r2;
    k1 = r1;
    k2 = cy.sin * m0 + cy.cos * r2;
  }
  const double p0 = in.theta.cos * k0 - in.theta.sin * k1;
  const double p1 = in.theta.sin * k0 + in.theta.cos * k1;
  const double p2 = k2;
  const double dx = p0 - center[0];
  const double dy = p1 - center[1];
  const double dz = p2 - center[2];
  const double dist = std::sqrt(dx * dx + dy * dy + dz * dz);
  out->e = dist - radius_mm;

  // Reverse.
  const double inv = 1.0 / dist;
  const double n0 = dx * inv, n1 = dy * inv, n2 = dz * inv;
  out->center[0] = -n0;
  out->center[1] = -n1;
  out->center[2] = -n2;
  out->theta = n1 * p0 - n0 * p1;
  const double gk0 = in.theta.cos * n0 + in.theta.sin * n1;
  const double gk1 = in.theta.cos * n1 - in.theta.sin * n0;
  const double gk2 = n2;
  double gm0 = gk0, gm1 = gk1, gm2 = gk2;
  if constexpr (kTilt) {
    const SinCos<double>& cx = in.tilt_x;
    const SinCos<double>& cy = in.tilt_y;
    out->tilt_y = gk2 * k0 - gk0 * k2;
    const double gr0 = cy.cos * gk0 + cy.sin * gk2;
    const double gr1 = gk1;
    const double gr2 = cy.cos * gk2 - cy.sin * gk0;
    out->tilt_x = gr1 * r2 - gr2 * r1;
    gm0 = gr0;
    gm1 = cx.cos * gr1 - cx.sin * gr2;
    gm2 = cx.sin * gr1 + cx.cos * gr2;
  }
  out->motion[0] = -gm0;
  out->motion[1] = -gm1;
  out->motion[2] = -gm2;
  out->geometry[kA] = gm0;
  out->geometry[kAlpha] = gm2 * mt1 - gm1 * mt2;
  const double gw0 = gm0;
  const double gw1 = et.alpha.cos * gm2 - et.alpha.sin * gm1;
  const double gw2 = -et.alpha.cos * gm1 - et.alpha.sin * gm2;
  out->phi_motion[0] = gw0;
  out->phi_motion[1] = gw1;
  out->phi_motion[2] = gw2;
  double gs0 = gw0, gs1 = gw1, gs2 = gw2;
  if constexpr (kWobble) {
    const SinCos<double>& tx = in.wobble_x;
    const SinCos<double>& ty = in.wobble_y;
    out->wobble_x = gw2 * ws1 - gw1 * ws2;
    const double gvx = gw0;
    const double gvy = tx.cos * gw1 + tx.sin * gw2;
    const double gvz = tx.cos * gw2 - tx.sin * gw1;
    out->wobble_y = gvx * vz - gvz * vx;
    gs0 = ty.cos * gvx - ty.sin * gvz;
    gs1 = gvy;
    gs2 = ty.sin * gvx + ty.cos * gvz;
  }
  out->phi = gs0 * s1 - gs1 * s0;
  const double gqx = in.phi.cos * gs0 - in.phi.sin * gs1;
  const double gqy = in.phi.sin * gs0 + in.phi.cos * gs1;
  const double gqz = gs2;
  out->geometry[kBeta] = gqy * qx - gqx * qy;
  out->geometry[kC] = gqx * et.beta.cos + gqy * et.beta.sin;
  out->geometry[kB] = gqz;
  const double gu = gqy * et.beta.cos - gqx * et.beta.sin;
  out->geometry[kEpsilon] = z * (gu * et.epsilon.sin - gqz * et.epsilon.cos);
  out->z = -gu * et.epsilon.cos - gqz * et.epsilon.sin;
  out->geometry[kDPrime] = -out->z;
}

/// The unit direction dp/dz of the probe line in the sphere frame at the inputs `in` (their z
/// aside): the rotations of SphereResidualGradient()'s forward pass applied to the probe line's
/// direction in the probe frame. (probe_incidence: the beam the surface is tilted against.)
template <bool kWobble = false, bool kTilt = false>
inline void BeamDirection(const ScmsErrorTrig<double>& et, const ResidualInputs& in, double* beam) {
  // dq/dz of ProbeToPhiFrame(): u = -cos(eps) z, qx = .. - sin(beta) u, qy = .. + cos(beta) u, qz = .. - sin(eps) z.
  const double qx = et.beta.sin * et.epsilon.cos;
  const double qy = -et.beta.cos * et.epsilon.cos;
  const double qz = -et.epsilon.sin;
  double s0 = in.phi.cos * qx + in.phi.sin * qy;
  double s1 = in.phi.cos * qy - in.phi.sin * qx;
  double s2 = qz;
  if constexpr (kWobble) {
    const double vx = in.wobble_y.cos * s0 + in.wobble_y.sin * s2;
    const double vz = in.wobble_y.cos * s2 - in.wobble_y.sin * s0;
    s0 = vx;
    const double w1 = in.wobble_x.cos * s1 - in.wobble_x.sin * vz;
    s2 = in.wobble_x.sin * s1 + in.wobble_x.cos * vz;
    s1 = w1;
  }
  double m0 = s0;
  double m1 = -et.alpha.sin * s1 - et.alpha.cos * s2;
  double m2 = et.alpha.cos * s1 - et.alpha.sin * s2;
  if constexpr (kTilt) {
    const double r1 = in.tilt_x.cos * m1 + in.tilt_x.sin * m2;
    const double r2 = in.tilt_x.cos * m2 - in.tilt_x.sin * m1;
    const double k0 = in.tilt_y.cos * m0 - in.tilt_y.sin * r2;
    m2 = in.tilt_y.sin * m0 + in.tilt_y.cos * r2;
    m0 = k0;
    m1 = r1;
  }
  beam[0] = in.theta.cos * m0 - in.theta.sin * m1;
  beam[1] = in.theta.sin * m0 + in.theta.cos * m1;
  beam[2] = m2;
}

}  // namespace sph

#endif  // SPH_MODEL_RESIDUAL_GRADIENT_HPP_
