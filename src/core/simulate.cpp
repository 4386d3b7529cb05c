#include "sph/core/simulate.hpp"

#include <cmath>
#include <random>
#include <string>

#include <Eigen/Geometry>

#include "sph/core/error.hpp"
#include "sph/model/units.hpp"

namespace sph {

ScmsGeometry SimulationSpec::PaperTruth() {
  ScmsGeometry g{};
  g[kAlpha] = 0.02 * kRadPerDeg;
  g[kA] = 0.002;
  g[kBeta] = 0.02 * kRadPerDeg;
  g[kB] = 0.002;
  g[kEpsilon] = 0.02 * kRadPerDeg;
  g[kC] = 0.002;
  g[kDPrime] = -0.062;
  return g;
}

std::vector<AnglePair> GridPattern(int theta_steps, int phi_steps) {
  std::vector<AnglePair> out;
  if (theta_steps <= 0 || phi_steps <= 0) return out;
  out.reserve(static_cast<std::size_t>(theta_steps) * static_cast<std::size_t>(phi_steps));
  for (int j = 0; j < phi_steps; ++j) {
    for (int i = 0; i < theta_steps; ++i) {
      out.push_back({360.0 * i / theta_steps, 180.0 * (j + 0.5) / phi_steps});
    }
  }
  return out;
}

std::optional<double> ProbeReading(const ScmsGeometry& g, double theta_rad, double phi_rad, double probe_offset_mm,
                                   const Eigen::Vector3d& center_mm, double sphere_radius_mm) {
  using Eigen::AngleAxisd;
  using Eigen::Translation3d;
  using Eigen::Vector3d;
  const Eigen::Affine3d T_theta_phi = AngleAxisd(theta_rad, Vector3d::UnitZ()) * Translation3d(g[kA], 0.0, 0.0) *
                                      AngleAxisd(kPi / 2 + g[kAlpha], Vector3d::UnitX());
  const Eigen::Affine3d T_phi_probe = AngleAxisd(-phi_rad, Vector3d::UnitZ()) * AngleAxisd(g[kBeta], Vector3d::UnitZ()) *
                                      Translation3d(0.0, 0.0, g[kB]) * Translation3d(g[kC], 0.0, 0.0) *
                                      AngleAxisd(kPi / 2 + g[kEpsilon], Vector3d::UnitX());
  const Eigen::Affine3d T_sphere_probe = T_theta_phi * T_phi_probe;
  const double zero_z = -(probe_offset_mm + g[kDPrime]);
  const Vector3d origin = T_sphere_probe * Vector3d(0.0, 0.0, zero_z);  // probe zero point
  const Vector3d dir = T_sphere_probe.linear() * Vector3d::UnitZ();      // unit: rotations only
  // |origin + s dir - O|^2 = R0^2  ->  s^2 + 2 s dir.(origin - O) + |origin - O|^2 - R0^2 = 0
  const Vector3d w = origin - center_mm;
  const double half_b = dir.dot(w);
  const double disc = half_b * half_b - (w.squaredNorm() - sphere_radius_mm * sphere_radius_mm);
  if (!(disc >= 0.0)) return std::nullopt;
  const double s = -half_b - std::sqrt(disc);  // first hit along the ray
  return s;
}

PointsData SimulateExact(const SimulationSpec& spec) {
  if (!(spec.sphere_radius_mm > 0.0)) throw Error("simulation: the sphere radius must be positive");
  if (!(spec.probe_offset_mm > 0.0)) throw Error("simulation: the probe offset must be positive");
  if (spec.centers_mm.empty()) throw Error("simulation: no sphere centre given");
  if (spec.pattern.empty()) throw Error("simulation: the measuring pattern is empty");
  PointsData data;
  data.source = "simulation";
  data.header.sphere_radius_mm = spec.sphere_radius_mm;
  data.header.probe_offset_mm = spec.probe_offset_mm;
  data.has_time = true;
  data.has_setup = spec.centers_mm.size() > 1;
  data.samples.reserve(spec.centers_mm.size() * spec.pattern.size());
  for (std::size_t k = 0; k < spec.centers_mm.size(); ++k) {
    for (const AnglePair& a : spec.pattern) {
      const auto r = ProbeReading(spec.truth, a.theta_deg * kRadPerDeg, a.phi_deg * kRadPerDeg, spec.probe_offset_mm,
                                  spec.centers_mm[k], spec.sphere_radius_mm);
      if (!r) {
        throw Error("simulation: the probe ray misses the sphere at theta " + std::to_string(a.theta_deg) +
                    " deg, phi " + std::to_string(a.phi_deg) + " deg (setup " + std::to_string(k) + ")");
      }
      Sample s;
      s.theta_deg = a.theta_deg;
      s.phi_deg = a.phi_deg;
      s.r_mm = *r;
      s.t_s = static_cast<double>(data.samples.size()) * spec.sample_period_s;
      s.setup = static_cast<int>(k);
      data.samples.push_back(s);
    }
  }
  return data;
}

void AddReadingNoise(PointsData& data, const SimulationSpec& spec) {
  std::mt19937_64 rng(spec.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double sigma_r_mm = spec.noise_r_um * kMmPerUm;
  const double sigma_theta_deg = spec.noise_theta_arcsec / 3600.0;
  const double sigma_phi_deg = spec.noise_phi_arcsec / 3600.0;
  for (Sample& s : data.samples) {
    const double n_r = gauss(rng), n_t = gauss(rng), n_p = gauss(rng);
    s.r_mm += sigma_r_mm * n_r;
    s.theta_deg += sigma_theta_deg * n_t;
    s.phi_deg += sigma_phi_deg * n_p;
  }
}

PointsData Simulate(const SimulationSpec& spec) {
  PointsData data = SimulateExact(spec);
  AddReadingNoise(data, spec);
  return data;
}

}  // namespace sph
