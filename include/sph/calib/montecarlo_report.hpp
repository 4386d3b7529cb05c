// The reports of the Monte Carlo study (sph/calib/montecarlo.hpp) and of its plan, as
// sph_montecarlo writes them: the paper's Tables 2 and 3 in text, the JSON report (every key:
// docs/formats/reports.md), the CSV, the data of Figure 4, and the predicted uncertainties of a
// design without simulation, and the orientation plan of --plan-orientations.
#ifndef SPH_CALIB_MONTECARLO_REPORT_HPP_
#define SPH_CALIB_MONTECARLO_REPORT_HPP_

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "sph/calib/montecarlo.hpp"
#include "sph/select/orientation_plan.hpp"

namespace sph {

/// Table 2 (the mean of the calibrations per eccentricity) and each eccentricity's statistics
/// against the Cramer-Rao bound, with the parameters the design does not determine.
void WriteStudyTables(std::ostream& out, const MonteCarloStudyOptions& spec, const MonteCarloStudy& study);

/// The paper's Table 3 reproduced from a study (SphericityStudy() of the paper's ten "before"
/// values), calibrated at `calibration_eccentricity_mm`.
struct PaperTable3 {
  double calibration_eccentricity_mm = 0.0;
  std::vector<SphericityRow> rows;
};
PaperTable3 MakePaperTable3(const MonteCarloStudyOptions& spec, const MonteCarloStudy& study,
                            double calibration_eccentricity_mm);
/// Table 3 beside the paper's values.
void WritePaperTable3(std::ostream& out, const MonteCarloStudyOptions& spec, const PaperTable3& table);

/// The JSON report of a study: its settings (`direction` as the user gave it), `wall_time_s`, every
/// eccentricity's statistics and, when given, Table 3.
std::string StudyJson(const MonteCarloStudyOptions& spec, const MonteCarloStudy& study, const std::string& direction,
                      double wall_time_s, const PaperTable3* table3);

/// One line per eccentricity and parameter: eccentricity_mm, parameter, unit, true, mean, std, se,
/// z, crlb, std_over_crlb, converged, trials, determined (a number that is not finite: empty).
void WriteStudyCsv(std::ostream& out, const MonteCarloStudy& study);

/// Figure 4's data: the std of b, c [um], beta, epsilon [urad] per eccentricity; the Cramer-Rao std
/// on 61 eccentricities spanning the study's; every converged trial's error of b and c [um].
void WriteFigure4Std(std::ostream& out, const MonteCarloStudy& study);
void WriteFigure4Crlb(std::ostream& out, const MonteCarloStudyOptions& spec, const MonteCarloStudy& study);
void WriteFigure4Spread(std::ostream& out, const MonteCarloStudyOptions& spec, const MonteCarloStudy& study);

/// Figure 4 as a gnuplot script: the std of b and c, and of beta and epsilon, against the
/// eccentricity with the Cramer-Rao curves, and the spread of the estimates of b and c. It reads
/// the data of WriteFigure4Std(), WriteFigure4Crlb() and WriteFigure4Spread() from the variables
/// std_dat, crlb_dat and spread_dat and draws into b_c_std_png, beta_epsilon_std_png and
/// spread_png (gnuplot -e), by default fig4_<name>.dat and fig4_<name>.png of its folder.
std::string Figure4Script(const MonteCarloStudyOptions& spec, const MonteCarloStudy& study);

/// The plan: the predicted std of every error at each eccentricity of `spec` (no simulation),
/// written as a table to `out` (`pattern` names the pattern in its title); with `target_std_um`,
/// the smallest eccentricity at which every error's std as a displacement is at most it, for
/// this pattern and, with `other_grids`, for six grids. Returns the plan's JSON report.
std::string PlanStudy(std::ostream& out, const MonteCarloStudyOptions& spec, const std::string& pattern,
                      std::optional<double> target_std_um, bool other_grids);

/// The orientation plan (PlanOrientations()) of the sphere at each eccentricity of `spec`, in the
/// first placement's direction: a table per eccentricity on `out` (`pattern` names the pattern in
/// its title) with the orientations, the form terms still confounded, the effects not seen and
/// the pairs not told apart with the placement that would; returns its JSON report.
std::string PlanOrientationsReport(std::ostream& out, const MonteCarloStudyOptions& spec,
                                   const OrientationPlanOptions& options, const std::string& pattern);

}  // namespace sph

#endif  // SPH_CALIB_MONTECARLO_REPORT_HPP_
