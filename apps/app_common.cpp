#include "app_common.hpp"

#include <algorithm>
#include <charconv>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <limits>

#include <CLI/CLI.hpp>

#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph::apps {
namespace {

using internal::Format;
using internal::Quoted;

// The parts of "a,b,c" (none for an empty text; "a," has two, the second empty).
std::vector<std::string> SplitCommas(const std::string& text) {
  std::vector<std::string> parts;
  if (text.empty()) return parts;
  std::size_t start = 0;
  for (std::size_t comma; (comma = text.find(',', start)) != std::string::npos; start = comma + 1) {
    parts.push_back(text.substr(start, comma - start));
  }
  parts.push_back(text.substr(start));
  return parts;
}

// A direction of three parsed values, refused when it has no length.
Eigen::Vector3d Direction(const std::vector<double>& v, std::size_t first, const std::string& what) {
  const Eigen::Vector3d d(v[first], v[first + 1], v[first + 2]);
  if (!(d.norm() > 0.0)) throw Error(what + ": the direction nx,ny,nz has no length");
  return d;
}

}  // namespace

CLI::Validator InRange(const ValidRange& range) {
  return CLI::Validator(
      [range](std::string& text) -> std::string {
        try {
          if (range.Contains(ParseNumber(text, "", ""))) return "";
        } catch (const Error&) {
        }
        return range.Refusal(text);
      },
      range.Text());
}

CLI::Option* AddSeedOption(CLI::App& app, std::uint64_t& seed, const std::string& help) {
  const CLI::Validator decimal(
      [](std::string& text) -> std::string {
        const std::size_t first = std::min(text.find_first_not_of('0'), text.empty() ? 0 : text.size() - 1);
        const std::string digits = text.substr(first);
        std::uint64_t value = 0;
        const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
        if (text.empty() || ec != std::errc() || end != digits.data() + digits.size()) {
          return "must be an integer from 0 to " + std::to_string(std::numeric_limits<std::uint64_t>::max()) +
                 ", got " + Quoted(text);
        }
        text = digits;  // CLI11 reads it with base 0
        return "";
      },
      "0 <= x <= 2^64 - 1");
  return app.add_option("--seed", seed, help)->transform(decimal);
}

void AddPlotTimeoutOption(CLI::App& app, double& timeout_s) {
  app.add_option("--plot-timeout-s", timeout_s,
                 "Time limit of each run of gnuplot [s]: a gnuplot still drawing then is stopped and the program fails")
      ->capture_default_str()
      ->check(InRange(ranges::kPlotTimeoutS));
}

void AddConditionOptions(CLI::App& app, SphereConditions& conditions, const std::string& source) {
  for (const ConditionField& c : kConditionFields) {
    std::string name = std::string("--") + c.key;
    std::replace(name.begin(), name.end(), '_', '-');
    const ValidRange range{c.min, c.max, c.unit};
    app.add_option(name, conditions.*c.field, std::string(c.what) + " " + source + c.key + ")")->check(InRange(range));
  }
}

std::vector<double> ParseFields(const std::string& text, const std::string& what, const std::string& expected,
                                const std::vector<Field>& fields) {
  const std::vector<std::string> parts = SplitCommas(text);
  if (parts.size() != fields.size() || text.back() == ',') throw Error(what + ": expected " + expected);
  std::vector<double> values;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const double v = ParseNumber(parts[i], fields[i].name, what + ": ");
    values.push_back(CheckedValue(v, fields[i].range, what + ": " + fields[i].name, parts[i]));
  }
  return values;
}

void AddFormOptions(CLI::App& app, FormOptions& o, const std::string& group) {
  app.add_option(
         "--form-um", o.harmonics_um,
         "Form error on the body frame: l,m,amplitude [um] of a Schmidt semi-normalised real spherical harmonic "
         "(|S_lm| <= 1, mean square 1/(2l+1); amplitude " +
             ranges::kEffectUm.Text() + "); repeatable")
      ->group(group);
  app.add_option("--form-flat-um", o.flats_um,
                 "A flat: depth,nx,ny,nz, the sphere cut by a plane at R0 - depth along the body direction n (depth " +
                     ranges::kFormDepthUm.Text() + "); repeatable")
      ->group(group);
  app.add_option("--form-bump-um", o.bumps_um,
                 "A Gaussian bump: height,width_deg,nx,ny,nz, of that height (" + ranges::kEffectUm.Text() +
                     ", negative: a dent) and angular standard deviation (" + ranges::kFormWidthDeg.Text() +
                     ") about the body direction n; repeatable")
      ->group(group);
}

