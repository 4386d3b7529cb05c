#include "sph/calib/montecarlo_report.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <sstream>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "sph/calib/design.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using internal::Format;
using nlohmann::json;

// The paper's Table 3 (um), printed beside the reproduction for comparison.
constexpr double kPaperBeforeUm[10] = {1.786, 1.796, 1.811, 1.828, 1.842, 2.641, 3.097, 3.256, 3.306, 3.528};
constexpr double kPaperAfterUm[10] = {0.00529, 0.00541, 0.00541, 0.00558, 0.00606,
                                      0.01656, 0.02519, 0.02927, 0.03838, 0.04541};

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

json NumberOrNull(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json RowsJson(const MonteCarloStudy& r) {
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

}  // namespace

void WriteStudyTables(std::ostream& out, const MonteCarloStudyOptions& o, const MonteCarloStudy& r) {
  out << "Table 2: mean of the calibrations (" << o.trials << " trials per eccentricity, seed " << o.seed
      << ", sigma_r " << o.base.noise_r_um << " um)\n";
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

void WriteStudyCsv(std::ostream& f, const MonteCarloStudy& r) {
  {
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
  }
}

PaperTable3 MakePaperTable3(const MonteCarloStudyOptions& spec, const MonteCarloStudy& study, double calibration_e_mm) {
  const std::vector<double> targets(std::begin(kPaperBeforeUm), std::end(kPaperBeforeUm));
  return {calibration_e_mm, SphericityStudy(spec, study, targets, calibration_e_mm)};
}

void WritePaperTable3(std::ostream& out, const MonteCarloStudyOptions& spec, const PaperTable3& table) {
  const std::vector<SphericityRow>& rows = table.rows;
  out << "\nTable 3: least-squares sphericity (um) of ten spheres, exact readings, evaluated with the nominal "
         "errors (before) and with the errors calibrated at "
      << table.calibration_eccentricity_mm << " mm (after): one calibration (sigma_r " << spec.base.noise_r_um
      << " um, seed " << spec.seed << "), the median over the study's calibrations there, and their mean\n"
      << "The paper does not give the spheres' centres: each eccentricity (along the study's direction) is the one "
         "whose 'before' value is the paper's.\n";
  out << Format("%-3s %9s %9s %9s %11s %12s %11s %11s\n", "#", "e_mm", "before", "paper", "after_one", "after_median",
                "after_mean", "paper_after");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const SphericityRow& w = rows[i];
    out << Format("%-3d", static_cast<int>(i) + 1) << Format(" %9.4f", w.eccentricity_mm)
        << Format(" %9.3f", w.before_um) << Format(" %9.3f", kPaperBeforeUm[i]) << Format(" %11.5f", w.after_one_um)
        << Format(" %12.5f", w.after_median_um) << Format(" %11.5f", w.after_mean_um)
        << Format(" %11.5f", kPaperAfterUm[i]) << "\n";
  }
}

namespace {

json Table3Json(const PaperTable3& table) {
  json j = json::array();
  for (std::size_t i = 0; i < table.rows.size(); ++i) {
    const SphericityRow& w = table.rows[i];
    j.push_back({{"sphere", i + 1},
                 {"eccentricity_mm", NumberOrNull(w.eccentricity_mm)},
                 {"before_um", NumberOrNull(w.before_um)},
                 {"paper_before_um", kPaperBeforeUm[i]},
                 {"after_one_calibration_um", NumberOrNull(w.after_one_um)},
                 {"after_median_um", NumberOrNull(w.after_median_um)},
                 {"after_mean_um", NumberOrNull(w.after_mean_um)},
                 {"paper_after_um", kPaperAfterUm[i]}});
  }
  return {{"calibration_eccentricity_mm", table.calibration_eccentricity_mm}, {"rows", j}};
}

}  // namespace

std::string StudyJson(const MonteCarloStudyOptions& spec, const MonteCarloStudy& study, const std::string& direction,
                      double wall_time_s, const PaperTable3* table3) {
  json j = {{"program", "sph_montecarlo " SPH_VERSION},
            {"trials", spec.trials},
            {"seed", spec.seed},
            {"noise_r_um", spec.base.noise_r_um},
            {"noise_theta_arcsec", spec.base.noise_theta_arcsec},
            {"noise_phi_arcsec", spec.base.noise_phi_arcsec},
            {"setups", spec.setups},
            {"random_direction", spec.random_direction},
            {"direction", direction},
            {"max_std_um", spec.max_std_um},
            {"wall_time_s", wall_time_s},
            {"eccentricities", RowsJson(study)}};
  if (table3 != nullptr) j["table3"] = Table3Json(*table3);
  return j.dump(2) + "\n";
}

void WriteFigure4Std(std::ostream& f, const MonteCarloStudy& r) {
  f << "# eccentricity_mm b_um c_um beta_urad epsilon_urad (Monte Carlo std)\n";
  for (const auto& row : r.rows) {
    f << row.eccentricity_mm << " " << row.params[kB].std * kUmPerMm << " " << row.params[kC].std * kUmPerMm << " "
      << row.params[kBeta].std * kUradPerRad << " " << row.params[kEpsilon].std * kUradPerRad << "\n";
  }
}

void WriteFigure4Crlb(std::ostream& f, const MonteCarloStudyOptions& spec, const MonteCarloStudy& r) {
  const double e_min = r.rows.front().eccentricity_mm, e_max = r.rows.back().eccentricity_mm;
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
}

void WriteFigure4Spread(std::ostream& f, const MonteCarloStudyOptions& spec, const MonteCarloStudy& r) {
  f << "# eccentricity_mm b_error_um c_error_um (estimate minus truth, every converged trial)\n";
  for (const auto& row : r.rows) {
    for (const auto& g : row.estimates) {
      f << row.eccentricity_mm << " " << (g[kB] - spec.base.truth[kB]) * kUmPerMm << " "
        << (g[kC] - spec.base.truth[kC]) * kUmPerMm << "\n";
    }
  }
}

std::string PlanStudy(std::ostream& out, const MonteCarloStudyOptions& spec, const std::string& pattern,
                      std::optional<double> target_std_um, bool other_grids) {
  out << "Predicted standard deviations (linearised at the truth, no simulation): " << pattern << ", sigma_r "
      << spec.base.noise_r_um << " um, " << spec.setups << " setup(s)\n";
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
      const bool determined = u.Determined(p, spec.max_std_um);
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
    WriteUndetermined(note, undetermined, spec.max_std_um, "std");
    notes += note.str().empty() ? "" : Format("e = %g mm: ", e) + note.str();
  }
  out << notes;
  json j = {{"plan", rows}, {"max_std_um", spec.max_std_um}};
  if (target_std_um) {
    std::vector<Eigen::Vector3d> dirs = PlacementCenters(spec, 1.0);
    const double hi = 0.5 * spec.base.sphere_radius_mm;
    out << "\nSmallest eccentricity at which every error's std, as a displacement (angles times R0), is at most "
        << *target_std_um << " um:\n";
    const auto e = SmallestEccentricityMm(spec.base, dirs, *target_std_um, 1e-3, hi);
    out << "  this pattern: " << (e ? Format("%.3f mm", *e) : std::string("not reached below R0/2")) << "\n";
    j["target_std_um"] = *target_std_um;
    j["smallest_eccentricity_mm"] = e ? json(*e) : json(nullptr);
    if (other_grids) {
      out << "  other grids (theta steps x phi rings):\n";
      json grids = json::array();
      for (auto [nt, np] :
           std::vector<std::pair<int, int>>{{12, 6}, {24, 12}, {36, 18}, {48, 24}, {72, 36}, {96, 48}}) {
        SimulationSpec s = spec.base;
        s.pattern = GridPattern(nt, np);
        const auto eg = SmallestEccentricityMm(s, dirs, *target_std_um, 1e-3, hi);
        out << Format("    %3d", nt) << Format(" x %-3d", np) << Format(" (%5d points): ", nt * np)
            << (eg ? Format("%.3f mm", *eg) : std::string("not reached")) << "\n";
        grids.push_back({{"theta_steps", nt}, {"phi_steps", np}, {"eccentricity_mm", eg ? json(*eg) : json(nullptr)}});
      }
      j["grids"] = grids;
    }
  }
  return j.dump(2) + "\n";
}

}  // namespace sph
