#include "sph/core/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <random>
#include <string>

#include <Eigen/Geometry>

#include "sph/core/error.hpp"
#include "sph/model/spherical_harmonics.hpp"
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

namespace {

// sum over the components of `term` on `axis` of value * basis(x), written out from the definition
// in sph/model/effects.hpp (deliberately not through the model header's own evaluation).
double TermValue(const EffectTerm& term, const std::vector<double>& values, int axis, double x) {
  double sum = 0.0;
  for (std::size_t i = 0; i < term.components.size(); ++i) {
    const EffectComponent& c = term.components[i];
    if (c.axis != axis) continue;
    const double basis = !term.info().harmonic ? std::pow(x, c.order)
                         : c.sine             ? std::sin(c.order * x)
                                              : std::cos(c.order * x);
    sum += values[i] * basis;
  }
  return sum;
}

double EffectValue(const SimulatedEffects& e, Effect which, int axis, double x) {
  double sum = 0.0;
  for (std::size_t i = 0; i < e.model.terms.size(); ++i) {
    if (e.model.terms[i].effect == which) sum += TermValue(e.model.terms[i], e.values[i], axis, x);
  }
  return sum;
}

// Form error [mm] of the sphere's surface in the direction u (unit, sphere frame).
double FormError(const std::vector<FormComponent>& form, const Eigen::Vector3d& u) {
  double sum = 0.0;
  const double lon = std::atan2(u.y(), u.x());
  for (const FormComponent& f : form) sum += f.amplitude_um * kMmPerUm * SchmidtHarmonic(f.l, f.m, lon, u.z());
  return sum;
}

// First intersection of the ray origin + s dir (unit) with the sphere |p - O| = radius.
std::optional<double> RaySphere(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, const Eigen::Vector3d& center,
                                double radius) {
  // |origin + s dir - O|^2 = R^2  ->  s^2 + 2 s dir.(origin - O) + |origin - O|^2 - R^2 = 0
  const Eigen::Vector3d w = origin - center;
  const double half_b = dir.dot(w);
  const double disc = half_b * half_b - (w.squaredNorm() - radius * radius);
  if (!(disc >= 0.0)) return std::nullopt;
  return -half_b - std::sqrt(disc);
}

}  // namespace

std::optional<double> TrueProbeDistance(const ScmsGeometry& g, const SimulatedEffects& e, double theta_rad,
                                        double phi_rad, double probe_offset_mm, const Eigen::Vector3d& center_mm,
                                        double sphere_radius_mm) {
  using Eigen::AngleAxisd;
  using Eigen::Translation3d;
  using Eigen::Vector3d;
  const double theta = theta_rad + EffectValue(e, Effect::kThetaEncoder, 0, theta_rad);
  const double phi = phi_rad + EffectValue(e, Effect::kPhiEncoder, 0, phi_rad);
  const Vector3d motion(EffectValue(e, Effect::kThetaRadialMotion, 0, theta_rad),
                        EffectValue(e, Effect::kThetaRadialMotion, 1, theta_rad),
                        EffectValue(e, Effect::kThetaAxialMotion, 0, theta_rad));
  const double wx = EffectValue(e, Effect::kPhiWobble, 0, phi_rad);
  const double wy = EffectValue(e, Effect::kPhiWobble, 1, phi_rad);
  const Eigen::Affine3d T_theta_phi = AngleAxisd(theta, Vector3d::UnitZ()) * Translation3d(-motion) *
                                      Translation3d(g[kA], 0.0, 0.0) *
                                      AngleAxisd(kPi / 2 + g[kAlpha], Vector3d::UnitX()) *
                                      AngleAxisd(wx, Vector3d::UnitX()) * AngleAxisd(wy, Vector3d::UnitY());
  const Eigen::Affine3d T_phi_probe = AngleAxisd(-phi, Vector3d::UnitZ()) * AngleAxisd(g[kBeta], Vector3d::UnitZ()) *
                                      Translation3d(0.0, 0.0, g[kB]) * Translation3d(g[kC], 0.0, 0.0) *
                                      AngleAxisd(kPi / 2 + g[kEpsilon], Vector3d::UnitX());
  const Eigen::Affine3d T_sphere_probe = T_theta_phi * T_phi_probe;
  const double zero_z = -(probe_offset_mm + g[kDPrime]);
  const Vector3d origin = T_sphere_probe * Vector3d(0.0, 0.0, zero_z);  // probe zero point
  const Vector3d dir = T_sphere_probe.linear() * Vector3d::UnitZ();      // unit: rotations only
  std::optional<double> s = RaySphere(origin, dir, center_mm, sphere_radius_mm);
  // A form error: intersect with the sphere whose radius is the surface radius in the direction
  // of the last hit, until the hit stops moving (the form error is smooth and tiny against R0).
  for (int it = 0; s && !e.form.empty() && it < 20; ++it) {
    const Vector3d u = (origin + *s * dir - center_mm).normalized();
    const std::optional<double> next = RaySphere(origin, dir, center_mm, sphere_radius_mm + FormError(e.form, u));
    if (!next) return std::nullopt;
    const bool settled = std::abs(*next - *s) < 1e-15;
    s = next;
    if (settled) break;
  }
  return s;
}

