#include "sph/simulation/simulate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "sph/core/error.hpp"
#include "sph/stats/gum.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"
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

std::vector<AnglePair> ReadAnglePattern(const std::string& path) {
  std::ifstream in = OpenInputFile(path);
  TextLines lines(in, path, "a file of angles");
  std::vector<AnglePair> out;
  std::string line;
  while (lines.Next(line)) {
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::vector<std::string> tokens;
    for (std::string token; fields >> token;) tokens.push_back(token);
    if (tokens.empty()) continue;
    AnglePair a;
    try {
      if (tokens.size() != 2) throw Error("");
      a = {ParseNumber(tokens[0], "theta_deg", ""), ParseNumber(tokens[1], "phi_deg", "")};
    } catch (const Error&) {
      throw Error(lines.Where() + "expected 'theta_deg phi_deg'");
    }
    if (static_cast<long>(out.size()) == kMaxPatternPoints) {
      throw Error(lines.Where() + "more than " + std::to_string(kMaxPatternPoints) + " pattern points");
    }
    out.push_back(a);
  }
  if (out.empty()) throw Error(path + ": no angles");
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
                         : c.sine              ? std::sin(c.order * x)
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

// First intersection of the ray origin + s dir (unit) with the sphere |p - O| = radius.
std::optional<double> RaySphere(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                const Eigen::Vector3d& center, double radius) {
  // |origin + s dir - O|^2 = R^2  ->  s^2 + 2 s dir.(origin - O) + |origin - O|^2 - R^2 = 0
  const Eigen::Vector3d w = origin - center;
  const double half_b = dir.dot(w);
  const double disc = half_b * half_b - (w.squaredNorm() - radius * radius);
  if (!(disc >= 0.0)) return std::nullopt;
  return -half_b - std::sqrt(disc);
}

// How far the surface can lie inside and outside the sphere of radius R0 [um]: |S_lm| <= 1 and a
// bump is at most its height; a flat's radius is at least R0 - depth.
std::pair<double, double> FormBounds(const SimulatedEffects& e) {
  double h = 0.0, depth = 0.0;
  for (const FormComponent& f : e.form) h += std::abs(f.amplitude_um);
  for (const FormBump& b : e.bumps) h += std::abs(b.height_um);
  for (const FormFlat& f : e.flats) depth = std::max(depth, f.depth_um);
  return {std::max(h, depth), h};
}

// The first hit of the ray origin + s dir (unit) with the surface of `e` turned by `body_to_theta`
// about `center`: the root of g(s) = |x - O| - rho(R^T (x - O) / |x - O|) between the entries into
// the spheres that bound the surface (TrueProbeDistance() in the header).
std::optional<double> RaySurface(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                 const Eigen::Vector3d& center, double sphere_radius_mm, const SimulatedEffects& e,
                                 const Eigen::Matrix3d& body_to_theta) {
  const auto [inside_um, outside_um] = FormBounds(e);
  constexpr double kMarginMm = 1e-6;  // keeps rounding inside the bracket
  const double r_lo = sphere_radius_mm - inside_um * kMmPerUm - kMarginMm;
  const double r_hi = sphere_radius_mm + outside_um * kMmPerUm + kMarginMm;
  const Eigen::Matrix3d theta_to_body = body_to_theta.transpose();
  const auto g = [&](double s) {
    const Eigen::Vector3d x = origin + s * dir - center;
    const double n = x.norm();
    return n - SurfaceRadius(e, sphere_radius_mm, theta_to_body * (x / n));
  };
  const std::optional<double> outer = RaySphere(origin, dir, center, r_hi);
  if (!outer) return std::nullopt;
  double a = *outer, fa = g(a);
  if (fa <= 0.0) return a;
  const std::optional<double> inner = RaySphere(origin, dir, center, r_lo);
  double b = inner ? *inner : -dir.dot(origin - center);  // else the point of the ray closest to O
  double fb = g(b);
  if (fb > 0.0) return std::nullopt;  // the ray passes the surface by
  if (fb == 0.0) return b;
  constexpr double kToleranceMm = 1e-14;
  int side = 0;         // which end moved last: +1 a, -1 b
  bool bisect = false;  // the last step shrank the bracket by less than half
  for (int it = 0; it < 400 && b - a > kToleranceMm; ++it) {
    const double width = b - a;
    double c = bisect ? 0.5 * (a + b) : (a * fb - b * fa) / (fb - fa);
    if (!(c > a && c < b)) c = 0.5 * (a + b);
    if (!(c > a && c < b)) break;  // a and b are neighbouring doubles
    const double fc = g(c);
    if (fc == 0.0) return c;
    if (fc > 0.0) {
      a = c;
      fa = fc;
      if (side == 1) fb *= 0.5;  // Illinois: the end that stays gets half its weight
      side = 1;
    } else {
      b = c;
      fb = fc;
      if (side == -1) fa *= 0.5;
      side = -1;
    }
    bisect = b - a > 0.5 * width;
  }
  return 0.5 * (a + b);
}

// A seed for the shuffled scan order of setup k, its own stream (the noise stays the same).
std::uint64_t ScanSeed(std::uint64_t seed, std::size_t k) {
  std::uint64_t z = seed ^ 0x7363616e6f726465ULL;  // "scanorde"
  z += 0x9E3779B97F4A7C15ULL * (static_cast<std::uint64_t>(k) + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;  // SplitMix64's finaliser
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

bool IsDirection(const Eigen::Vector3d& v) { return v.allFinite() && v.norm() > 0.0; }

// Throws when the form cannot be a sphere's surface.
void CheckForm(const SimulatedEffects& e, double sphere_radius_mm) {
  for (const FormComponent& f : e.form) {
    if (f.l < 0 || std::abs(f.m) > f.l || !std::isfinite(f.amplitude_um)) {
      throw Error(internal::Format("simulation: form harmonic l %d, m %d, %g um: needs 0 <= |m| <= l", f.l, f.m,
                                   f.amplitude_um));
    }
  }
  for (const FormFlat& f : e.flats) {
    if (!(f.depth_um > 0.0) || !(f.depth_um * kMmPerUm < sphere_radius_mm) || !IsDirection(f.normal_body)) {
      throw Error(
          internal::Format("simulation: a flat needs a depth between 0 and the radius (%g um) and a normal "
                           "direction, got depth %g um",
                           sphere_radius_mm * kUmPerMm, f.depth_um));
    }
  }
  for (const FormBump& b : e.bumps) {
    if (!std::isfinite(b.height_um) || !(b.width_deg > 0.0) || !std::isfinite(b.width_deg) ||
        !IsDirection(b.center_body)) {
      throw Error(
          internal::Format("simulation: a bump needs a finite height, a width > 0 and a centre direction, "
                           "got height %g um, width %g deg",
                           b.height_um, b.width_deg));
    }
  }
  const double inside_um = FormBounds(e).first;
  if (!(inside_um * kMmPerUm < sphere_radius_mm)) {
    throw Error(
        internal::Format("simulation: the form error (up to %g um into the sphere) must be smaller than the "
                         "sphere's radius (%g mm)",
                         inside_um, sphere_radius_mm));
  }
}

}  // namespace

const char* ScanOrderName(ScanOrder order) {
  switch (order) {
    case ScanOrder::kRings:
      return "rings";
    case ScanOrder::kReversed:
      return "reversed";
    case ScanOrder::kSerpentine:
      return "serpentine";
    case ScanOrder::kColumns:
      return "columns";
    case ScanOrder::kSerpentineColumns:
      return "serpentine-columns";
    case ScanOrder::kShuffled:
      return "shuffled";
  }
  return "?";
}

const char* ScanOrderNames() { return "rings reversed serpentine columns serpentine-columns shuffled"; }

bool ScanOrderFromName(std::string_view name, ScanOrder* order) {
  for (ScanOrder o : {ScanOrder::kRings, ScanOrder::kReversed, ScanOrder::kSerpentine, ScanOrder::kColumns,
                      ScanOrder::kSerpentineColumns, ScanOrder::kShuffled}) {
    if (name == ScanOrderName(o)) {
      *order = o;
      return true;
    }
  }
  return false;
}

std::vector<AnglePair> InScanOrder(const std::vector<AnglePair>& pattern, ScanOrder order, std::uint64_t seed) {
  std::vector<AnglePair> out;
  out.reserve(pattern.size());
  switch (order) {
    case ScanOrder::kRings:
      out = pattern;
      break;
    case ScanOrder::kReversed:
      out.assign(pattern.rbegin(), pattern.rend());
      break;
    case ScanOrder::kSerpentine: {
      bool backwards = false;
      for (std::size_t i = 0; i < pattern.size();) {
        std::size_t j = i;
        while (j < pattern.size() && pattern[j].phi_deg == pattern[i].phi_deg) ++j;
        if (backwards) {
          out.insert(out.end(), pattern.rbegin() + static_cast<std::ptrdiff_t>(pattern.size() - j),
                     pattern.rbegin() + static_cast<std::ptrdiff_t>(pattern.size() - i));
        } else {
          out.insert(out.end(), pattern.begin() + static_cast<std::ptrdiff_t>(i),
                     pattern.begin() + static_cast<std::ptrdiff_t>(j));
        }
        backwards = !backwards;
        i = j;
      }
      break;
    }
    case ScanOrder::kColumns:
    case ScanOrder::kSerpentineColumns: {
      std::map<double, std::size_t> column_of;  // theta -> its column, numbered in order of appearance
      std::vector<std::vector<AnglePair>> columns;
      for (const AnglePair& a : pattern) {
        const auto [it, added] = column_of.emplace(a.theta_deg, columns.size());
        if (added) columns.emplace_back();
        columns[it->second].push_back(a);
      }
      for (std::size_t k = 0; k < columns.size(); ++k) {
        if (order == ScanOrder::kSerpentineColumns && k % 2 == 1) {
          out.insert(out.end(), columns[k].rbegin(), columns[k].rend());
        } else {
          out.insert(out.end(), columns[k].begin(), columns[k].end());
        }
      }
      break;
    }
    case ScanOrder::kShuffled: {
      out = pattern;
      Random(seed).Shuffle(out);
      break;
    }
  }
  return out;
}

double FormHarmonic(int l, int m, const Eigen::Vector3d& u) {
  const Eigen::Vector3d v = u.normalized();
  const int am = std::abs(m);
  // sin^|m|(polar) * (cos, sin)(|m| lon) = (Re, Im) of (x + iy)^|m|
  double re = 1.0, im = 0.0;
  for (int k = 0; k < am; ++k) {
    const double next_re = re * v.x() - im * v.y();
    im = re * v.y() + im * v.x();
    re = next_re;
  }
  // Q_l^m = P~_l^m / sin^m, with P~ the Schmidt semi-normalised Legendre functions:
  // P~_1^1 = s, P~_m^m = sqrt((2m - 1) / 2m) s P~_(m-1)^(m-1) (m >= 2), P~_(m+1)^m = sqrt(2m + 1) z P~_m^m,
  // P~_l^m = ((2l - 1) z P~_(l-1)^m - sqrt((l - 1)^2 - m^2) P~_(l-2)^m) / sqrt(l^2 - m^2).
  double q_mm = 1.0;
  for (int k = 2; k <= am; ++k) q_mm *= std::sqrt((2.0 * k - 1.0) / (2.0 * k));
  double q = q_mm;
  if (l > am) {
    double prev = q_mm;
    q = std::sqrt(2.0 * am + 1.0) * v.z() * q_mm;
    for (int ll = am + 2; ll <= l; ++ll) {
      const double next = ((2.0 * ll - 1.0) * v.z() * q - std::sqrt((ll - 1.0) * (ll - 1.0) - 1.0 * am * am) * prev) /
                          std::sqrt(1.0 * ll * ll - 1.0 * am * am);
      prev = q;
      q = next;
    }
  }
  return q * (m >= 0 ? re : im);
}

double SurfaceRadius(const SimulatedEffects& e, double sphere_radius_mm, const Eigen::Vector3d& u) {
  double h_um = 0.0;
  for (const FormComponent& f : e.form) h_um += f.amplitude_um * FormHarmonic(f.l, f.m, u);
  for (const FormBump& b : e.bumps) {
    const Eigen::Vector3d c = b.center_body.normalized();
    const double angle = std::atan2(u.cross(c).norm(), u.dot(c));
    const double w = b.width_deg * kRadPerDeg;
    h_um += b.height_um * std::exp(-angle * angle / (2.0 * w * w));
  }
  double rho = sphere_radius_mm + h_um * kMmPerUm;
  for (const FormFlat& f : e.flats) {
    const double cos_n = u.dot(f.normal_body.normalized());
    if (cos_n > 0.0) rho = std::min(rho, (sphere_radius_mm - f.depth_um * kMmPerUm) / cos_n);
  }
  return rho;
}

FormSize FormSizeOf(const SimulatedEffects& e, double sphere_radius_mm) {
  constexpr int kBands = 360, kLongitudes = 720;
  std::vector<double> f;
  std::vector<Eigen::Vector3d> dirs;
  f.reserve(kBands * kLongitudes);
  dirs.reserve(kBands * kLongitudes);
  Eigen::Matrix4d normal = Eigen::Matrix4d::Zero();
  Eigen::Vector4d rhs = Eigen::Vector4d::Zero();
  for (int j = 0; j < kBands; ++j) {
    const double z = -1.0 + 2.0 * (j + 0.5) / kBands, s = std::sqrt(1.0 - z * z);
    for (int i = 0; i < kLongitudes; ++i) {
      const double lon = 2.0 * kPi * (i + 0.5) / kLongitudes;
      const Eigen::Vector3d u(s * std::cos(lon), s * std::sin(lon), z);
      const double v_um = (SurfaceRadius(e, sphere_radius_mm, u) - sphere_radius_mm) * kUmPerMm;
      const Eigen::Vector4d basis(1.0, u.x(), u.y(), u.z());
      normal += basis * basis.transpose();
      rhs += basis * v_um;
      f.push_back(v_um);
      dirs.push_back(u);
    }
  }
  const Eigen::Vector4d low = normal.ldlt().solve(rhs);  // the degree 0 and 1 parts
  const auto deviation = [&](double v_um, const Eigen::Vector3d& u) { return v_um - low(0) - low.tail<3>().dot(u); };
  double sum2 = 0.0, lo = 0.0, hi = 0.0;
  for (std::size_t k = 0; k < f.size(); ++k) {
    const double r = deviation(f[k], dirs[k]);
    sum2 += r * r;
    lo = k == 0 ? r : std::min(lo, r);
    hi = k == 0 ? r : std::max(hi, r);
  }
  // A flat or a bump may be narrower than the grid: their centres (and opposites) count for the peak-to-valley.
  std::vector<Eigen::Vector3d> extremes;
  for (const FormFlat& flat : e.flats) extremes.push_back(flat.normal_body.normalized());
  for (const FormBump& b : e.bumps) extremes.push_back(b.center_body.normalized());
  for (const Eigen::Vector3d& u : extremes) {
    for (const Eigen::Vector3d& v : {u, Eigen::Vector3d(-u)}) {
      const double r = deviation((SurfaceRadius(e, sphere_radius_mm, v) - sphere_radius_mm) * kUmPerMm, v);
      lo = std::min(lo, r);
      hi = std::max(hi, r);
    }
  }
  return {std::sqrt(sum2 / static_cast<double>(f.size())), hi - lo};
}

Eigen::Matrix3d RotationOfVectorDeg(const Eigen::Vector3d& rotation_deg) {
  const double angle_deg = rotation_deg.norm();
  if (!(angle_deg > 0.0)) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle_deg * kRadPerDeg, rotation_deg / angle_deg).toRotationMatrix();
}

std::optional<double> TrueProbeDistance(const ScmsGeometry& g, const SimulatedEffects& e, double theta_rad,
                                        double phi_rad, double probe_offset_mm, const Eigen::Vector3d& center_mm,
                                        double sphere_radius_mm, const Eigen::Matrix3d& body_to_theta,
                                        double* sin2_incidence, MotionDirection approach) {
  using Eigen::AngleAxisd;
  using Eigen::Translation3d;
  using Eigen::Vector3d;
  // Where the axes stand: off their readings by the encoder's error and half the reversal value
  // in the direction of approach.
  const double theta = theta_rad + EffectValue(e, Effect::kThetaEncoder, 0, theta_rad) +
                       0.5 * approach.theta * EffectValue(e, Effect::kThetaReversal, 0, 1.0);
  const double phi = phi_rad + EffectValue(e, Effect::kPhiEncoder, 0, phi_rad) +
                     0.5 * approach.phi * EffectValue(e, Effect::kPhiReversal, 0, 1.0);
  const Vector3d motion(EffectValue(e, Effect::kThetaRadialMotion, 0, theta_rad),
                        EffectValue(e, Effect::kThetaRadialMotion, 1, theta_rad),
                        EffectValue(e, Effect::kThetaAxialMotion, 0, theta_rad));
  const double wx = EffectValue(e, Effect::kPhiWobble, 0, phi_rad);
  const double wy = EffectValue(e, Effect::kPhiWobble, 1, phi_rad);
  const Vector3d pivot(0.0, 0.0, e.model.phi_wobble_pivot_mm);
  const Vector3d phi_motion(EffectValue(e, Effect::kPhiRadialMotion, 0, phi_rad),
                            EffectValue(e, Effect::kPhiRadialMotion, 1, phi_rad),
                            EffectValue(e, Effect::kPhiAxialMotion, 0, phi_rad));
  // The Theta spindle's rotor (and the sphere on it) in the machine frame: turned by -theta about
  // z, tilted by (tx, ty) about the machine x and y axes through the origin, displaced by `motion`.
  const double tx = EffectValue(e, Effect::kThetaTiltMotion, 0, theta_rad);
  const double ty = EffectValue(e, Effect::kThetaTiltMotion, 1, theta_rad);
  const Eigen::Affine3d machine_from_sphere(Translation3d(motion) * AngleAxisd(tx, Vector3d::UnitX()) *
                                            AngleAxisd(ty, Vector3d::UnitY()) * AngleAxisd(-theta, Vector3d::UnitZ()));
  // The Phi axis' rotor in its frame: tilted by (wx, wy) about the bearing at `pivot`, then displaced.
  const Eigen::Affine3d phi_rotor(Translation3d(phi_motion) * Translation3d(pivot) * AngleAxisd(wx, Vector3d::UnitX()) *
                                  AngleAxisd(wy, Vector3d::UnitY()) * Translation3d(-pivot));
  const Eigen::Affine3d T_theta_phi = machine_from_sphere.inverse(Eigen::Isometry) * Translation3d(g[kA], 0.0, 0.0) *
                                      AngleAxisd(kPi / 2 + g[kAlpha], Vector3d::UnitX()) * phi_rotor;
  const Eigen::Affine3d T_phi_probe = AngleAxisd(-phi, Vector3d::UnitZ()) * AngleAxisd(g[kBeta], Vector3d::UnitZ()) *
                                      Translation3d(0.0, 0.0, g[kB]) * Translation3d(g[kC], 0.0, 0.0) *
                                      AngleAxisd(kPi / 2 + g[kEpsilon], Vector3d::UnitX());
  const Eigen::Affine3d T_sphere_probe = T_theta_phi * T_phi_probe;
  const double zero_z = -(probe_offset_mm + g[kDPrime]);
  const Vector3d origin = T_sphere_probe * Vector3d(0.0, 0.0, zero_z);  // probe zero point
  const Vector3d dir = T_sphere_probe.linear() * Vector3d::UnitZ();     // unit: rotations only
  const std::optional<double> hit = e.HasForm() ? RaySurface(origin, dir, center_mm, sphere_radius_mm, e, body_to_theta)
                                                : RaySphere(origin, dir, center_mm, sphere_radius_mm);
  if (hit && sin2_incidence) {
    // The angle between the beam and the sphere's normal where it meets the surface (the form's
    // slope, micrometres over millimetres, left aside).
    const Vector3d normal = (origin + *hit * dir - center_mm).normalized();
    *sin2_incidence = dir.cross(normal).squaredNorm();
  }
  return hit;
}

std::optional<double> ProbeReading(const ScmsGeometry& g, double theta_rad, double phi_rad, double probe_offset_mm,
                                   const Eigen::Vector3d& center_mm, double sphere_radius_mm) {
  return TrueProbeDistance(g, SimulatedEffects{}, theta_rad, phi_rad, probe_offset_mm, center_mm, sphere_radius_mm);
}

namespace {

// The probe's reading error that depends on the reading, gain(u) + nonlinearity(u) = sum_k c[k] u^k
// (powers 1 to 3, the library's probe terms), and how the distance it reports moves with the reading.
struct ProbeResponse {
  std::array<double, 4> c{};  // c[k]: the coefficient of u^k [mm]
  bool none = true;           // no gain nor nonlinearity: the reading is the distance less the offsets

  explicit ProbeResponse(const SimulatedEffects& e) {
    for (std::size_t i = 0; i < e.model.terms.size(); ++i) {
      const EffectTerm& term = e.model.terms[i];
      if (term.effect != Effect::kProbeGain && term.effect != Effect::kProbeNonlinearity) continue;
      for (std::size_t j = 0; j < term.components.size(); ++j) {
        const int k = term.components[j].order;
        if (k < 1 || k > 3)
          throw Error("simulation: a probe term of power " + std::to_string(k) + " (1 to 3 are known)");
        c[static_cast<std::size_t>(k)] += e.values[i][j];
        none = false;
      }
    }
  }
  double ErrorAt(double u) const { return ((c[3] * u + c[2]) * u + c[1]) * u; }
  double Slope(double u) const { return (3.0 * c[3] * u + 2.0 * c[2]) * u + c[1]; }  // d Error / du
  // The least of d(distance)/d(reading) = 1 + Slope(u) / r_half over u in [-1, 1] (a quadratic in u:
  // its ends and its vertex), and where it is.
  double LeastGain(double r_half_mm, double* at_u) const {
    std::vector<double> us{-1.0, 1.0};
    if (c[3] != 0.0 && std::abs(c[2] / (3.0 * c[3])) < 1.0) us.push_back(-c[2] / (3.0 * c[3]));
    double least = std::numeric_limits<double>::infinity();
    for (double u : us) {
      const double g = 1.0 + Slope(u) / r_half_mm;
      if (g < least) least = g, *at_u = u;
    }
    return least;
  }
};

// The probe's terms that make its response, "probe_gain.u1 -600 um, probe_nonlinearity.u3 20 um".
std::string ResponseTerms(const ProbeResponse& p) {
  std::string out;
  for (std::size_t k = 1; k <= 3; ++k) {
    if (p.c[k] == 0.0) continue;
    out += (out.empty() ? "" : ", ") + std::string(k == 1 ? "probe_gain.u1" : "probe_nonlinearity.u") +
           (k == 1 ? "" : std::to_string(k)) + internal::Format(" %.6g um", p.c[k] * kUmPerMm);
  }
  return out;
}

// Throws unless the response of the probe of reference `ref` rises with the reading over the
// readings r_ref -+ r_half (`range`: what they are, for the message): else one distance has two
// readings there, and a reading would not tell the distance.
void CheckProbeResponseRises(const ProbeResponse& p, const EffectReference& ref, const std::string& range) {
  double u = 0.0;
  const double least = p.LeastGain(ref.r_half_range_mm, &u);
  if (least > 0.0) return;
  throw Error(
      internal::Format("simulation: with %s, the distance the probe reports does not rise with its reading "
                       "over %s: d(distance)/d(reading) is %.3g at r = %.6g mm, so one distance has several "
                       "readings; a probe's response rises over its range",
                       ResponseTerms(p).c_str(), range.c_str(), least, ref.r_ref_mm + u * ref.r_half_range_mm));
}

// The distance [mm] that the reading r_mm reports with the response p (without the offsets).
double ReportedDistance(const ProbeResponse& p, const EffectReference& ref, double r_mm) {
  return r_mm + p.ErrorAt((r_mm - ref.r_ref_mm) / ref.r_half_range_mm);
}

}  // namespace

std::optional<double> ProbeReadingOfDistance(const SimulatedEffects& e, double distance_mm, double t_s,
                                             double sin2_incidence) {
  const EffectReference& ref = e.model.reference;
  const double tau = (t_s - ref.t_start_s) / ref.t_span_s;
  // The errors that do not depend on the reading: the drift at t and the error at this incidence.
  const double offsets =
      EffectValue(e, Effect::kProbeDrift, 0, tau) + EffectValue(e, Effect::kProbeIncidence, 0, sin2_incidence);
  const double target = distance_mm - offsets;  // what the reading and its own error add up to
  const ProbeResponse p(e);
  double lo = ref.r_ref_mm - ref.r_half_range_mm, hi = ref.r_ref_mm + ref.r_half_range_mm;
  const double tolerance = 8.0 * std::numeric_limits<double>::epsilon() * std::max({1.0, std::abs(lo), std::abs(hi)});
  const double f_lo = ReportedDistance(p, ref, lo) - target, f_hi = ReportedDistance(p, ref, hi) - target;
  if (!(f_lo <= tolerance && f_hi >= -tolerance)) return std::nullopt;  // beyond the range, or not finite
  if (p.none) return target;
  CheckProbeResponseRises(p, ref, internal::Format("the readings %.6g to %.6g mm", lo, hi));
  if (f_lo >= 0.0) return lo;
  if (f_hi <= 0.0) return hi;
  // r + ErrorAt(u(r)) rises with r over the range: the reading is its one root there, bracketed by
  // the range's ends, found by Newton's method kept inside the bracket by bisection, to a few units
  // in the last place.
  double r = std::clamp(target, lo, hi);
  for (int it = 0; it < 200; ++it) {
    const double f = ReportedDistance(p, ref, r) - target;
    if (std::abs(f) <= tolerance) return r;
    (f < 0.0 ? lo : hi) = r;
    const double next = r - f / (1.0 + p.Slope((r - ref.r_ref_mm) / ref.r_half_range_mm) / ref.r_half_range_mm);
    r = next > lo && next < hi ? next : 0.5 * (lo + hi);
    if (!(hi - lo > tolerance)) return r;
  }
  throw Error(internal::Format("simulation: the probe reading of the distance %.9g mm did not converge", distance_mm));
}

namespace {

// Throws unless the sphere, the probe, the centres, the pattern and the effects' values can be simulated.
void CheckSpec(const SimulationSpec& spec) {
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
}

// Throws when a mount rotation, an unknown mount or a scan order is given for a setup that does not
// exist, or a mount rotation is not finite.
void CheckSetupOptions(const SimulationSpec& spec) {
  const int n_setups = static_cast<int>(spec.centers_mm.size());
  const auto check_setup = [&](int setup, const char* what) {
    if (setup < 0 || setup >= n_setups) {
      throw Error("simulation: " + std::string(what) + " is given for setup " + std::to_string(setup) + ", but the " +
                  std::to_string(n_setups) + " setup(s) are 0 to " + std::to_string(n_setups - 1));
    }
  };
  for (const auto& [setup, rotation] : spec.mount_rotations_deg) {
    check_setup(setup, "a mount rotation");
    if (!rotation.allFinite())
      throw Error("simulation: the mount rotation of setup " + std::to_string(setup) + " is not finite");
  }
  for (int setup : spec.mount_unknown) check_setup(setup, "an unknown mount rotation");
  for (const auto& [setup, radius_mm] : spec.sphere_radii_mm) {
    check_setup(setup, "another sphere");
    if (!(radius_mm > 0.0))
      throw Error("simulation: the radius of the sphere of setup " + std::to_string(setup) + " must be positive");
  }
  for (const auto& entry : spec.scan_orders) check_setup(entry.first, "a scan order");
}

// The header of the simulated points, before any sample.
PointsData EmptyPointsData(const SimulationSpec& spec) {
  PointsData data;
  data.source = "simulation";
  data.header.sphere_radius_mm = spec.sphere_radius_mm;
  data.header.probe_offset_mm = spec.probe_offset_mm;
  data.header.sphere_radii_mm = spec.sphere_radii_mm;
  data.has_time = true;
  data.has_setup = spec.centers_mm.size() > 1;
  data.samples.reserve(spec.centers_mm.size() * spec.pattern.size());
  return data;
}

// The rotation that takes the sphere's body frame into the frame turning with Theta in `setup`.
Eigen::Matrix3d BodyToTheta(const SimulationSpec& spec, int setup) {
  const auto rotation = spec.mount_rotations_deg.find(setup);
  return rotation == spec.mount_rotations_deg.end() ? Eigen::Matrix3d::Identity()
                                                    : RotationOfVectorDeg(rotation->second);
}

// Writes the mount rotation of `setup` into the header: unknown, known, or (without one) nothing.
void RecordMountRotation(const SimulationSpec& spec, int setup, PointsHeader& header) {
  const auto rotation = spec.mount_rotations_deg.find(setup);
  if (spec.mount_unknown.count(setup)) {
    header.mount_rotations[setup] = MountRotation::Unknown();
  } else if (rotation != spec.mount_rotations_deg.end()) {
    header.mount_rotations[setup] = MountRotation::Known(rotation->second);
  }
}

// The measuring pattern in the scan order of setup k.
std::vector<AnglePair> ScanOfSetup(const SimulationSpec& spec, std::size_t k) {
  const auto order = spec.scan_orders.find(static_cast<int>(k));
  return InScanOrder(spec.pattern, order == spec.scan_orders.end() ? spec.scan_order : order->second,
                     ScanSeed(spec.seed, k));
}

// The direction in which each axis comes to each position of `scan` (commanded positions, in time
// order): the sign of its move from the previous position, the shorter way round; standing, that of its last move;
// before its first move, that of the first; +1 for an axis that never moves.
std::vector<MotionDirection> ApproachOfScan(const std::vector<AnglePair>& scan) {
  std::vector<MotionDirection> out(scan.size());
  auto fill = [&](double AnglePair::*angle, int MotionDirection::*dir) {
    int last = 0;
    for (std::size_t i = 1; i < scan.size(); ++i) {
      const double move = std::remainder(scan[i].*angle - scan[i - 1].*angle, 360.0);  // the shorter way
      if (move != 0.0) last = move > 0.0 ? 1 : -1;
      out[i].*dir = last;
    }
    int first = 1;
    for (const MotionDirection& d : out) {
      if (d.*dir != 0) {
        first = d.*dir;
        break;
      }
    }
    for (std::size_t i = 0; i < scan.size() && out[i].*dir == 0; ++i) out[i].*dir = first;
  };
  fill(&AnglePair::theta_deg, &MotionDirection::theta);
  fill(&AnglePair::phi_deg, &MotionDirection::phi);
  return out;
}

// Appends the exact probe distances of setup k, in its scan order, to `data`, and the sin^2 of each
// beam's incidence on the surface to `sin2_incidence`; throws when a beam misses the sphere.
void AppendSetupDistances(const SimulationSpec& spec, std::size_t k, PointsData& data,
                          std::vector<double>& sin2_incidence) {
  const Eigen::Matrix3d body_to_theta = BodyToTheta(spec, static_cast<int>(k));
  const auto other = spec.sphere_radii_mm.find(static_cast<int>(k));
  const bool reference_sphere = other == spec.sphere_radii_mm.end();
  const double radius_mm = reference_sphere ? spec.sphere_radius_mm : other->second;
  SimulatedEffects effects = spec.effects;
  if (!reference_sphere) {  // another sphere: perfect
    effects.form.clear();
    effects.flats.clear();
    effects.bumps.clear();
  }
  const std::vector<AnglePair> scan = ScanOfSetup(spec, k);
  const std::vector<MotionDirection> approach = ApproachOfScan(scan);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const AnglePair& a = scan[i];
    double sin2 = 0.0;
    const auto r =
        TrueProbeDistance(spec.truth, effects, a.theta_deg * kRadPerDeg, a.phi_deg * kRadPerDeg, spec.probe_offset_mm,
                          spec.centers_mm[k], radius_mm, body_to_theta, &sin2, approach[i]);
    sin2_incidence.push_back(sin2);
    if (!r) {
      throw Error("simulation: the probe ray misses the sphere at theta " + std::to_string(a.theta_deg) + " deg, phi " +
                  std::to_string(a.phi_deg) + " deg (setup " + std::to_string(k) + ")");
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

// Sets each reading in `samples` to the probe's reading of the distance in `distances` under
// `effects`; throws, naming the first and counting them, when distances lie beyond what the probe
// reads over its reference's range (`range`: what that range is, in words).
void ReadDistances(const SimulatedEffects& effects, const std::vector<Sample>& distances,
                   const std::vector<double>& sin2_incidence, const std::string& range, std::vector<Sample>& samples) {
  std::size_t beyond = 0, first = 0;
  for (std::size_t i = 0; i < distances.size(); ++i) {
    const std::optional<double> r =
        ProbeReadingOfDistance(effects, distances[i].r_mm, distances[i].t_s, sin2_incidence[i]);
    if (r) {
      samples[i].r_mm = *r;
    } else if (beyond++ == 0) {
      first = i;
    }
  }
  if (beyond == 0) return;
  const Sample& s = distances[first];
  throw Error(
      internal::Format("simulation: %zu of %zu distances (the first: %.6g mm at theta %g deg, phi %g deg, "
                       "setup %d) lie beyond what the probe reads over %s: its readings would lie outside it",
                       beyond, distances.size(), s.r_mm, s.theta_deg, s.phi_deg, s.setup, range.c_str()));
}

// The readings with the probe's errors normalised by its range `probe_range_mm`; the reference's fit
// span is the readings' own.
void ReadWithProbeRange(double probe_range_mm, const std::vector<Sample>& distances,
                        const std::vector<double>& sin2_incidence, SimulatedEffects& effects,
                        std::vector<Sample>& samples) {
  effects.model.reference = WithProbeRange(effects.model.reference, probe_range_mm);
  const std::string range = internal::Format("its range 0 to %g mm (probe_range_mm)", probe_range_mm);
  CheckProbeResponseRises(ProbeResponse(effects), effects.model.reference, range);
  ReadDistances(effects, distances, sin2_incidence, range, samples);
  // The data's span as a calibration records it; the normalisation stays the probe's.
  const EffectReference of_readings = EffectReferenceOf(samples);
  effects.model.reference.r_fit_min_mm = of_readings.r_fit_min_mm;
  effects.model.reference.r_fit_max_mm = of_readings.r_fit_max_mm;
}

// The readings with the probe's errors normalised by the readings themselves. Where the response
// rises, the least and the greatest reading are those of the least and greatest y = distance -
// drift - incidence, at u = -1 and +1: y_lo = r_ref - r_half + E(-1), y_hi = r_ref + r_half + E(1),
// with E the reading's own error, which gives the reference; each reading is then solved on it.
void ReadOwnRange(const std::vector<Sample>& distances, const std::vector<double>& sin2_incidence,
                  SimulatedEffects& effects, std::vector<Sample>& samples) {
  EffectReference& ref = effects.model.reference;  // its times are the distances', which the readings keep
  double y_lo = std::numeric_limits<double>::infinity(), y_hi = -y_lo;
  for (std::size_t i = 0; i < distances.size(); ++i) {
    const double tau = (distances[i].t_s - ref.t_start_s) / ref.t_span_s;
    const double y = distances[i].r_mm - EffectValue(effects, Effect::kProbeDrift, 0, tau) -
                     EffectValue(effects, Effect::kProbeIncidence, 0, sin2_incidence[i]);
    y_lo = std::min(y_lo, y);
    y_hi = std::max(y_hi, y);
  }
  const ProbeResponse p(effects);
  if (y_hi > y_lo) {
    const double e_hi = p.ErrorAt(1.0), e_lo = p.ErrorAt(-1.0);
    ref.r_half_range_mm = 0.5 * ((y_hi - y_lo) - (e_hi - e_lo));
    ref.r_ref_mm = 0.5 * ((y_hi + y_lo) - (e_hi + e_lo));
    if (!(ref.r_half_range_mm > 0.0)) {
      throw Error(internal::Format(
          "simulation: %s at the ends of the readings exceed half the span of the distances the probe reads "
          "(%.6g mm): no readings normalised by their own range report these distances; state the probe's range "
          "(probe_range_mm)",
          ResponseTerms(p).c_str(), 0.5 * (y_hi - y_lo)));
    }
  } else {  // one distance: every reading is it (u = 0), the reference EffectReferenceOf()'s
    ref.r_ref_mm = y_lo;
    ref.r_half_range_mm = 1.0;
  }
  const std::string range = "the readings' own range";
  if (y_hi > y_lo) CheckProbeResponseRises(p, ref, range);
  ReadDistances(effects, distances, sin2_incidence, range, samples);
  const EffectReference of_readings = EffectReferenceOf(samples);
  constexpr double kRelative = 1e-9;  // the readings span the range they were solved on
  if (!(std::abs(of_readings.r_half_range_mm - ref.r_half_range_mm) <= kRelative * ref.r_half_range_mm &&
        std::abs(of_readings.r_ref_mm - ref.r_ref_mm) <= kRelative * std::max(1.0, std::abs(ref.r_ref_mm)))) {
    throw Error(
        internal::Format("simulation: the readings span %.12g to %.12g mm, not the %.12g -+ %.12g mm they "
                         "were solved on",
                         of_readings.FitMin(), of_readings.FitMax(), ref.r_ref_mm, ref.r_half_range_mm));
  }
  ref = of_readings;  // what a calibration computes from these readings
}

// Turns the exact distances in `data` into the probe's readings of them; returns the reference that
// normalises the probe's errors.
EffectReference ApplyProbeErrors(const SimulationSpec& spec, const std::vector<double>& sin2_incidence,
                                 PointsData& data) {
  // The probe's own errors act on the reading, normalised by the probe's range or by the range and
  // run of the readings themselves, as a calibration normalises them.
  SimulatedEffects effects = spec.effects;
  const std::vector<Sample> distances = data.samples;
  effects.model.reference = EffectReferenceOf(distances);
  if (spec.probe_range_mm) {
    ReadWithProbeRange(*spec.probe_range_mm, distances, sin2_incidence, effects, data.samples);
  } else {
    ReadOwnRange(distances, sin2_incidence, effects, data.samples);
  }
  return effects.model.reference;
}

}  // namespace

void CheckSimulationSetup(const SimulationSpec& spec) {
  CheckSpec(spec);
  CheckForm(spec.effects, spec.sphere_radius_mm);
  CheckSetupOptions(spec);
  PointsData data = EmptyPointsData(spec);
  std::vector<double> sin2_incidence;
  for (std::size_t k = 0; k < spec.centers_mm.size(); ++k) AppendSetupDistances(spec, k, data, sin2_incidence);
}

PointsData SimulateExact(const SimulationSpec& spec, EffectReference* reference) {
  CheckSpec(spec);
  CheckForm(spec.effects, spec.sphere_radius_mm);
  CheckSetupOptions(spec);
  PointsData data = EmptyPointsData(spec);
  std::vector<double> sin2_incidence;  // of each sample's beam against the surface
  for (std::size_t k = 0; k < spec.centers_mm.size(); ++k) {
    RecordMountRotation(spec, static_cast<int>(k), data.header);
    AppendSetupDistances(spec, k, data, sin2_incidence);
  }
  const EffectReference probe_reference = ApplyProbeErrors(spec, sin2_incidence, data);
  if (reference) *reference = probe_reference;
  return data;
}

void AddReadingNoise(PointsData& data, const SimulationSpec& spec) {
  Random rng(spec.seed);  // the same numbers with every standard library
  const double sigma_r_mm = spec.noise_r_um * kMmPerUm;
  const double sigma_theta_deg = spec.noise_theta_arcsec / 3600.0;
  const double sigma_phi_deg = spec.noise_phi_arcsec / 3600.0;
  // Three normals per reading, r, theta, phi, whether their sigma is zero or not, so that the
  // noise of r is the same with and without noise on the angles.
  auto add = [&rng](double sigma, double& value) {
    if (sigma == 0.0) {
      rng.SkipNormal();
    } else {
      value += sigma * rng.Normal();
    }
  };
  for (Sample& s : data.samples) {
    add(sigma_r_mm, s.r_mm);
    add(sigma_theta_deg, s.theta_deg);
    add(sigma_phi_deg, s.phi_deg);
  }
  if (spec.effects.outlier_fraction > 0.0) {
    Random gross(spec.seed ^ 0x6f75746c69657273ULL);  // its own stream: the noise above stays the same
    for (Sample& s : data.samples) {
      const double pick = gross.Uniform(), sign = gross.Uniform() < 0.5 ? -1.0 : 1.0;
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
