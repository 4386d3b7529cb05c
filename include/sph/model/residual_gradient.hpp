// The residual of one reading against the reference sphere and its gradient, derived by hand.
//
//   e = |p - O| - R0,   p = Rz(theta') [Tx(a) Rx(pi/2 + alpha) W s - motion],
//   s = Rz(-phi') DH(beta, b, c, pi/2 + epsilon) [0, 0, z],   z = r_true - (d + d')
//
// This is Eq. (1) in the stages of sph/model/scms_model.hpp with the places where the effects of
// sph/model/effects.hpp enter it: theta' and phi' are the readings plus the encoder errors, W is
// the tilt of the Phi axis (phi_wobble: Rx(wx) Ry(wy)), `motion` the Theta spindle's error motion
// and r_true the probe reading plus the probe terms. Every effect parameter enters through one of
// these inputs, linearly (sum of parameter times basis function), so the gradient of e with respect
// to the inputs is all a fit needs: de/dp_k = de/d(input) * basis_k.
//
// The forward pass is the one of ScmsPoint()/EffectScmsPoint() (same operations in the same order,
// so e is bit for bit theirs); the gradient is one reverse sweep through it:
//   n = (p - O) / |p - O|           de/dO = -n,   de/dtheta' = n . dp/dtheta' = n1 p0 - n0 p1
//   gm = Rz(theta')^T n             de/dmotion = -gm,   de/da = gm0,   de/dalpha = gm2 m1 - gm1 m2
//   gs = (dm/ds)^T gm               (through W^T when the Phi axis tilts: de/dwx, de/dwy)
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
  SinCos<double> theta{0.0, 1.0};      ///< of theta' = theta reading + encoder error
  SinCos<double> phi{0.0, 1.0};        ///< of phi' = phi reading + encoder error
  double z = 0.0;                      ///< r_true - (d + d') [mm]: the probe point on the probe line
  double motion[3] = {0.0, 0.0, 0.0};  ///< Theta spindle displacement in the machine frame [mm]
  SinCos<double> wobble_x{0.0, 1.0};   ///< of the Phi axis tilt wx (used when kWobble)
  SinCos<double> wobble_y{0.0, 1.0};   ///< of wy
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
};

/// e = |p - O| - R0 and its gradient (see the file comment). g: the seven errors (rad, mm), et =
/// ErrorTrigOf(g); center: O [mm]; radius_mm: R0. kWobble: whether the Phi axis tilts (otherwise
/// in.wobble_* are ignored and W = I exactly, as in EffectScmsPoint()).
template <bool kWobble = false>
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
  double w0 = s0, w1 = s1, w2 = s2, vx = 0.0, vz = 0.0;  // W s
  if constexpr (kWobble) {
    const SinCos<double>& tx = in.wobble_x;
    const SinCos<double>& ty = in.wobble_y;
    vx = ty.cos * s0 + ty.sin * s2;
    vz = ty.cos * s2 - ty.sin * s0;
    w0 = vx;
    w1 = tx.cos * s1 - tx.sin * vz;
    w2 = tx.sin * s1 + tx.cos * vz;
  }
  const double mt1 = -et.alpha.sin * w1 - et.alpha.cos * w2;  // Rx(pi/2 + alpha) W s
  const double mt2 = et.alpha.cos * w1 - et.alpha.sin * w2;
  const double m0 = (w0 + g[kA]) - in.motion[0];
  const double m1 = mt1 - in.motion[1];
  const double m2 = mt2 - in.motion[2];
  const double p0 = in.theta.cos * m0 - in.theta.sin * m1;
  const double p1 = in.theta.sin * m0 + in.theta.cos * m1;
  const double p2 = m2;
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
  const double gm0 = in.theta.cos * n0 + in.theta.sin * n1;
  const double gm1 = in.theta.cos * n1 - in.theta.sin * n0;
  const double gm2 = n2;
  out->motion[0] = -gm0;
  out->motion[1] = -gm1;
  out->motion[2] = -gm2;
  out->geometry[kA] = gm0;
  out->geometry[kAlpha] = gm2 * mt1 - gm1 * mt2;
  const double gw0 = gm0;
  const double gw1 = et.alpha.cos * gm2 - et.alpha.sin * gm1;
  const double gw2 = -et.alpha.cos * gm1 - et.alpha.sin * gm2;
  double gs0 = gw0, gs1 = gw1, gs2 = gw2;
  if constexpr (kWobble) {
    const SinCos<double>& tx = in.wobble_x;
    const SinCos<double>& ty = in.wobble_y;
    out->wobble_x = gw2 * w1 - gw1 * w2;
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

}  // namespace sph

#endif  // SPH_MODEL_RESIDUAL_GRADIENT_HPP_
