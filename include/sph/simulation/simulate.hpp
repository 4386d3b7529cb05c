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
// first intersection of that ray with the sphere's surface.
//
// Effects beyond the seven errors (sph/model/effects.hpp) enter the same way, as elementary
// transforms in their places, evaluated here from their definitions and not through the model
// header's EffectScmsPoint():
//
//   T_sphere_probe = Rz(theta_true) * T(-(dx, dy, dz)(theta)) * Tx(a) * Rx(pi/2 + alpha)
//                    * Rx(wx(phi)) * Ry(wy(phi)) * Rz(-phi_true) * Rz(beta) * Tz(b) * Tx(c) * Rx(pi/2 + epsilon)
//
// A reversal term (theta_reversal, phi_reversal) is the axis standing off its reading by half its
// value b in the direction of approach: each axis moves from one commanded position of the scan to
// the next the shorter way round, keeps the direction of its last move while it stands, and before its first move
// in a setup was approached in the direction of that move; the ray then goes out along the angle
// the axis really stands at (theta_read + b dir / 2), a backlash b < 0 when the load lags.
//
// and the probe reads r_read such that r_read + (gain + nonlinearity + drift)(r_read, t) equals the
// true distance (a bracketed solve over the probe's range, where that sum must rise with r_read:
// ProbeReadingOfDistance()). The simulator also makes what is not in the
// library, so that the calibration can be tested on what it cannot explain, or must separate:
// outliers, and the reference sphere's own form error. The form is defined on the sphere's BODY
// frame; in each setup the sphere sits on its mount turned by a rotation R (p_theta = R * p_body
// for points relative to its centre, in the frame that turns with Theta), so the surface of a
// setup is { O + R * rho(u) * u : |u| = 1 } with rho(u) the body-frame radius (SurfaceRadius()):
// R0 plus spherical harmonics and Gaussian bumps, cut by flats. The probe ray is traced to that
// surface by a bracketed root search (TrueProbeDistance()).
#ifndef SPH_SIMULATION_SIMULATE_HPP_
#define SPH_SIMULATION_SIMULATE_HPP_

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "sph/io/points_file.hpp"
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

/// The most points a pattern of the simulators has (a grid or a file of angles): 10 million.
inline constexpr long kMaxPatternPoints = 10000000;

/// A pattern from a text file of "theta_deg phi_deg" lines ('#' starts a comment, blank lines are
/// skipped). Throws sph::Error naming the file and line: "angles.txt:3: expected 'theta_deg
/// phi_deg'", more than kMaxPatternPoints points, or no angles at all.
std::vector<AnglePair> ReadAnglePattern(const std::string& path);

/// The order in which a setup measures the pattern's points (the same points, another time
/// order), so that time and direction on the sphere are not one function of the other.
enum class ScanOrder {
  kRings,              ///< the pattern's order: for a grid, phi ring by ring, theta within each ring
  kReversed,           ///< the pattern's order backwards
  kSerpentine,         ///< ring by ring, every other ring backwards (a ring: consecutive points of one phi)
  kColumns,            ///< theta outer (in the order the pattern first reaches each theta), phi inner
  kSerpentineColumns,  ///< as kColumns, every other column backwards: phi's direction alternates
  kShuffled,           ///< a random permutation, seeded
};

/// "rings", "reversed", "serpentine", "columns", "serpentine-columns", "shuffled".
const char* ScanOrderName(ScanOrder order);
/// The order named `name` (ScanOrderName()); false for any other text.
bool ScanOrderFromName(std::string_view name, ScanOrder* order);
/// The names of all orders, separated by spaces, for messages.
const char* ScanOrderNames();

/// `pattern` in the time order `order`: a permutation of it. kShuffled draws a Fisher-Yates
/// shuffle from the 64-bit Mersenne Twister of seed (Random: the same permutation on every platform).
std::vector<AnglePair> InScanOrder(const std::vector<AnglePair>& pattern, ScanOrder order, std::uint64_t seed);

/// One spherical-harmonic component of the sphere's form error, on its body frame: the surface
/// radius gains amplitude * S_lm(u), with S_lm the Schmidt semi-normalised real spherical
/// harmonic (|S_lm| <= 1, mean square over the sphere 1 / (2l + 1); cos(m lon) for m >= 0,
/// sin(|m| lon) for m < 0, no Condon-Shortley phase) of the body direction u, polar angle from
/// the body's z axis, longitude from its x axis.
struct FormComponent {
  int l = 2;
  int m = 0;
  double amplitude_um = 0.0;
};

/// A flat ground on the sphere: the sphere cut by the plane at distance R0 - depth from its
/// centre, normal to the body direction `normal_body` (the radius in a direction u with
/// u.n > 0 is at most (R0 - depth) / (u.n)).
struct FormFlat {
  double depth_um = 0.0;                                   ///< > 0, < R0
  Eigen::Vector3d normal_body = Eigen::Vector3d::UnitZ();  ///< any length > 0
};

