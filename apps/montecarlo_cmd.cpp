#include "montecarlo_cmd.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include <CLI/CLI.hpp>

#include "gnuplot.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/calib/design.hpp"
#include "sph/calib/montecarlo.hpp"
#include "sph/core/error.hpp"
#include "sph/core/output_files.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph::apps {
namespace {

using internal::Format;
using nlohmann::json;

// The paper's Table 3 (um), printed beside the reproduction for comparison.
constexpr double kPaperBeforeUm[10] = {1.786, 1.796, 1.811, 1.828, 1.842, 2.641, 3.097, 3.256, 3.306, 3.528};
constexpr double kPaperAfterUm[10] = {0.00529, 0.00541, 0.00541, 0.00558, 0.00606,
                                      0.01656, 0.02519, 0.02927, 0.03838, 0.04541};

MonteCarloStudyOptions ToSpec(const MonteCarloAppOptions& o) {
  MonteCarloStudyOptions spec;
  spec.base = ToSimulationSpec(o.machine);
  spec.eccentricities_mm = o.eccentricities_mm;
  spec.direction = ParseVector3(o.direction, "--direction");
  if (!o.random_direction && !(spec.direction.norm() > 0.0)) throw Error("--direction must not be zero");
  spec.random_direction = o.random_direction;
  spec.setups = o.setups;
  spec.trials = o.trials;
  spec.seed = o.seed;
  spec.threads = o.threads;
  spec.max_std_um = o.max_std_um;
  for (double e : spec.eccentricities_mm) {
    if (!(e >= 0.0) || !(e < o.machine.sphere_radius_mm)) {
      throw Error("--eccentricities-mm: " + Format("%g", e) + " is not in [0, R0)");
    }
  }
  const auto& es = spec.eccentricities_mm;
  if (o.table3 && !o.plan && !o.plan_orientations &&
      std::find(es.begin(), es.end(), o.table3_calibration_e_mm) == es.end()) {
    std::string list;
    for (double e : es) list += (list.empty() ? "" : ", ") + Format("%g", e);
    throw Error("--table3-calibration-e-mm " + Format("%g", o.table3_calibration_e_mm) +
                ": Table 3 uses the study's calibrations at one of the eccentricities studied (--eccentricities-mm " +
                list + "); choose one of them, add it to the study, or leave Table 3 out (--no-table3)");
  }
  return spec;
}

class ProgressBar {
 public:
  ProgressBar(std::ostream& err, bool enabled) : err_(err), enabled_(enabled && ::isatty(STDERR_FILENO) == 1) {}
  void operator()(long done, long total) {
    if (!enabled_) return;
    const int width = 40;
    const int filled = static_cast<int>(width * done / total);
    err_ << "\rsph_montecarlo: [" << std::string(static_cast<std::size_t>(filled), '#')
         << std::string(static_cast<std::size_t>(width - filled), '.') << "] " << (100 * done / total) << "% (" << done
         << "/" << total << ")" << (done == total ? "\n" : "") << std::flush;
  }