void AddForm(const FormOptions& o, double sphere_radius_mm, SimulatedEffects& effects) {
  for (const std::string& f : o.harmonics_um) {
    const std::vector<std::string> parts = SplitCommas(f);
    FormComponent c;
    try {
      if (parts.size() != 3) throw Error("");
      c = {ParseInteger(parts[0], "l", ""), ParseInteger(parts[1], "m", ""), ParseNumber(parts[2], "amplitude_um", "")};
    } catch (const Error&) {
      c.l = -1;  // refused below
    }
    if (c.l < 0 || c.l > 20 || std::abs(c.m) > c.l) {
      throw Error("--form-um " + f + ": expected l,m,amplitude_um with 0 <= l <= 20 and |m| <= l");
    }
    CheckedValue(c.amplitude_um, ranges::kEffectUm, "--form-um " + f, Format("%g", c.amplitude_um));
    effects.form.push_back(c);
  }
  for (const std::string& text : o.flats_um) {
    const std::string what = "--form-flat-um " + Quoted(text);
    const std::vector<double> v = ParseFields(text, what, "depth_um,nx,ny,nz",
                                              {{"depth_um", ranges::kFormDepthUm},
                                               {"nx", ranges::kDirection},
                                               {"ny", ranges::kDirection},
                                               {"nz", ranges::kDirection}});
    if (!(v[0] * kMmPerUm < sphere_radius_mm))
      throw Error(what + ": the depth must be smaller than the sphere's radius");
    effects.flats.push_back({v[0], Direction(v, 1, what)});
  }
  for (const std::string& text : o.bumps_um) {
    const std::string what = "--form-bump-um " + Quoted(text);
    const std::vector<double> v = ParseFields(text, what, "height_um,width_deg,nx,ny,nz",
                                              {{"height_um", ranges::kEffectUm},
                                               {"width_deg", ranges::kFormWidthDeg},
                                               {"nx", ranges::kDirection},
                                               {"ny", ranges::kDirection},
                                               {"nz", ranges::kDirection}});
    effects.bumps.push_back({v[0], v[1], Direction(v, 2, what)});
  }
}

Eigen::Vector3d ParseRotationDeg(const std::string& text, const std::string& what, const std::string& expected) {
  const std::vector<double> v = ParseFields(
      text, what, expected,
      {{"rx", ranges::kMountRotationDeg}, {"ry", ranges::kMountRotationDeg}, {"rz", ranges::kMountRotationDeg}});
  return {v[0], v[1], v[2]};
}

