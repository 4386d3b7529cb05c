#include "app_common.hpp"

#include <algorithm>
#include <charconv>
#include <csignal>
#include <cstdint>
#include <limits>

#include <CLI/CLI.hpp>

#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"

namespace sph::apps {

using internal::Quoted;

CLI::Validator InRange(const ValidRange& range) {
  return CLI::Validator([range](std::string& text) { return RefusalOf(text, range); }, range.Text());
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

void AddDccOptions(CLI::App& app, std::string& dcc_path, std::string& settings_path) {
  CLI::Option* dcc = app.add_option(
      "--dcc", dcc_path,
      "Write a Digital Calibration Certificate (PTB's DCC 3.1.2, XML) to this file ('-' for stdout): the results "
      "in SI units with U; the administrative data from --dcc-settings and the points header (docs/dcc.md)");
  app.add_option("--dcc-settings", settings_path,
                 "The laboratory's settings of the certificate: `key: value` lines (laboratory, customer, persons, "
                 "identifier; docs/dcc.md); the points header's keys of the same names win")
      ->needs(dcc);
}

void AddConditionOptions(CLI::App& app, SphereConditions& conditions, const std::string& source) {
  for (const ConditionField& c : kConditionFields) {
    std::string name = std::string("--") + c.key;
    std::replace(name.begin(), name.end(), '_', '-');
    const ValidRange range{c.min, c.max, c.unit};
    app.add_option(name, conditions.*c.field, std::string(c.what) + " " + source + c.key + ")")->check(InRange(range));
  }
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
