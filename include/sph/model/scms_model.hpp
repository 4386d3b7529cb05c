// Forward model of a spherical coordinate measuring system (SCMS) with its seven
// position-independent geometric errors (Li, Yuan, He, Du; Eq. (1)).
//
// Axes: Theta turns the sphere (reading theta), Phi swings the probe (reading phi), the probe
// reads r along its line. d is the nominal probe zero distance (distance from the axes' common
// point at which the probe reads 0).
//
//   T_theta_phi = DH(theta, 0, a, pi/2 + alpha)
//   T_phi_probe = Rz(-phi) * DH(beta, b, c, pi/2 + epsilon)
//   p_probe     = [0, 0, r - (d + d'), 1]^T
//   p_sphere    = T_theta_phi * T_phi_probe * p_probe
//
// p_sphere is expressed in the frame that turns with Theta, i.e. the frame in which the measured
// sphere is at rest. With all errors zero, p_sphere = (d - r) * (sin phi cos theta, sin phi sin theta,
// cos phi): phi is the polar angle, theta the azimuth.
//
// Geometry parameter block g[kNumScmsParams], internal units rad and mm:
//   g[0] alpha   [rad] angle error between the Theta and Phi axis lines
//   g[1] a       [mm]  offset between the Theta and Phi axis lines
//   g[2] beta    [rad] angle error about the Phi axis (zero of the probe direction)
//   g[3] b       [mm]  offset of the probe line along the Phi axis
//   g[4] epsilon [rad] angle error between the Phi axis and the probe line
//   g[5] c       [mm]  offset between the Phi axis line and the probe line
//   g[6] d'      [mm]  error of the probe zero distance d
//
// Everything here is templated on the scalar (double, float, ceres::Jet) and includes Eigen only.
#ifndef SPH_MODEL_SCMS_MODEL_HPP_
#define SPH_MODEL_SCMS_MODEL_HPP_

#include <array>

#include "sph/model/dh.hpp"
#include "sph/model/units.hpp"