 private:
  std::ostream& err_;
  bool enabled_;
};

// `value` in the printf format `fmt` (one conversion, with its width), or "-" in that width when it
// is not a number (a statistic of fewer than two trials).
std::string Number(const char* fmt, double value) {
  if (!std::isnan(value)) return Format(fmt, value);
  const std::string blank = Format(fmt, 0.0);
  return std::string(blank.size() - 1, ' ') + "-";
}

// "undetermined (...): b (CRLB 18.8 um as a displacement), ...", a line below a table that names
// the parameters (index, std as a displacement [um]) whose predicted std exceeds max_std_um.
void WriteUndetermined(std::ostream& out, const std::vector<std::pair<int, double>>& undetermined, double max_std_um,
                       const char* what) {
  if (undetermined.empty()) return;
  std::string list;
  for (const auto& [p, um] : undetermined) {
    list += (list.empty() ? "" : ", ") + std::string(kScmsParamInfo[static_cast<std::size_t>(p)].name) + " (" + what +
            " " + (std::isfinite(um) ? Format("%.3g", um) + " um as a displacement" : std::string("infinite")) + ")";
  }
  out << "undetermined: " << list << "; a parameter counts as determined when its predicted std, as a displacement "
      << "of the probed point (angles times R0), is at most " << Format("%g", max_std_um)
      << " um (--max-std-um), as sph_calibrate judges a calibration\n";
}

void PrintTable2(std::ostream& out, const MonteCarloStudy& r, const MonteCarloAppOptions& o) {
  out << "Table 2: mean of the calibrations (" << o.trials << " trials per eccentricity, seed " << o.seed
      << ", sigma_r " << o.machine.noise_r_um << " um)\n";
  out << Format("%-9s %-4s %12s", "param", "unit", "true");
  for (const auto& row : r.rows) out << Format("%12s", Format("e=%g mm", row.eccentricity_mm).c_str());
  out << "\n";
  for (int p = 0; p < kNumScmsParams; ++p) {
    const ReportUnits u = ReportUnitsOf(p);
    out << Format("%-9s", kScmsParamInfo[static_cast<std::size_t>(p)].name) << Format(" %-4s", u.coarse)
        << Format(" %12.6f", r.rows.front().params[static_cast<std::size_t>(p)].truth * u.to_coarse);
    for (const auto& row : r.rows) out << Number(" %11.6f", row.params[static_cast<std::size_t>(p)].mean * u.to_coarse);
    out << "\n";
  }
  for (const auto& row : r.rows) {
    out << "\ne = " << row.eccentricity_mm << " mm: " << row.converged << " of " << row.trials << " converged";
    if (!row.not_converged.empty()) {
      // Named, never silently dropped: the statistics below are of the converged trials only.
      out << "; left out of every statistic below: trial";
      for (std::size_t i = 0; i < row.not_converged.size() && i < 10; ++i) {
        out << (i == 0 ? " " : ", ") << row.not_converged[i] + 1;
      }
      if (row.not_converged.size() > 10) out << " and " << row.not_converged.size() - 10 << " more";
    }
    out << "\n";
    if (o.random_direction) {
      out << "(random directions: each trial has its own Cramer-Rao bound CRLB_t; CRLB is their root mean square, "
             "std/CRLB the std of (estimate - true) / CRLB_t, bias2 the mean of the trials' second-order biases)\n";
    }
    out << Format("%-9s %14s %14s %10s %9s %9s %12s %9s %9s %9s\n", "param", "true", "mean", "std", "SE", "(m-t)/SE",
                  "CRLB", "std/CRLB", "bias2", "(m-t-b)/SE");
    for (int p = 0; p < kNumScmsParams; ++p) {
      const ReportUnits u = ReportUnitsOf(p);
      const ParameterStats& s = row.params[static_cast<std::size_t>(p)];
      out << Format("%-9s", kScmsParamInfo[static_cast<std::size_t>(p)].name)
          << Format(" %10.6f ", s.truth * u.to_coarse) << Format("%-3s", u.coarse)
          << Number(" %10.6f", s.mean * u.to_coarse) << " " << Format("%-3s", u.coarse)
          << Number(" %10.4f", s.std * u.to_fine) << Number(" %9.4f", s.se * u.to_fine) << Number(" %9.2f", s.z);
      out << (s.determined ? Number(" %12.4f", s.crlb * u.to_fine) : Format(" %12s", "undetermined"))
          << Number(" %9.3f", s.std_over_crlb) << Number(" %9.4f", s.bias * u.to_fine) << Number(" %9.2f", s.z_bias);
      out << "  " << u.fine << "\n";
    }
    std::vector<std::pair<int, double>> undetermined;
    for (int p = 0; p < kNumScmsParams; ++p) {
      const ParameterStats& s = row.params[static_cast<std::size_t>(p)];
      if (!s.determined) undetermined.emplace_back(p, s.crlb_displacement_um);
    }
    WriteUndetermined(out, undetermined, o.max_std_um, "CRLB");
  }
}

json NumberOrNull(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json StudyJson(const MonteCarloStudy& r) {
  json rows = json::array();
  for (const auto& row : r.rows) {
    json params = json::object();
    json undetermined = json::array();
    for (int p = 0; p < kNumScmsParams; ++p) {
      const ReportUnits u = ReportUnitsOf(p);
      const ParameterStats& s = row.params[static_cast<std::size_t>(p)];
      params[kScmsParamInfo[static_cast<std::size_t>(p)].name] = {
          {"unit", u.coarse},
          {"true", s.truth * u.to_coarse},
          {"mean", s.mean * u.to_coarse},
          {"std", s.std * u.to_coarse},
          {"se", s.se * u.to_coarse},
          {"z", s.z},
          {"crlb", NumberOrNull(s.crlb * u.to_coarse)},
          {"crlb_displacement_um", NumberOrNull(s.crlb_displacement_um)},
          {"determined", s.determined},
          {"std_over_crlb", NumberOrNull(s.std_over_crlb)},
          {"bias_second_order", NumberOrNull(s.bias * u.to_coarse)},
          {"z_after_bias", NumberOrNull(s.z_bias)}};
      if (!s.determined) undetermined.push_back(kScmsParamInfo[static_cast<std::size_t>(p)].name);
    }
    json not_converged = json::array();
    for (int t : row.not_converged) not_converged.push_back(t + 1);
    rows.push_back({{"eccentricity_mm", row.eccentricity_mm},
                    {"trials", row.trials},
                    {"converged", row.converged},
                    {"not_converged_trials", not_converged},
                    {"undetermined", undetermined},
                    {"parameters", params}});
  }
  return rows;
}

void WriteCsv(const std::string& path, const MonteCarloStudy& r, OutputFiles& files) {
  files.Stage(path, [&](std::ostream& f) {
    f << "eccentricity_mm,parameter,unit,true,mean,std,se,z,crlb,std_over_crlb,converged,trials,determined\n";
    // A number that is not finite is an empty field.
    const auto field = [](double v) { return std::isfinite(v) ? Format("%.17g", v) : std::string(); };
    for (const auto& row : r.rows) {
      for (int p = 0; p < kNumScmsParams; ++p) {
        const ReportUnits u = ReportUnitsOf(p);
        const ParameterStats& s = row.params[static_cast<std::size_t>(p)];
        f << row.eccentricity_mm << "," << kScmsParamInfo[static_cast<std::size_t>(p)].name << "," << u.coarse << ","
          << s.truth * u.to_coarse << "," << s.mean * u.to_coarse << "," << s.std * u.to_coarse << ","
          << s.se * u.to_coarse << "," << s.z << "," << field(s.crlb * u.to_coarse) << "," << field(s.std_over_crlb)
          << "," << row.converged << "," << row.trials << "," << (s.determined ? 1 : 0) << "\n";
      }
    }
  });
}

// Table 3: ten spheres whose nominal-model sphericity is the paper's "before" value.
json Table3(std::ostream& out, const MonteCarloStudyOptions& spec, const MonteCarloStudy& r,
            const MonteCarloAppOptions& o) {
  const std::vector<double> targets(std::begin(kPaperBeforeUm), std::end(kPaperBeforeUm));
  const std::vector<SphericityRow> rows = SphericityStudy(spec, r, targets, o.table3_calibration_e_mm);
  out << "\nTable 3: least-squares sphericity (um) of ten spheres, exact readings, evaluated with the nominal "
         "errors (before) and with the errors calibrated at "
      << o.table3_calibration_e_mm << " mm (after): one calibration (sigma_r " << o.machine.noise_r_um << " um, seed "
      << o.seed << "), the median over the study's calibrations there, and their mean\n"
      << "The paper does not give the spheres' centres: each eccentricity (along the study's direction) is the one "
         "whose 'before' value is the paper's.\n";
  out << Format("%-3s %9s %9s %9s %11s %12s %11s %11s\n", "#", "e_mm", "before", "paper", "after_one", "after_median",
                "after_mean", "paper_after");
  json j = json::array();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const SphericityRow& w = rows[i];
    out << Format("%-3d", static_cast<int>(i) + 1) << Format(" %9.4f", w.eccentricity_mm)
        << Format(" %9.3f", w.before_um) << Format(" %9.3f", kPaperBeforeUm[i]) << Format(" %11.5f", w.after_one_um)
        << Format(" %12.5f", w.after_median_um) << Format(" %11.5f", w.after_mean_um)
        << Format(" %11.5f", kPaperAfterUm[i]) << "\n";
    auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
    j.push_back({{"sphere", i + 1},
                 {"eccentricity_mm", num(w.eccentricity_mm)},
                 {"before_um", num(w.before_um)},
                 {"paper_before_um", kPaperBeforeUm[i]},
                 {"after_one_calibration_um", num(w.after_one_um)},
                 {"after_median_um", num(w.after_median_um)},
                 {"after_mean_um", num(w.after_mean_um)},
                 {"paper_after_um", kPaperAfterUm[i]}});
  }
  return {{"calibration_eccentricity_mm", o.table3_calibration_e_mm}, {"rows", j}};
}

// Figure 4: std against eccentricity with the Cramer-Rao curve, and the spread of the estimates:
// the data, the script and the three images, staged in the folder `dir` (PlotFolder::Make()).
void Plot(const std::string& dir, const MonteCarloStudyOptions& spec, const MonteCarloStudy& r, double timeout_s,
          OutputFiles& files) {
  const std::string folder = dir + "/";
  const double e_min = r.rows.front().eccentricity_mm, e_max = r.rows.back().eccentricity_mm;
  files.Stage(folder + "fig4_std.dat", [&](std::ostream& f) {
    f << "# eccentricity_mm b_um c_um beta_urad epsilon_urad (Monte Carlo std)\n";
    for (const auto& row : r.rows) {
      f << row.eccentricity_mm << " " << row.params[kB].std * kUmPerMm << " " << row.params[kC].std * kUmPerMm << " "
        << row.params[kBeta].std * kUradPerRad << " " << row.params[kEpsilon].std * kUradPerRad << "\n";
    }
  });
  files.Stage(folder + "fig4_crlb.dat", [&](std::ostream& f) {
    f << "# eccentricity_mm b_um c_um beta_urad epsilon_urad (Cramer-Rao std)\n";
    const double lo = std::max(0.8 * std::min(e_min, e_max), 0.05), hi = 1.1 * std::max(e_min, e_max);
    for (int i = 0; i <= 60; ++i) {
      const double e = lo * std::pow(hi / lo, i / 60.0);
      SimulationSpec s = spec.base;
      s.centers_mm = PlacementCenters(spec, e);
      const PredictedUncertainty u = PredictUncertainty(s);
      f << e << " " << u.std(kB) * kUmPerMm << " " << u.std(kC) * kUmPerMm << " " << u.std(kBeta) * kUradPerRad << " "
        << u.std(kEpsilon) * kUradPerRad << "\n";
    }
  });
  files.Stage(folder + "fig4_spread.dat", [&](std::ostream& f) {
    f << "# eccentricity_mm b_error_um c_error_um (estimate minus truth, every converged trial)\n";
    for (const auto& row : r.rows) {
      for (const auto& g : row.estimates) {
        f << row.eccentricity_mm << " " << (g[kB] - spec.base.truth[kB]) * kUmPerMm << " "
          << (g[kC] - spec.base.truth[kC]) * kUmPerMm << "\n";
      }
    }
  });
  const std::string title = Format("%d trials per point, sigma_r %g um", spec.trials, spec.base.noise_r_um);
  std::string xtics;
  for (const auto& row : r.rows) xtics += (xtics.empty() ? "" : ", ") + Format("%g", row.eccentricity_mm);
  std::ostringstream script;
  script << "# Figure 4 of the study; rerun with: gnuplot fig4.gp (in this folder)\n";
  for (const char* name : {"std", "crlb", "spread"}) {
    script << "if (!exists(\"" << name << "_dat\")) " << name << "_dat = 'fig4_" << name << ".dat'\n";
  }
  for (const char* name : {"b_c_std", "beta_epsilon_std", "spread"}) {
    script << "if (!exists(\"" << name << "_png\")) " << name << "_png = 'fig4_" << name << ".png'\n";
  }
  script << "set terminal pngcairo size 900,600 font ',11'\n"
         << "set grid\nset logscale xy\nset key top right\nset xlabel 'eccentricity of the sphere [mm]'\n"
         << "set xrange [" << 0.7 * std::min(e_min, e_max) << ":" << 1.4 * std::max(e_min, e_max) << "]\n"
         << "set xtics (" << xtics << ")\n"
         << "set output b_c_std_png\n"
         << "set title 'Standard deviation of b and c (" << title << ")'\n"
         << "set ylabel 'standard deviation [um]'\n"
         << "plot crlb_dat u 1:2 w l lw 2 lc rgb '#1f77b4' t 'b, Cramer-Rao', "
            "std_dat u 1:2 w p pt 7 ps 1.5 lc rgb '#1f77b4' t 'b, Monte Carlo', "
            "crlb_dat u 1:3 w l lw 2 lc rgb '#d62728' t 'c, Cramer-Rao', "
            "std_dat u 1:3 w p pt 5 ps 1.5 lc rgb '#d62728' t 'c, Monte Carlo'\n"
         << "set output beta_epsilon_std_png\n"
         << "set title 'Standard deviation of beta and epsilon (" << title << ")'\n"
         << "set ylabel 'standard deviation [urad]'\n"
         << "plot crlb_dat u 1:4 w l lw 2 lc rgb '#1f77b4' t 'beta, Cramer-Rao', "
            "std_dat u 1:4 w p pt 7 ps 1.5 lc rgb '#1f77b4' t 'beta, Monte Carlo', "
            "crlb_dat u 1:5 w l lw 2 lc rgb '#d62728' t 'epsilon, Cramer-Rao', "
            "std_dat u 1:5 w p pt 5 ps 1.5 lc rgb '#d62728' t 'epsilon, Monte Carlo'\n"
         << "unset logscale\nset logscale x\nset key top right\n"
         << "set output spread_png\n"
         << "set title 'Spread of the estimates of b and c (every trial)'\n"
         << "set ylabel 'estimate - truth [um]'\n"
         << "plot spread_dat u ($1*0.97):2 w p pt 7 ps 0.3 lc rgb '#801f77b4' t 'b', "
            "spread_dat u ($1*1.03):3 w p pt 7 ps 0.3 lc rgb '#80d62728' t 'c'\n";
  files.Stage(folder + "fig4.gp", [&](std::ostream& f) { f << script.str(); });
  GnuplotRun run;
  run.folder = dir;
  run.script = script.str();
  run.description = "Figure 4";
  run.timeout_s = timeout_s;
  for (const char* name : {"std", "crlb", "spread"}) {
    run.Set(std::string(name) + "_dat", files.StagedName(folder + "fig4_" + name + ".dat"));
  }
  for (const char* name : {"b_c_std", "beta_epsilon_std", "spread"}) {
    run.Draw(std::string(name) + "_png", folder + "fig4_" + name + ".png", files);
  }
  RunGnuplot(run, "--plot-dir " + dir);
}

int RunPlan(const MonteCarloAppOptions& o, const MonteCarloStudyOptions& spec, std::ostream& report,
            OutputFiles& files) {
  // The table goes to the report, unless the JSON takes standard output.
  std::ostringstream discarded;
  std::ostream& out = o.json_path == "-" ? discarded : report;
  out << "Predicted standard deviations (linearised at the truth, no simulation): "
      << (o.machine.angles_path.empty()
              ? Format("%d", o.machine.theta_steps) + " x " + Format("%d", o.machine.phi_steps) + " grid"
              : "pattern " + o.machine.angles_path)
      << ", sigma_r " << o.machine.noise_r_um << " um, " << spec.setups << " setup(s)\n";
  out << Format("%-8s", "e_mm");
  for (int p = 0; p < kNumScmsParams; ++p) {
    out << Format(
        " %12s", (std::string(kScmsParamInfo[static_cast<std::size_t>(p)].name) + "_" + ReportUnitsOf(p).fine).c_str());
  }
  out << Format(" %12s\n", "worst_um");
  json rows = json::array();
  std::string notes;  // the undetermined parameters of each eccentricity, below the table
  for (double e : spec.eccentricities_mm) {
    SimulationSpec s = spec.base;
    s.centers_mm = PlacementCenters(spec, e);
    const PredictedUncertainty u = PredictUncertainty(s);
    out << Format("%-8g", e);
    json row = {{"eccentricity_mm", e}};
    json undetermined_names = json::array();
    std::vector<std::pair<int, double>> undetermined;
    for (int p = 0; p < kNumScmsParams; ++p) {
      const char* name = kScmsParamInfo[static_cast<std::size_t>(p)].name;
      const bool determined = u.Determined(p, o.max_std_um);
      out << (determined ? Format(" %12.4f", u.std(p) * ReportUnitsOf(p).to_fine) : Format(" %12s", "undetermined"));
      row[std::string(name) + "_std_" + ReportUnitsOf(p).fine] = NumberOrNull(u.std(p) * ReportUnitsOf(p).to_fine);
      if (!determined) {
        undetermined_names.push_back(name);
        undetermined.emplace_back(p, u.StdAsDisplacementUm(p));
      }
    }
    const double worst = u.WorstErrorStdUm();
    out << (worst < 1e7 ? Format(" %12.4f\n", worst) : Format(" %12.4g\n", worst));
    row["worst_std_um"] = NumberOrNull(worst);
    row["undetermined"] = undetermined_names;
    rows.push_back(row);
    std::ostringstream note;
    WriteUndetermined(note, undetermined, o.max_std_um, "std");
    notes += note.str().empty() ? "" : Format("e = %g mm: ", e) + note.str();
  }
  out << notes;
  json j = {{"plan", rows}, {"max_std_um", o.max_std_um}};
  if (o.target_std_um) {
    std::vector<Eigen::Vector3d> dirs = PlacementCenters(spec, 1.0);
    const double hi = 0.5 * spec.base.sphere_radius_mm;
    out << "\nSmallest eccentricity at which every error's std, as a displacement (angles times R0), is at most "
        << *o.target_std_um << " um:\n";
    const auto e = SmallestEccentricityMm(spec.base, dirs, *o.target_std_um, 1e-3, hi);
    out << "  this pattern: " << (e ? Format("%.3f mm", *e) : std::string("not reached below R0/2")) << "\n";
    j["target_std_um"] = *o.target_std_um;
    j["smallest_eccentricity_mm"] = e ? json(*e) : json(nullptr);
    if (o.machine.angles_path.empty()) {
      out << "  other grids (theta steps x phi rings):\n";
      json grids = json::array();
      for (auto [nt, np] :
           std::vector<std::pair<int, int>>{{12, 6}, {24, 12}, {36, 18}, {48, 24}, {72, 36}, {96, 48}}) {
        SimulationSpec s = spec.base;
        s.pattern = GridPattern(nt, np);
        const auto eg = SmallestEccentricityMm(s, dirs, *o.target_std_um, 1e-3, hi);
        out << Format("    %3d", nt) << Format(" x %-3d", np) << Format(" (%5d points): ", nt * np)
            << (eg ? Format("%.3f mm", *eg) : std::string("not reached")) << "\n";
        grids.push_back({{"theta_steps", nt}, {"phi_steps", np}, {"eccentricity_mm", eg ? json(*eg) : json(nullptr)}});
      }
      j["grids"] = grids;
    }
  }
  if (!o.json_path.empty()) files.Stage(o.json_path, [&](std::ostream& f) { f << j.dump(2) << "\n"; });
  files.Commit();
  return kExitOk;
}

}  // namespace