Eigen::Vector3d ParseVector3(const std::string& text, const std::string& what) {
  const std::vector<std::string> parts = SplitCommas(text);
  if (parts.size() != 3 || text.back() == ',') throw Error(what + " " + Quoted(text) + ": expected x,y,z in mm");
  Eigen::Vector3d c;
  for (int i = 0; i < 3; ++i) {
    const std::string& part = parts[static_cast<std::size_t>(i)];
    c(i) =
        CheckedValue(ParseNumber(part, Quoted(text), what + " "), ranges::kCenterMm, what + " " + Quoted(text), part);
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
  using namespace ranges;
  add("--alpha-deg", o.alpha_deg, "True alpha [deg]")->check(InRange(ErrorRange(kAlpha)));
  add("--a-mm", o.a_mm, "True a [mm]")->check(InRange(ErrorRange(kA)));
  add("--beta-deg", o.beta_deg, "True beta [deg]")->check(InRange(ErrorRange(kBeta)));
  add("--b-mm", o.b_mm, "True b [mm]")->check(InRange(ErrorRange(kB)));
  add("--epsilon-deg", o.epsilon_deg, "True epsilon [deg]")->check(InRange(ErrorRange(kEpsilon)));
  add("--c-mm", o.c_mm, "True c [mm]")->check(InRange(ErrorRange(kC)));
  add("--d-prime-mm", o.d_prime_mm, "True d' [mm]; |d'| < d")->check(InRange(ErrorRange(kDPrime)));
  add("--sphere-radius-mm", o.sphere_radius_mm, "Sphere radius R0 [mm]")->check(InRange(kSphereRadiusMm));
  add("--probe-offset-mm", o.probe_offset_mm, "Nominal probe zero distance d [mm]")->check(InRange(kProbeOffsetMm));
  add("--theta-steps", o.theta_steps, "Grid: theta positions per ring (at most 10 million grid points)")
      ->check(CLI::Range(1, 1000000));
  add("--phi-steps", o.phi_steps, "Grid: phi rings")->check(CLI::Range(1, 1000000));
  add("--angles", o.angles_path, "Explicit pattern instead of the grid: file of 'theta_deg phi_deg' lines");
  add("--noise-r-um", o.noise_r_um, "Sigma of the noise on r [um]")->check(InRange(kNoiseUm));
  add("--noise-theta-arcsec", o.noise_theta_arcsec, "Sigma of the noise on the theta reading [arcsec]")
      ->check(InRange(kNoiseArcsec));
  add("--noise-phi-arcsec", o.noise_phi_arcsec, "Sigma of the noise on the phi reading [arcsec]")
      ->check(InRange(kNoiseArcsec));
}

SimulationSpec ToSimulationSpec(const MachineOptions& o) {
  SimulationSpec spec;
  spec.truth = {o.alpha_deg * kRadPerDeg,
                o.a_mm,
                o.beta_deg * kRadPerDeg,
                o.b_mm,
                o.epsilon_deg * kRadPerDeg,
                o.c_mm,
                o.d_prime_mm};
  spec.sphere_radius_mm = o.sphere_radius_mm;
  spec.probe_offset_mm = o.probe_offset_mm;
  if (!(std::abs(o.d_prime_mm) < o.probe_offset_mm)) {
    throw Error("--d-prime-mm " + Format("%g", o.d_prime_mm) +
                ": the error of the probe zero distance must be "
                "smaller than the distance itself (--probe-offset-mm " +
                Format("%g", o.probe_offset_mm) + ")");
  }
  if (o.angles_path.empty() && static_cast<long>(o.theta_steps) * o.phi_steps > kMaxPatternPoints) {
    throw Error("--theta-steps " + std::to_string(o.theta_steps) + " x --phi-steps " + std::to_string(o.phi_steps) +
                " is a grid of " + std::to_string(static_cast<long>(o.theta_steps) * o.phi_steps) +
                " points; at most " + std::to_string(kMaxPatternPoints) + " are simulated");
  }
  spec.pattern = o.angles_path.empty() ? GridPattern(o.theta_steps, o.phi_steps) : ReadAnglePattern(o.angles_path);
  spec.noise_r_um = o.noise_r_um;
  spec.noise_theta_arcsec = o.noise_theta_arcsec;
  spec.noise_phi_arcsec = o.noise_phi_arcsec;
  return spec;
}

int RunApp(int argc, char** argv, const char* name, const std::function<void(CLI::App&)>& setup,
           const std::function<int()>& run) {
  RemoveTempFilesOnSignals();
  std::signal(SIGPIPE, SIG_IGN);  // a closed pipe fails a write (EPIPE) as a full disk does
  const StandardOutput standard_output;
  CLI::App app;
  setup(app);
  app.footer("Manual: docs/apps/" + std::string(name) +
             ".md in sph's source tree (this help is the option reference).");
  app.set_version_flag("--version", std::string(name) + " " SPH_VERSION);
  int code = kExitOk;
  try {
    app.parse(argc, argv);
    code = run();
  } catch (const CLI::ParseError& e) {
    code = app.exit(e) == 0 ? kExitOk : kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << name << ": error: " << e.what() << "\n";
    code = kExitBadInput;
  }
  const std::string failed = FlushStandardOutput();
  if (!failed.empty()) {
    std::cerr << name << ": error: cannot write to standard output: " << failed << "\n";
    return code == kExitOk || code == kExitNotUsable ? kExitBadInput : code;
  }
  return code;
}

}  // namespace sph::apps