/// A local bump (a dent when the height is negative): the radius gains
/// height * exp(-g^2 / (2 width^2)), g the angle between the direction and `center_body`.
struct FormBump {
  double height_um = 0.0;
  double width_deg = 1.0;                                  ///< angular standard deviation, > 0
  Eigen::Vector3d center_body = Eigen::Vector3d::UnitZ();  ///< any length > 0
};

/// What the simulated machine and sphere have beyond the seven errors.
struct SimulatedEffects {
  /// Library effects; `model.reference` is set by the simulator from the simulated readings
  /// themselves (EffectReferenceOf, before noise), as a calibration sets it from its data.
  EffectModel model;
  std::vector<std::vector<double>> values;  ///< one block per term of `model` (rad, mm)
  std::vector<FormComponent> form;          ///< form error of the reference sphere: harmonics
  std::vector<FormFlat> flats;              ///< ... flats
  std::vector<FormBump> bumps;              ///< ... and bumps
  double outlier_fraction = 0.0;            ///< share of readings with a gross error in r
  double outlier_um = 0.0;                  ///< size of that error (random sign) [um]

  bool HasForm() const { return !form.empty() || !flats.empty() || !bumps.empty(); }
  bool Empty() const { return model.Empty() && !HasForm() && !(outlier_fraction > 0.0); }
};

/// S_lm (FormComponent) of the direction u (any length > 0), evaluated by the simulator itself:
/// Schmidt semi-normalised Legendre recurrences and (x + iy)^m, independent of
/// sph/model/spherical_harmonics.hpp, which a fit of the form uses.
double FormHarmonic(int l, int m, const Eigen::Vector3d& u);

/// The radius [mm] of the sphere's true surface in the body direction u (unit): R0 plus the
/// harmonics and bumps of `effects`, cut by its flats.
double SurfaceRadius(const SimulatedEffects& effects, double sphere_radius_mm, const Eigen::Vector3d& u_body);

/// The form's size over the whole sphere, without its degree 0 and 1 parts (a change of radius
/// and a shift of the centre, which a sphere fit takes): rms and peak-to-valley of
/// rho(u) - R0 minus its projection onto 1, x, y, z, on a grid of 360 equal-area bands of the
/// polar angle times 720 longitudes (midpoints, each of the same area), and for the
/// peak-to-valley also at the centres of the flats and bumps and their opposite directions (a
/// feature may be narrower than the grid). For harmonics alone the rms equals
/// sqrt(sum over l >= 2 of a^2 / (2l + 1)) to the grid's accuracy.
struct FormSize {
  double rms_um = 0.0;
  double pv_um = 0.0;
};
FormSize FormSizeOf(const SimulatedEffects& effects, double sphere_radius_mm);

/// The rotation matrix of a rotation vector [deg] (axis times angle): p_theta = R * p_body.
Eigen::Matrix3d RotationOfVectorDeg(const Eigen::Vector3d& rotation_deg);

/// What to simulate. Defaults are the paper's study (Table 1 truth, R0 20 mm, d 25 mm,
/// 24 x 12 grid, centre (2, 0, 0) mm, noise on r 0.05 um).
struct SimulationSpec {
  ScmsGeometry truth = PaperTruth();  ///< internal units (rad, mm)
  double sphere_radius_mm = 20.0;     ///< R0
  double probe_offset_mm = 25.0;      ///< nominal d
  /// Sphere centre of each setup [mm]; setup ids are 0, 1, ... in this order.
  std::vector<Eigen::Vector3d> centers_mm{Eigen::Vector3d(2.0, 0.0, 0.0)};
  /// The sphere's orientation on its mount by setup id: the rotation vector [deg] (axis times
  /// angle) of R, p_theta = R * p_body about the sphere's centre. A setup without an entry holds
  /// the sphere in the reference orientation (R = I). Written into the points file's header.
  std::map<int, Eigen::Vector3d> mount_rotations_deg;
  /// Setups whose header says "mount_rotation_deg@<setup>: unknown" instead of the rotation
  /// they are simulated with.
  std::set<int> mount_unknown;
  /// Setups that measure another sphere, by setup id: its radius [mm]. That sphere is perfect (the
  /// form of `effects` is the reference sphere's); the header says "sphere_radius_mm@<setup>".
  std::map<int, double> sphere_radii_mm;
  std::vector<AnglePair> pattern = GridPattern(24, 12);  ///< measured at every setup
  ScanOrder scan_order = ScanOrder::kRings;              ///< the time order of the pattern in every setup ...
  std::map<int, ScanOrder> scan_orders;                  ///< ... but these (by setup id)
  double noise_r_um = 0.05;                              ///< sigma of Gaussian noise on r [um]
  double noise_theta_arcsec = 0.0;                       ///< sigma of the theta reading noise [arcsec]
  double noise_phi_arcsec = 0.0;                         ///< sigma of the phi reading noise [arcsec]
  std::uint64_t seed = 1;
  double sample_period_s = 1.0;  ///< t_s of row i is i * sample_period_s
  SimulatedEffects effects;      ///< none by default
  /// The probe's measuring range, readings 0 to it [mm]: when given, the probe's gain and
  /// nonlinearity are normalised by it (WithProbeRange()), a property of the probe; otherwise by
  /// the range of the readings, as a calibration without it normalises them.
  std::optional<double> probe_range_mm;