void SetupMonteCarloApp(CLI::App& app, MonteCarloAppOptions& o) {
  app.description(
      "Monte Carlo study of the calibration against the sphere's eccentricity (the paper's Tables 2 and "
      "3 and Figure 4), with the Cramer-Rao prediction; --plan predicts without simulating.");
  AddMachineOptions(app, o.machine);
  app.add_option("--trials", o.trials, "Calibrations per eccentricity")
      ->capture_default_str()
      ->check(CLI::Range(2, 1000000));
  app.add_option("--eccentricities-mm", o.eccentricities_mm, "Eccentricities of the sphere [mm]")
      ->capture_default_str()
      ->delimiter(',');
  app.add_option("--direction", o.direction, "Direction of the eccentricity x,y,z")->capture_default_str();
  app.add_flag("--random-direction", o.random_direction, "A random direction for every trial (and setup)");
  app.add_option("--setups", o.setups, "Sphere placements per trial, turned evenly about the Theta axis")
      ->capture_default_str()
      ->check(CLI::Range(1, 100));
  AddSeedOption(app, o.seed, "Random seed (results depend on it alone, not on --threads)")->capture_default_str();
  app.add_option("--max-std-um", o.max_std_um,
                 "A parameter whose predicted standard deviation, as a displacement of the probed point (angles "
                 "times R0), exceeds this is undetermined, as sph_calibrate judges it [um]")
      ->capture_default_str()
      ->check(InRange(ranges::kStdUm));
  app.add_option("--threads", o.threads, "Worker threads (0: all cores)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1024));
  app.add_flag("!--no-table3", o.table3, "Skip Table 3 (sphericity of ten further spheres)");
  app.add_option("--table3-calibration-e-mm", o.table3_calibration_e_mm,
                 "Eccentricity of the calibration used for Table 3 [mm]")
      ->capture_default_str();
  app.add_option("--json", o.json_path, "Write the results as JSON ('-' for stdout)");
  app.add_option("--csv", o.csv_path, "Write the per-parameter statistics as CSV");
  app.add_option("--plot-dir", o.plot_dir, "Write Figure 4 (PNG, with gnuplot) and its data into this folder");
  AddPlotTimeoutOption(app, o.plot_timeout_s);
  app.add_flag("--plan", o.plan, "Predict the standard deviations from the linearised model, without simulating");
  app.add_option("--target-std-um", o.target_std_um,
                 "With --plan: find the smallest eccentricity (and per grid) meeting this std as a displacement [um]")
      ->check(InRange(ranges::kStdUm));
  auto* orient = app.add_flag("--plan-orientations", o.plan_orientations,
                              "Propose the orientations of the sphere on its mount that separate its form from the "
                              "machine (--effects, --form-degree-max), at each eccentricity, without simulating noise");
  orient->excludes(app.get_option("--plan"))->excludes(app.get_option("--random-direction"));
  std::string ids;
  std::vector<std::string> all_ids;
  for (const EffectInfo& e : kEffectInfo) {
    ids += (ids.empty() ? "" : ", ") + std::string(e.id);
    all_ids.emplace_back(e.id);
  }
  app.add_option("--effects", o.effects,
                 "With --plan-orientations: the machine's effects beyond the seven errors (comma-separated; default "
                 "the whole library): " +
                     ids)
      ->delimiter(',')
      ->needs(orient)
      ->check(CLI::IsMember(all_ids));
  app.add_option("--form-degree-max", o.form_degree_max,
                 "With --plan-orientations: separate the form's terms of degrees 2 to this")
      ->capture_default_str()
      ->needs(orient)
      ->check(CLI::Range(2, 12));
  app.add_option("--max-orientations", o.max_orientations,
                 "With --plan-orientations: at most this many orientations, the reference one included")
      ->capture_default_str()
      ->needs(orient)
      ->check(CLI::Range(1, 20));
  app.add_option("--candidate-rotation-deg", o.candidate_rotations,
                 "With --plan-orientations: a mount rotation to choose from, a rotation vector rx,ry,rz [deg] "
                 "(axis times angle; repeat the option; default: turns by 90, 180, 270 deg about z, by +-90 and 180 "
                 "deg about x and y, and 120 deg about (1,1,1))")
      ->needs(orient);
  app.add_option("--phi-wobble-pivot-mm", o.phi_wobble_pivot_mm,
                 "With --plan-orientations: the Phi axis wobble's pivot distance along the axis [mm]")
      ->capture_default_str()
      ->needs(orient)
      ->check(InRange(ranges::kPivotMm));
  app.add_flag("!--no-progress", o.progress, "No progress bar");
}

int RunMonteCarloApp(const MonteCarloAppOptions& o, std::ostream& out, std::ostream& err) {
  const PlotFolder plot_folder(o.plot_dir);  // removed again when a failed run leaves it empty
  try {
    RunPaths paths;
    paths.Input("--angles", o.machine.angles_path)
        .Output("the text report", o.json_path != "-" ? "-" : "")
        .Output("--json", o.json_path)
        .Output("--csv", o.csv_path);
    if (!o.plot_dir.empty()) {
      for (const char* f : {"fig4_std.dat", "fig4_crlb.dat", "fig4_spread.dat", "fig4.gp", "fig4_b_c_std.png",
                            "fig4_beta_epsilon_std.png", "fig4_spread.png"}) {
        paths.Output("--plot-dir", o.plot_dir + "/" + f);
      }
    }
    const MonteCarloStudyOptions spec = ToSpec(o);
    OutputFiles files(out);
    if (o.plan) return RunPlan(o, spec, out, files);
    if (o.target_std_um) throw Error("--target-std-um goes with --plan");
    if (o.plan_orientations) return RunOrientationPlan(o, spec, out, files);
    ProgressBar bar(err, o.progress);
    const auto t0 = std::chrono::steady_clock::now();
    const MonteCarloStudy r = RunMonteCarlo(spec, [&](long d, long t) { bar(d, t); });
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (o.json_path != "-") PrintTable2(out, r, o);
    json j = {{"program", "sph_montecarlo " SPH_VERSION},
              {"trials", o.trials},
              {"seed", o.seed},
              {"noise_r_um", o.machine.noise_r_um},
              {"noise_theta_arcsec", o.machine.noise_theta_arcsec},
              {"noise_phi_arcsec", o.machine.noise_phi_arcsec},
              {"setups", o.setups},
              {"random_direction", o.random_direction},
              {"direction", o.direction},
              {"max_std_um", o.max_std_um},
              {"wall_time_s", wall_s},
              {"eccentricities", StudyJson(r)}};
    if (o.table3) {
      std::ostringstream t3;
      j["table3"] = Table3(t3, spec, r, o);
      if (o.json_path != "-") out << t3.str();
    }
    if (o.json_path != "-")
      out << "\n"
          << o.trials * static_cast<int>(r.rows.size()) << " calibrations in " << Format("%.2f", wall_s) << " s\n"
          << std::flush;
    if (!o.json_path.empty()) files.Stage(o.json_path, [&](std::ostream& f) { f << j.dump(2) << "\n"; });
    if (!o.csv_path.empty()) WriteCsv(o.csv_path, r, files);
    if (!o.plot_dir.empty()) {
      plot_folder.Make();
      Plot(o.plot_dir, spec, r, o.plot_timeout_s, files);
    }
    files.Commit();
    if (!o.plot_dir.empty()) {
      err << "sph_montecarlo: wrote " << o.plot_dir
          << "/fig4_b_c_std.png, fig4_beta_epsilon_std.png, fig4_spread.png\n";
    }
    return kExitOk;
  } catch (const std::exception& e) {
    err << "sph_montecarlo: error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace sph::apps
