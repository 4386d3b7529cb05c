// sph_simulate: options, CLI set-up and the run function (unit-tested directly).
#ifndef SPH_APPS_SIMULATE_CMD_HPP_
#define SPH_APPS_SIMULATE_CMD_HPP_

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "cli_fwd.hpp"

#include "app_common.hpp"

namespace sph::apps {

struct SimulateOptions {
  std::string output_path = "-";
  std::string truth_path;                        ///< JSON truth file, empty: none
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
  std::vector<std::string> mount_unknown;  ///< setup ids whose header says "unknown"
  std::vector<std::string> sphere_radii_mm;  ///< "SETUP:R": that setup measures another sphere
  FormOptions form;                        ///< the sphere's form error on its body frame
  std::vector<std::string> scan_orders;  ///< "ORDER" (every setup) or "SETUP:ORDER"
  double outlier_fraction = 0.0;
  double outlier_um = 0.0;
  double phi_wobble_pivot_mm = 0.0;  ///< where the Phi axis tilts about, along it [mm]
  /// The probe's measuring range (readings 0 to it) [mm], written into the header; empty: none.
  std::optional<double> probe_range_mm;
};

/// Parses "id.param=value" into `effects` (value in arcsec for angle effects, um for length
/// effects, as `unit` says). Throws sph::Error naming the option and the problem.
void AddEffectValue(const std::string& text, Quantity unit, SimulatedEffects& effects);

void SetupSimulateApp(CLI::App& app, SimulateOptions& options);

/// Writes the points file (and truth file). Returns kExitOk or kExitBadInput.
int RunSimulate(const SimulateOptions& options, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_SIMULATE_CMD_HPP_
