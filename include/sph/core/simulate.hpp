// Simulated SCMS readings of a reference sphere, by intersecting the probe ray with the sphere.
//
// The probe line is built from elementary rotations and translations (Eigen::Transform), not from
// the model headers or the residual functor, so data made here tests the calibration independently:
//
//   T_theta_phi = Rz(theta) * Tx(a) * Rx(pi/2 + alpha)
//   T_phi_probe = Rz(-phi) * Rz(beta) * Tz(b) * Tx(c) * Rx(pi/2 + epsilon)
//
// The probe zero point is at z = -(d + d') on the probe frame's z axis, and the probe measures
// along +z (towards the axes' common point): reading r is the distance from the zero point to the
// first intersection of that ray with the sphere |p - O| = R0.
//
// Effects beyond the seven errors (sph/model/effects.hpp) enter the same way, as elementary
// transforms in their places, evaluated here from their definitions and not through the model
// header's EffectScmsPoint():
//
//   T_sphere_probe = Rz(theta_true) * T(-(dx, dy, dz)(theta)) * Tx(a) * Rx(pi/2 + alpha)
//                    * Rx(wx(phi)) * Ry(wy(phi)) * Rz(-phi_true) * Rz(beta) * Tz(b) * Tx(c) * Rx(pi/2 + epsilon)
//
// and the probe reads r_read such that r_read + (gain + nonlinearity + drift)(r_read, t) equals the
// true distance (solved by fixed-point iteration). The simulator also makes effects that are not in
// the library, so that the calibrator can be tested on what it cannot explain: a form error of the
// reference sphere (real spherical harmonics fixed on the sphere) and outliers.
#ifndef SPH_CORE_SIMULATE_HPP_
#define SPH_CORE_SIMULATE_HPP_

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "sph/core/points_file.hpp"
#include "sph/model/effects.hpp"
#include "sph/model/scms_model.hpp"

namespace sph {

/// One commanded position of the two axes [deg].
struct AnglePair {
  double theta_deg = 0.0;
  double phi_deg = 0.0;
};

/// A theta x phi grid: theta = 0, 360/nt, ...; phi = (j + 0.5) * 180/np (the paper's 24 x 12 grid
/// is theta 0, 15, ..., 345 deg and phi 7.5, 22.5, ..., 172.5 deg). Rows: phi outer, theta inner.
std::vector<AnglePair> GridPattern(int theta_steps, int phi_steps);

/// One component of the reference sphere's form error: the surface radius is
/// R0 + amplitude * S_lm(direction), with S_lm the Schmidt semi-normalised real spherical harmonic
/// (|S_lm| <= 1; cos(m lon) for m >= 0, sin(|m| lon) for m < 0) of the direction from the centre,
/// in the sphere's frame (polar angle from its z axis).
struct FormComponent {
  int l = 2;
  int m = 0;
  double amplitude_um = 0.0;
};

/// What the simulated machine and sphere have beyond the seven errors.
struct SimulatedEffects {
  /// Library effects; `model.reference` is set by the simulator from the simulated readings
  /// themselves (EffectReferenceOf, before noise), as a calibration sets it from its data.
  EffectModel model;
  std::vector<std::vector<double>> values;  ///< one block per term of `model` (rad, mm)
  std::vector<FormComponent> form;          ///< form error of the reference sphere
  double outlier_fraction = 0.0;            ///< share of readings with a gross error in r
  double outlier_um = 0.0;                  ///< size of that error (random sign) [um]

  bool Empty() const { return model.Empty() && form.empty() && !(outlier_fraction > 0.0); }
};

/// What to simulate. Defaults are the paper's study (Table 1 truth, R0 20 mm, d 25 mm,
/// 24 x 12 grid, centre (2, 0, 0) mm, noise on r 0.05 um).
struct SimulationSpec {
  ScmsGeometry truth = PaperTruth();  ///< internal units (rad, mm)
  double sphere_radius_mm = 20.0;     ///< R0
  double probe_offset_mm = 25.0;      ///< nominal d
  /// Sphere centre of each setup [mm]; setup ids are 0, 1, ... in this order.
  std::vector<Eigen::Vector3d> centers_mm{Eigen::Vector3d(2.0, 0.0, 0.0)};
  std::vector<AnglePair> pattern = GridPattern(24, 12);  ///< measured at every setup
  double noise_r_um = 0.05;          ///< sigma of Gaussian noise on r [um]
  double noise_theta_arcsec = 0.0;   ///< sigma of the theta reading noise [arcsec]
  double noise_phi_arcsec = 0.0;     ///< sigma of the phi reading noise [arcsec]
  std::uint64_t seed = 1;
  double sample_period_s = 1.0;      ///< t_s of row i is i * sample_period_s
  SimulatedEffects effects;          ///< none by default

  /// Table 1 of the paper: alpha = beta = epsilon = 0.02 deg, a = b = c = 0.002 mm, d' = -0.062 mm.
  static ScmsGeometry PaperTruth();
};

/// The probe reading r [mm] at the true axis positions theta, phi [rad], or nothing when the probe
/// ray misses the sphere.
std::optional<double> ProbeReading(const ScmsGeometry& truth, double theta_rad, double phi_rad, double probe_offset_mm,
                                   const Eigen::Vector3d& center_mm, double sphere_radius_mm);

/// The true distance [mm] from the probe zero point to the sphere's surface along the probe ray,
/// for the axis readings theta_read, phi_read [rad], with the effects of `effects` except the probe's
/// own errors (gain, nonlinearity, drift), which act on the reading and not on the ray. Nothing
/// when the ray misses the sphere. `effects.model.reference` is not used here.
std::optional<double> TrueProbeDistance(const ScmsGeometry& truth, const SimulatedEffects& effects, double theta_rad,
                                        double phi_rad, double probe_offset_mm, const Eigen::Vector3d& center_mm,
                                        double sphere_radius_mm);

/// The reading r_read [mm] of a probe with the gain, nonlinearity and drift of `effects` (with the
/// reference `effects.model.reference`) that sees the true distance `distance_mm` at time t_s.
double ProbeReadingOfDistance(const SimulatedEffects& effects, double distance_mm, double t_s);

/// Simulates a points file: for each setup, each pattern point in order; the axes are at the
/// commanded angles, the readings carry the noise. Throws sph::Error when a ray misses the sphere.
/// Equals AddReadingNoise(SimulateExact(spec), spec).
/// When `reference` is given, it receives the reference the probe terms were simulated with.
PointsData Simulate(const SimulationSpec& spec, EffectReference* reference = nullptr);

/// Simulate() without noise and outliers: the exact readings of the stated truth and effects.
PointsData SimulateExact(const SimulationSpec& spec, EffectReference* reference = nullptr);

/// Adds Gaussian noise with the spec's sigmas to every reading, drawn from std::mt19937_64(spec.seed)
/// in the order (r, theta, phi) per sample, so that a seed gives the same noise whatever sigmas are zero;
/// then the outliers of spec.effects, from a second generator seeded from spec.seed.
void AddReadingNoise(PointsData& data, const SimulationSpec& spec);

}  // namespace sph

#endif  // SPH_CORE_SIMULATE_HPP_
