// sph_simulate: options, CLI set-up and the run function (unit-tested directly).
#ifndef SPH_APPS_SIMULATE_CMD_HPP_
#define SPH_APPS_SIMULATE_CMD_HPP_

#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace sph::apps {

struct SimulateOptions {
  std::string output_path = "-";
  std::string truth_path;                 ///< JSON truth file, empty: none
  double alpha_deg = 0.02, a_mm = 0.002, beta_deg = 0.02, b_mm = 0.002;
  double epsilon_deg = 0.02, c_mm = 0.002, d_prime_mm = -0.062;
  double sphere_radius_mm = 20.0;
  double probe_offset_mm = 25.0;
  std::vector<std::string> centers_mm{"2,0,0"};  ///< "x,y,z" per setup
  int theta_steps = 24;
  int phi_steps = 12;
  std::string angles_path;                ///< explicit pattern: "theta_deg phi_deg" per line
  double noise_r_um = 0.05;
  double noise_theta_arcsec = 0.0;
  double noise_phi_arcsec = 0.0;
  std::uint64_t seed = 1;
  double sample_period_s = 1.0;
};

void SetupSimulateApp(CLI::App& app, SimulateOptions& options);

/// Writes the points file (and truth file). Returns kExitOk or kExitBadInput.
int RunSimulate(const SimulateOptions& options, std::ostream& err);

}  // namespace sph::apps

#endif  // SPH_APPS_SIMULATE_CMD_HPP_
