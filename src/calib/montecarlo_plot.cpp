#include <algorithm>
#include <sstream>

#include "sph/calib/montecarlo_report.hpp"
#include "sph/internal/format.hpp"

namespace sph {

using internal::Format;

std::string Figure4Script(const MonteCarloStudyOptions& spec, const MonteCarloStudy& r) {
  const double e_min = r.rows.front().eccentricity_mm, e_max = r.rows.back().eccentricity_mm;
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
  return script.str();
}

}  // namespace sph