std::optional<double> ProbeReading(const ScmsGeometry& g, double theta_rad, double phi_rad, double probe_offset_mm,
                                   const Eigen::Vector3d& center_mm, double sphere_radius_mm) {
  return TrueProbeDistance(g, SimulatedEffects{}, theta_rad, phi_rad, probe_offset_mm, center_mm, sphere_radius_mm);
}

double ProbeReadingOfDistance(const SimulatedEffects& e, double distance_mm, double t_s) {
  const EffectReference& ref = e.model.reference;
  const double tau = (t_s - ref.t_start_s) / ref.t_span_s;
  const double drift = EffectValue(e, Effect::kProbeDrift, 0, tau);
  // r + error(r) = distance, error(r) = gain + nonlinearity in u(r) + drift: a contraction (the
  // errors change by far less than r does), so fixed-point iteration converges in a few steps.
  double r = distance_mm;
  for (int it = 0; it < 100; ++it) {
    const double u = (r - ref.r_ref_mm) / ref.r_half_range_mm;
    const double next = distance_mm - drift - EffectValue(e, Effect::kProbeGain, 0, u) -
                        EffectValue(e, Effect::kProbeNonlinearity, 0, u);
    const bool settled = next == r;
    r = next;
    if (settled) break;
  }
  return r;
}

PointsData SimulateExact(const SimulationSpec& spec, EffectReference* reference) {
  if (!(spec.sphere_radius_mm > 0.0)) throw Error("simulation: the sphere radius must be positive");
  if (!(spec.probe_offset_mm > 0.0)) throw Error("simulation: the probe offset must be positive");
  if (spec.centers_mm.empty()) throw Error("simulation: no sphere centre given");
  if (spec.pattern.empty()) throw Error("simulation: the measuring pattern is empty");
  if (spec.effects.values.size() != spec.effects.model.terms.size()) {
    throw Error("simulation: one block of values is needed for each effect");
  }
  for (std::size_t i = 0; i < spec.effects.values.size(); ++i) {
    if (static_cast<int>(spec.effects.values[i].size()) != spec.effects.model.terms[i].size()) {
      throw Error(std::string("simulation: effect ") + spec.effects.model.terms[i].info().id + " needs " +
                  std::to_string(spec.effects.model.terms[i].size()) + " values");
    }
  }
  PointsData data;
  data.source = "simulation";
  data.header.sphere_radius_mm = spec.sphere_radius_mm;
  data.header.probe_offset_mm = spec.probe_offset_mm;
  data.has_time = true;
  data.has_setup = spec.centers_mm.size() > 1;
  data.samples.reserve(spec.centers_mm.size() * spec.pattern.size());
  for (std::size_t k = 0; k < spec.centers_mm.size(); ++k) {
    for (const AnglePair& a : spec.pattern) {
      const auto r = TrueProbeDistance(spec.truth, spec.effects, a.theta_deg * kRadPerDeg, a.phi_deg * kRadPerDeg,
                                       spec.probe_offset_mm, spec.centers_mm[k], spec.sphere_radius_mm);
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
  // The probe's own errors act on the reading, normalised by the range and run of the readings
  // themselves, as a calibration normalises them: the reference and the readings are iterated to
  // their common fixed point (the errors are tiny against the range, so two or three steps do).
  SimulatedEffects effects = spec.effects;
  const std::vector<Sample> distances = data.samples;
  effects.model.reference = EffectReferenceOf(distances);
  for (int it = 0; it < 20; ++it) {
    for (std::size_t i = 0; i < distances.size(); ++i) {
      data.samples[i].r_mm = ProbeReadingOfDistance(effects, distances[i].r_mm, distances[i].t_s);
    }
    const EffectReference next = EffectReferenceOf(data.samples);
    const bool settled = next.r_ref_mm == effects.model.reference.r_ref_mm &&
                         next.r_half_range_mm == effects.model.reference.r_half_range_mm;
    effects.model.reference = next;
    if (settled) break;
  }
  if (reference) *reference = effects.model.reference;
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
  if (spec.effects.outlier_fraction > 0.0) {
    std::mt19937_64 gross(spec.seed ^ 0x6f75746c69657273ULL);  // its own stream: the noise above stays the same
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    for (Sample& s : data.samples) {
      const double pick = uniform(gross), sign = uniform(gross) < 0.5 ? -1.0 : 1.0;
      if (pick < spec.effects.outlier_fraction) s.r_mm += sign * spec.effects.outlier_um * kMmPerUm;
    }
  }
}

PointsData Simulate(const SimulationSpec& spec, EffectReference* reference) {
  PointsData data = SimulateExact(spec, reference);
  AddReadingNoise(data, spec);
  return data;
}

}  // namespace sph
