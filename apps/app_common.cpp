#include "app_common.hpp"

#include <charconv>
#include <fstream>
#include <sstream>

#include "sph/core/error.hpp"
#include "sph/model/units.hpp"

namespace sph::apps {
namespace {

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
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream ls(line);
    AnglePair a;
    std::string extra;
    if (!(ls >> a.theta_deg >> a.phi_deg) || (ls >> extra) || !std::isfinite(a.theta_deg) || !std::isfinite(a.phi_deg)) {
      throw Error(path + ":" + std::to_string(n) + ": expected 'theta_deg phi_deg'");
    }
    out.push_back(a);
  }
  if (out.empty()) throw Error(path + ": no angles");
  return out;
}

}  // namespace

Eigen::Vector3d ParseVector3(const std::string& text, const std::string& what) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  for (std::string part; std::getline(ss, part, ',');) parts.push_back(part);
  if (parts.size() != 3 || text.back() == ',') throw Error(what + " '" + text + "': expected x,y,z in mm");
  Eigen::Vector3d c;
  for (int i = 0; i < 3; ++i) {
    const std::string& part = parts[static_cast<std::size_t>(i)];
    const auto [ptr, ec] = std::from_chars(part.data(), part.data() + part.size(), c(i));
    if (part.empty() || ec != std::errc() || ptr != part.data() + part.size()) {
      throw Error(what + " '" + text + "': '" + part + "' is not a number");
    }
  }
  return c;
}

void AddMachineOptions(CLI::App& app, MachineOptions& o, const std::string& group) {
  // Every option shows its default in --help and sits in `group` (CLI11's default group if empty).
  const auto add = [&](const char* name, auto& value, const char* help) {
    CLI::Option* opt = app.add_option(name, value, help)->capture_default_str();
    if (!group.empty()) opt->group(group);
    return opt;
  };
  add("--alpha-deg", o.alpha_deg, "True alpha [deg]");
  add("--a-mm", o.a_mm, "True a [mm]");
  add("--beta-deg", o.beta_deg, "True beta [deg]");
  add("--b-mm", o.b_mm, "True b [mm]");
  add("--epsilon-deg", o.epsilon_deg, "True epsilon [deg]");
  add("--c-mm", o.c_mm, "True c [mm]");
  add("--d-prime-mm", o.d_prime_mm, "True d' [mm]");
  add("--sphere-radius-mm", o.sphere_radius_mm, "Sphere radius R0 [mm]")->check(Positive());
  add("--probe-offset-mm", o.probe_offset_mm, "Nominal probe zero distance d [mm]")->check(Positive());
  add("--theta-steps", o.theta_steps, "Grid: theta positions per ring")->check(CLI::Range(1, 1000000));
  add("--phi-steps", o.phi_steps, "Grid: phi rings")->check(CLI::Range(1, 1000000));
  add("--angles", o.angles_path, "Explicit pattern instead of the grid: file of 'theta_deg phi_deg' lines");
  add("--noise-r-um", o.noise_r_um, "Sigma of the noise on r [um]")->check(NonNegative());
  add("--noise-theta-arcsec", o.noise_theta_arcsec, "Sigma of the noise on the theta reading [arcsec]")
      ->check(NonNegative());
  add("--noise-phi-arcsec", o.noise_phi_arcsec, "Sigma of the noise on the phi reading [arcsec]")
      ->check(NonNegative());
}

SimulationSpec ToSimulationSpec(const MachineOptions& o) {
  SimulationSpec spec;
  spec.truth = {o.alpha_deg * kRadPerDeg, o.a_mm, o.beta_deg * kRadPerDeg, o.b_mm, o.epsilon_deg * kRadPerDeg,
                o.c_mm, o.d_prime_mm};
  spec.sphere_radius_mm = o.sphere_radius_mm;
  spec.probe_offset_mm = o.probe_offset_mm;
  spec.pattern = o.angles_path.empty() ? GridPattern(o.theta_steps, o.phi_steps) : ReadAngles(o.angles_path);
  spec.noise_r_um = o.noise_r_um;
  spec.noise_theta_arcsec = o.noise_theta_arcsec;
  spec.noise_phi_arcsec = o.noise_phi_arcsec;
  return spec;
}

}  // namespace sph::apps