  /// Table 1 of the paper: alpha = beta = epsilon = 0.02 deg, a = b = c = 0.002 mm, d' = -0.062 mm.
  static ScmsGeometry PaperTruth();
};

/// The probe reading r [mm] at the true axis positions theta, phi [rad], or nothing when the probe
/// ray misses the sphere.
std::optional<double> ProbeReading(const ScmsGeometry& truth, double theta_rad, double phi_rad, double probe_offset_mm,
                                   const Eigen::Vector3d& center_mm, double sphere_radius_mm);

/// The true distance [mm] from the probe zero point to the sphere's surface along the probe ray,
/// for the axis readings theta_read, phi_read [rad], with the effects of `effects` except the probe's
/// own errors (gain, nonlinearity, drift), which act on the reading and not on the ray; `approach`:
/// the direction in which each axis came to its position, for the reversal terms. The
/// sphere's form is turned by `body_to_theta` (R) about its centre. Nothing when the ray misses
/// the sphere. `effects.model.reference` is not used here.
///
/// With a form, the hit is the root of g(s) = |x(s) - O| - rho(R^T (x(s) - O) / |x(s) - O|)
/// along the ray x(s), searched between the entry into the sphere of radius max rho (g >= 0) and
/// the entry into the sphere of radius min rho (g <= 0), from the bounds of the form, by regula
/// falsi (Illinois) with a bisection whenever a step shrinks the bracket by less than half: it
/// converges for any continuous rho, the kink at a flat's rim too, to 1e-14 mm.
std::optional<double> TrueProbeDistance(const ScmsGeometry& truth, const SimulatedEffects& effects, double theta_rad,
                                        double phi_rad, double probe_offset_mm, const Eigen::Vector3d& center_mm,
                                        double sphere_radius_mm,
                                        const Eigen::Matrix3d& body_to_theta = Eigen::Matrix3d::Identity(),
                                        double* sin2_incidence = nullptr, MotionDirection approach = {});

/// The reading r_read [mm] of a probe with the gain, nonlinearity, drift and incidence error of
/// `effects` (with the reference `effects.model.reference`) that sees the true distance
/// `distance_mm` at time t_s, its beam meeting the surface at sin^2 psi = sin2_incidence: the root
/// of r + gain(u) + nonlinearity(u) + drift + incidence = distance over the reference's readings
/// r_ref -+ r_half (u from -1 to 1), to a few units in the last place. Nothing when the distance
/// lies beyond what the probe reads there. Throws sph::Error when the distance the probe reports
/// does not rise with the reading over that range (a distance would have several readings).
std::optional<double> ProbeReadingOfDistance(const SimulatedEffects& effects, double distance_mm, double t_s,
                                             double sin2_incidence = 0.0);

/// Simulates a points file: for each setup, each pattern point in the setup's scan order (t_s of
/// row i is i * sample_period_s); the axes are at the commanded angles, the readings carry the
/// noise. The header holds the mount rotations (or "unknown") of the setups that have one.
/// Throws sph::Error when a ray misses the sphere, the spec is impossible, or the probe cannot read
/// the distances: its response (gain, nonlinearity) does not rise with the reading over its range
/// (probe_range_mm, else the readings' own), or a reading would lie outside probe_range_mm.
/// Equals AddReadingNoise(SimulateExact(spec), spec).
/// When `reference` is given, it receives the reference the probe terms were simulated with.
PointsData Simulate(const SimulationSpec& spec, EffectReference* reference = nullptr);

/// Simulate() without noise and outliers: the exact readings of the stated truth and effects.
PointsData SimulateExact(const SimulationSpec& spec, EffectReference* reference = nullptr);

/// Throws the sph::Error SimulateExact() would throw for the set-up of `spec` before it reads a
/// probe: the sphere, probe, centres, pattern or effects' values impossible, a form deeper than
/// the sphere, options of setups that do not exist, or a pattern point whose probe ray misses its
/// setup's sphere ("simulation: the probe ray misses the sphere at theta ... deg, phi ... deg
/// (setup 0)"). For simulators of the same machine that read the probe otherwise (sph::can).
void CheckSimulationSetup(const SimulationSpec& spec);

/// Adds Gaussian noise with the spec's sigmas to every reading, drawn from sph::Random(spec.seed)
/// (the same numbers with every compiler) in the order (r, theta, phi) per sample, so that a seed gives
/// the same noise whatever sigmas are zero; then the outliers of spec.effects, from a second generator
/// seeded from spec.seed.
void AddReadingNoise(PointsData& data, const SimulationSpec& spec);

/// The truth file (JSON, "format": "sph-truth") of the simulation of `spec` that made `data` with
/// `reference`: the seven errors, centres, setups, R0, d, noise, seed, effects, the form and the
/// outliers, each in its report unit (sph_simulate --truth).
std::string SimulationTruthJson(const SimulationSpec& spec, const EffectReference& reference, const PointsData& data);

}  // namespace sph

#endif  // SPH_SIMULATION_SIMULATE_HPP_
