#include "simulate_cmd.hpp"

#include <charconv>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "app_common.hpp"
#include "sph/core/atomic_file.hpp"
#include "sph/core/error.hpp"
#include "sph/core/simulate.hpp"
#include "sph/model/units.hpp"

namespace sph::apps {
namespace {

Eigen::Vector3d ParseCenter(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  for (std::string part; std::getline(ss, part, ',');) parts.push_back(part);
  if (parts.size() != 3 || text.back() == ',') throw Error("--center-mm '" + text + "': expected x,y,z in mm");
  Eigen::Vector3d c;
  for (int i = 0; i < 3; ++i) {
    const std::string& part = parts[static_cast<std::size_t>(i)];
    const auto [ptr, ec] = std::from_chars(part.data(), part.data() + part.size(), c(i));
    if (part.empty() || ec != std::errc() || ptr != part.data() + part.size()) {
      throw Error("--center-mm '" + text + "': '" + part + "' is not a number");
    }
  }
  return c;
}

std::vector<AnglePair> ReadAngles(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open for reading");
  std::vector<AnglePair> out;
  std::string line;
  long n = 0;
  while (std::getline(in, line)) {
    ++n;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream ls(line);
    AnglePair a;
    std::string extra;
    if (!(ls >> a.theta_deg)) {
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      throw Error(path + ":" + std::to_string(n) + ": expected 'theta_deg phi_deg'");
    }
    if (!(ls >> a.phi_deg) || (ls >> extra)) throw Error(path + ":" + std::to_string(n) + ": expected 'theta_deg phi_deg'");
    out.push_back(a);
  }
  if (out.empty()) throw Error(path + ": no angles");
  return out;
}

}  // namespace

void SetupSimulateApp(CLI::App& app, SimulateOptions& o) {
  app.description("Simulate the readings of an SCMS measuring a reference sphere, by intersecting the probe ray "
                  "with the sphere. Defaults are the paper's study (Table 1 truth, 24 x 12 grid, 2 mm eccentricity).");
  app.option_defaults()->always_capture_default();
  app.add_option("-o,--output", o.output_path, "Points file to write ('-' for stdout)");
  app.add_option("--truth", o.truth_path, "Also write the truth (JSON) to this file");
  app.add_option("--alpha-deg", o.alpha_deg, "True alpha [deg]");
  app.add_option("--a-mm", o.a_mm, "True a [mm]");
  app.add_option("--beta-deg", o.beta_deg, "True beta [deg]");
  app.add_option("--b-mm", o.b_mm, "True b [mm]");
  app.add_option("--epsilon-deg", o.epsilon_deg, "True epsilon [deg]");
  app.add_option("--c-mm", o.c_mm, "True c [mm]");
  app.add_option("--d-prime-mm", o.d_prime_mm, "True d' [mm]");
  app.add_option("--sphere-radius-mm", o.sphere_radius_mm, "Sphere radius R0 [mm]")->check(CLI::PositiveNumber);
  app.add_option("--probe-offset-mm", o.probe_offset_mm, "Nominal probe zero distance d [mm]")
      ->check(CLI::PositiveNumber);
  app.add_option("--center-mm", o.centers_mm, "Sphere centre x,y,z [mm]; repeat for several setups");
  app.add_option("--theta-steps", o.theta_steps, "Grid: theta positions per ring")->check(CLI::Range(1, 1000000));
  app.add_option("--phi-steps", o.phi_steps, "Grid: phi rings")->check(CLI::Range(1, 1000000));
  app.add_option("--angles", o.angles_path, "Explicit pattern instead of the grid: file of 'theta_deg phi_deg' lines");
  app.add_option("--noise-r-um", o.noise_r_um, "Sigma of the noise on r [um]")->check(CLI::NonNegativeNumber);
  app.add_option("--noise-theta-arcsec", o.noise_theta_arcsec, "Sigma of the noise on the theta reading [arcsec]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--noise-phi-arcsec", o.noise_phi_arcsec, "Sigma of the noise on the phi reading [arcsec]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--seed", o.seed, "Random seed");
  app.add_option("--sample-period-s", o.sample_period_s, "Time between samples [s]")->check(CLI::NonNegativeNumber);
}

int RunSimulate(const SimulateOptions& o, std::ostream& err) {
  try {
    SimulationSpec spec;
    spec.truth = {o.alpha_deg * kRadPerDeg, o.a_mm, o.beta_deg * kRadPerDeg, o.b_mm, o.epsilon_deg * kRadPerDeg,
                  o.c_mm, o.d_prime_mm};
    spec.sphere_radius_mm = o.sphere_radius_mm;
    spec.probe_offset_mm = o.probe_offset_mm;
    spec.centers_mm.clear();
    for (const auto& c : o.centers_mm) spec.centers_mm.push_back(ParseCenter(c));
    spec.pattern = o.angles_path.empty() ? GridPattern(o.theta_steps, o.phi_steps) : ReadAngles(o.angles_path);
    spec.noise_r_um = o.noise_r_um;
    spec.noise_theta_arcsec = o.noise_theta_arcsec;
    spec.noise_phi_arcsec = o.noise_phi_arcsec;
    spec.seed = o.seed;
    spec.sample_period_s = o.sample_period_s;
    PointsData data = Simulate(spec);
    data.header.metadata.emplace_back("generator", "sph_simulate " SPH_VERSION);
    data.header.metadata.emplace_back("seed", std::to_string(o.seed));

    if (!o.truth_path.empty()) {
      nlohmann::json t;
      t["format"] = "sph-truth";
      t["generator"] = "sph_simulate " SPH_VERSION;
      t["geometry"] = {{"alpha", {{"value", o.alpha_deg}, {"unit", "deg"}}},
                       {"a", {{"value", o.a_mm}, {"unit", "mm"}}},
                       {"beta", {{"value", o.beta_deg}, {"unit", "deg"}}},
                       {"b", {{"value", o.b_mm}, {"unit", "mm"}}},
                       {"epsilon", {{"value", o.epsilon_deg}, {"unit", "deg"}}},
                       {"c", {{"value", o.c_mm}, {"unit", "mm"}}},
                       {"d_prime", {{"value", o.d_prime_mm}, {"unit", "mm"}}}};
      nlohmann::json centers = nlohmann::json::array();
      for (const auto& c : spec.centers_mm) centers.push_back({c.x(), c.y(), c.z()});
      t["centers_mm"] = centers;
      t["sphere_radius_mm"] = o.sphere_radius_mm;
      t["probe_offset_mm"] = o.probe_offset_mm;
      t["noise"] = {{"r_um", o.noise_r_um}, {"theta_arcsec", o.noise_theta_arcsec}, {"phi_arcsec", o.noise_phi_arcsec}};
      t["seed"] = o.seed;
      t["n_points"] = data.samples.size();
      WriteFileAtomically(o.truth_path, [&](std::ostream& f) { f << t.dump(2) << "\n"; });
    }
    WritePointsFile(o.output_path, data);
    return kExitOk;
  } catch (const std::exception& e) {
    err << "sph_simulate: error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace sph::apps
