// A simulation as sph_simulate's options state it (numbers and texts such as "theta_encoder.c2=10"
// or "1:0,0,90"): checked, each number in its range (sph/core/ranges.hpp), and turned into the
// library's SimulationSpec, so that the apps and a host program (the Python module) simulate the
// same machine from the same words. Messages name each setting as the option that sets it:
// "--form-flat-um '0,0,0,1': depth_um: must be > 0 and <= 1e+06 um, got 0".
#ifndef SPH_SIMULATION_SIMULATION_OPTIONS_HPP_
#define SPH_SIMULATION_SIMULATION_OPTIONS_HPP_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/io/points_file.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/core/valid_range.hpp"
#include "sph/model/effects.hpp"

namespace sph {

/// The simulated machine and measurement shared by sph_simulate, sph_montecarlo and sph_cansim:
/// the true errors, the sphere, the pattern and the noise (defaults: the paper's study).
struct MachineOptions {
  double alpha_deg = 0.02, a_mm = 0.002, beta_deg = 0.02, b_mm = 0.002;
  double epsilon_deg = 0.02, c_mm = 0.002, d_prime_mm = -0.062;
  double sphere_radius_mm = 20.0;
  double probe_offset_mm = 25.0;
  int theta_steps = 24;
  int phi_steps = 12;
  std::string angles_path;  ///< explicit pattern: "theta_deg phi_deg" per line
  double noise_r_um = 0.05;
  double noise_theta_arcsec = 0.0;
  double noise_phi_arcsec = 0.0;
};

/// The simulation spec of the options (centres and seed left at their defaults), each number in
/// its range ("--noise-r-um: must be >= 0 and <= 1000 um, got -1"). Reads the --angles file;
/// throws sph::Error on a bad one.
SimulationSpec ToSimulationSpec(const MachineOptions& o);

/// One number of a comma-separated option value: its name and its valid values.
struct Field {
  const char* name;
  ValidRange range;
};

/// "v1,v2,..." as the numbers `fields`, each in its range; `what` ("--form-flat-um '0.1,0,0,1'")
/// names the option and its value in messages, `expected` the layout ("depth_um,nx,ny,nz").
std::vector<double> ParseFields(const std::string& text, const std::string& what, const std::string& expected,
                                const std::vector<Field>& fields);

/// A form error of the sphere on its body frame, as options: harmonics "l,m,amplitude_um", flats
/// "depth_um,nx,ny,nz" and bumps "height_um,width_deg,nx,ny,nz", each.
struct FormOptions {
  std::vector<std::string> harmonics_um;
  std::vector<std::string> flats_um;
  std::vector<std::string> bumps_um;
};

/// The form of the options into `effects` (form, flats, bumps) of a sphere of radius
/// `sphere_radius_mm`; throws sph::Error naming the option and its value.
void AddForm(const FormOptions& o, double sphere_radius_mm, SimulatedEffects& effects);

/// "rx,ry,rz": a rotation vector [deg] (axis times angle), each component within
/// ranges::kMountRotationDeg; messages as ParseFields().
Eigen::Vector3d ParseRotationDeg(const std::string& text, const std::string& what, const std::string& expected);

/// Parses "x,y,z" (mm, each within ranges::kCenterMm); `what` names the option in the error.
Eigen::Vector3d ParseVector3(const std::string& text, const std::string& what);

/// Parses "id.param=value" into `effects` (value in arcsec for angle effects, um for length
/// effects, as `unit` says). Throws sph::Error naming the option (--effect-arcsec, --effect-um)
/// and the problem.
void AddEffectValue(const std::string& text, Quantity unit, SimulatedEffects& effects);

/// Everything sph_simulate simulates from (all its options but the files it writes).
struct SimulationOptions {
  MachineOptions machine;                        ///< truth, sphere, pattern, noise
  std::vector<std::string> centers_mm{"2,0,0"};  ///< "x,y,z" per setup
  std::uint64_t seed = 1;
  double sample_period_s = 1.0;
  /// Effects of the library, "id.param=value": angles in arcsec, lengths in um (e.g.
  /// "theta_encoder.c2=10", "probe_drift.t1=0.5"); the points file does not declare them.
  std::vector<std::string> effects_arcsec;
  std::vector<std::string> effects_um;
  /// The sphere's orientation on its mount, "SETUP:rx,ry,rz" (rotation vector, deg) each.
  std::vector<std::string> mount_rotations_deg;
  std::vector<std::string> mount_unknown;    ///< setup ids whose header says "unknown"
  std::vector<std::string> sphere_radii_mm;  ///< "SETUP:R": that setup measures another sphere
  FormOptions form;                          ///< the sphere's form error on its body frame
  std::vector<std::string> scan_orders;      ///< "ORDER" (every setup) or "SETUP:ORDER"
  double outlier_fraction = 0.0;
  double outlier_um = 0.0;
  double phi_wobble_pivot_mm = 0.0;  ///< where the Phi axis tilts about, along it [mm]
  /// The probe's measuring range (readings 0 to it) [mm], written into the header; empty: none.
  std::optional<double> probe_range_mm;
};

/// The simulation the options describe: the machine, the centres, the effects, the sphere's form
/// and mounts, and the outliers. Throws sph::Error naming the option and the problem.
SimulationSpec SimulationSpecOf(const SimulationOptions& o);

/// What sph_simulate writes: the points (their header with the generator "sph_simulate <version>",
/// the seed and the probe's range) and the truth file's JSON text (SimulationTruthJson()).
struct SimulationRun {
  PointsData points;
  std::string truth_json;
};

/// Simulate() of SimulationSpecOf(o). Throws sph::Error on bad options or an impossible simulation.
SimulationRun RunSimulation(const SimulationOptions& o);

}  // namespace sph

#endif  // SPH_SIMULATION_SIMULATION_OPTIONS_HPP_