namespace sph {

/// Index of each geometric error in the geometry parameter block (see the file comment).
enum ScmsParam : int { kAlpha = 0, kA, kBeta, kB, kEpsilon, kC, kDPrime, kNumScmsParams };

/// Whether a parameter is an angle or a length, for unit conversion and reporting.
enum class Quantity { kAngle, kLength };

/// Static description of one geometry parameter.
struct ScmsParamInfo {
  const char* name;    ///< identifier used in files and reports ("alpha", "d_prime", ...)
  const char* symbol;  ///< symbol as in the paper
  Quantity quantity;
  /// The largest magnitude, in report units (deg or mm), that files and options accept for the
  /// error: an assembly error, not a different machine (|d'| must moreover stay below d).
  double max_abs_report;
  /// Its location error of ISO 230-1 (Theta the C axis, Phi the B axis, both with the senses of
  /// ISO 841 for the probe relative to the sphere), with a minus sign where ours is opposite;
  /// "" for the probe's offsets and orientation, which ISO 230-1 has no name for.
  const char* iso_name;
};

inline constexpr std::array<ScmsParamInfo, kNumScmsParams> kScmsParamInfo{{
    {"alpha", "alpha", Quantity::kAngle, 10.0, "EA0B"},
    {"a", "a", Quantity::kLength, 10.0, "X0B"},
    {"beta", "beta", Quantity::kAngle, 10.0, "-EB0B"},
    {"b", "b", Quantity::kLength, 10.0, ""},
    {"epsilon", "epsilon", Quantity::kAngle, 10.0, ""},
    {"c", "c", Quantity::kLength, 10.0, ""},
    {"d_prime", "d'", Quantity::kLength, 100.0, ""},
}};

/// The seven geometric errors in internal units (rad, mm), in ScmsParam order.
using ScmsGeometry = std::array<double, kNumScmsParams>;

/// The units a quantity is reported in: coarse (deg or mm, the paper's and the files') and fine
/// (urad or um), with the factors from internal units (rad or mm). The one table of report units.
struct ReportUnits {
  const char* coarse;
  const char* fine;
  double to_coarse;
  double to_fine;
};
constexpr ReportUnits ReportUnitsOf(Quantity q) {
  return q == Quantity::kAngle ? ReportUnits{"deg", "urad", kDegPerRad, kUradPerRad}
                               : ReportUnits{"mm", "um", 1.0, kUmPerMm};
}
/// The report units of geometry parameter `param`.
constexpr ReportUnits ReportUnitsOf(int param) {
  return ReportUnitsOf(kScmsParamInfo[static_cast<std::size_t>(param)].quantity);
}

/// Converts a parameter from report units (deg or mm) to internal units (rad or mm).
inline double FromReportUnits(int param, double value) {
  return kScmsParamInfo[param].quantity == Quantity::kAngle ? value * kRadPerDeg : value;
}
/// Converts a parameter from internal units (rad or mm) to report units (deg or mm).
inline double ToReportUnits(int param, double value) { return value * ReportUnitsOf(param).to_coarse; }

/// Eq. (1) literally, as a product of 4x4 transforms. Clear, and the reference for ScmsPoint();
/// ScmsPoint() is the same function written as successive operations on one point (faster).
/// @param g geometry block (rad, mm); theta, phi [rad]; r, d [mm]. Returns p_sphere [mm].
template <typename T>
Vec3<T> ScmsPointDh(const T* g, const T& theta, const T& phi, const T& r, const T& d) {
  const T half_pi(kPi / 2);
  const Mat4<T> T_theta_phi = DhTransform(theta, T(0), g[kA], half_pi + g[kAlpha]);
  const Mat4<T> T_phi_probe = RotZ(T(-phi)) * DhTransform(g[kBeta], g[kB], g[kC], half_pi + g[kEpsilon]);
  const Vec4<T> p_probe(T(0), T(0), r - (d + g[kDPrime]), T(1));
  return (T_theta_phi * T_phi_probe * p_probe).template head<3>();
}

/// sin and cos of the three angle errors. They depend on the geometry only, so code that evaluates
/// many readings with one geometry computes them once (ErrorTrigOf) and passes them to ScmsPoint().
template <typename T>
struct ScmsErrorTrig {
  SinCos<T> alpha;
  SinCos<T> beta;
  SinCos<T> epsilon;
};

/// sin and cos of alpha, beta and epsilon of the geometry block g.
template <typename T>
ScmsErrorTrig<T> ErrorTrigOf(const T* g) {
  return {SinCosOf(g[kAlpha]), SinCosOf(g[kBeta]), SinCosOf(g[kEpsilon])};
}

/// Eq. (1) applied right to left, in three stages that the effect model (sph/model/effects.hpp)
/// also uses, with its own terms between them:
///   ProbeToPhiFrame:    s = Rz(-phi) * DH(beta, b, c, pi/2 + eps) * [0, 0, z]   (frame of the Phi axis)
///   PhiFrameToMachine:  m = Tx(a) * Rx(pi/2 + alpha) * s                         (machine frame)
///   MachineToSphere:    p = Rz(theta) * m                                         (frame turning with Theta)
/// They use sin(pi/2 + x) = cos x and cos(pi/2 + x) = -sin x. The reading trig may be precomputed
/// (fixed readings, A = double) or carry derivatives of its own.

/// The probe point at z on the probe line (R frame), in the frame of the Phi axis [mm].
template <typename T, typename A>
Vec3<T> ProbeToPhiFrame(const T* g, const ScmsErrorTrig<T>& et, const SinCos<A>& phi, const T& z) {
  // q = DH(beta, b, c, pi/2 + eps) * [0, 0, z]: Rx(pi/2 + eps) gives [0, -cos(eps) z, -sin(eps) z],
  // then + [c, 0, b], then Rz(beta).
  const T u = -et.epsilon.cos * z;
  const T qx = et.beta.cos * g[kC] - et.beta.sin * u;
  const T qy = et.beta.sin * g[kC] + et.beta.cos * u;
  const T qz = g[kB] - et.epsilon.sin * z;
  // Rz(-phi) * q.
  return Vec3<T>(phi.cos * qx + phi.sin * qy, phi.cos * qy - phi.sin * qx, qz);
}

/// A point s of the Phi-axis frame in the machine frame (fixed to the base, before the Theta turn) [mm].
template <typename T>
Vec3<T> PhiFrameToMachine(const T* g, const ScmsErrorTrig<T>& et, const Vec3<T>& s) {
  // Rx(pi/2 + alpha) gives [sx, -sin(alpha) sy - cos(alpha) sz, cos(alpha) sy - sin(alpha) sz], then + [a, 0, 0].
  return Vec3<T>(s[0] + g[kA], -et.alpha.sin * s[1] - et.alpha.cos * s[2], et.alpha.cos * s[1] - et.alpha.sin * s[2]);
}

/// A machine-frame point m in the frame that turns with Theta (the sphere's frame) [mm].
template <typename T, typename A>
Vec3<T> MachineToSphere(const SinCos<A>& theta, const Vec3<T>& m) {
  return Vec3<T>(theta.cos * m[0] - theta.sin * m[1], theta.sin * m[0] + theta.cos * m[1], m[2]);
}

/// Eq. (1) applied right to left to the probe point, given sin and cos of the angle errors
/// (ErrorTrigOf(g)) and of the axis readings.
/// @param g geometry block (rad, mm); et = ErrorTrigOf(g); theta, phi: sin and cos of the readings;
///        r, d [mm]. Returns p_sphere [mm].
template <typename T, typename A>
Vec3<T> ScmsPoint(const T* g, const ScmsErrorTrig<T>& et, const SinCos<A>& theta, const SinCos<A>& phi, const T& r,
                  const T& d) {
  const T z = r - (d + g[kDPrime]);  // probe point on the probe line (R frame z)
  return MachineToSphere(theta, PhiFrameToMachine(g, et, ProbeToPhiFrame(g, et, phi, z)));
}

/// ScmsPoint() given sin and cos of the axis readings; computes the angle errors' trig itself.
template <typename T, typename A>
Vec3<T> ScmsPoint(const T* g, const SinCos<A>& theta, const SinCos<A>& phi, const T& r, const T& d) {
  return ScmsPoint(g, ErrorTrigOf(g), theta, phi, r, d);
}

/// Convenience overload of ScmsPoint() taking the readings theta, phi in rad.
template <typename T>
Vec3<T> ScmsPoint(const T* g, const T& theta, const T& phi, const T& r, const T& d) {
  return ScmsPoint(g, SinCosOf(theta), SinCosOf(phi), r, d);
}

/// ScmsPoint() for a ScmsGeometry in double; readings in rad and mm.
inline Eigen::Vector3d ScmsPoint(const ScmsGeometry& g, double theta_rad, double phi_rad, double r_mm, double d_mm) {
  return ScmsPoint(g.data(), theta_rad, phi_rad, r_mm, d_mm);
}

}  // namespace sph

#endif  // SPH_MODEL_SCMS_MODEL_HPP_
