#include "sph/select/form_report.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sph/internal/format.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/spherical_harmonics.hpp"
#include "sph/model/units.hpp"

namespace sph {

std::vector<std::array<double, 3>> FormMap(const EffectFit& fit, int group, double step_deg) {
  std::vector<std::array<double, 3>> out;
  const FormModel& form = fit.model.form;
  if (form.Empty()) return out;
  const std::vector<double>& c = fit.form_values[static_cast<std::size_t>(group)];
  const int n_polar = std::max(1, static_cast<int>(std::lround(180.0 / step_deg)));
  const int n_lon = 2 * n_polar;
  const double step = 180.0 / n_polar;
  for (int i = 0; i < n_polar; ++i) {
    const double polar = (i + 0.5) * step;
    for (int j = 0; j < n_lon; ++j) {
      const double lon = (j + 0.5) * step;
      const double sp = std::sin(polar * kRadPerDeg);
      const Eigen::Vector3d u(sp * std::cos(lon * kRadPerDeg), sp * std::sin(lon * kRadPerDeg),
                              std::cos(polar * kRadPerDeg));
      out.push_back({polar, lon, FormValue(form.terms, c.data(), u) * kUmPerMm});
    }
  }
  return out;
}

std::vector<SphereFormResult> SphereFormOf(const EffectFit& fit, double max_vif) {
  std::vector<SphereFormResult> out;
  const FormModel& form = fit.model.form;
  if (form.Empty()) return out;
  const ObservabilityReport& rep = fit.calibration.analysis;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int g = 0; g < form.NumGroups(); ++g) {
    SphereFormResult r;
    r.setups = form.group_names[static_cast<std::size_t>(g)];
    if (g > 0) {
      for (const auto& [id, fs] : form.setups) {
        if (fs.group == g) r.setup_ids.push_back(id);
      }
    }
    r.degree_max = form.MaxDegree();
    const std::vector<double>& c = fit.form_values[static_cast<std::size_t>(g)];
    r.rms_um = FormRms(form.terms, c) * kUmPerMm;
    const int first = fit.FormOffset(g);
    const auto n = static_cast<Eigen::Index>(form.terms.size());
    Eigen::VectorXd gradient(n);
    for (Eigen::Index k = 0; k < n; ++k) {
      const FormTerm& t = form.terms[static_cast<std::size_t>(k)];
      FormTermValue v{t.l, t.m, c[static_cast<std::size_t>(k)] * kUmPerMm, nan};
      if (!rep.Empty()) v.std_um = rep.std(first + k) * kUmPerMm;
      r.terms.push_back(v);
      gradient(k) = r.rms_um > 0.0 ? v.value_um / ((2.0 * t.l + 1.0) * r.rms_um) : 0.0;
    }
    r.rms_std_um = nan;
    if (!rep.Empty()) {
      const Eigen::MatrixXd cov = rep.covariance.block(first, first, n, n) * (kUmPerMm * kUmPerMm);
      const double var = gradient.dot(cov * gradient);
      r.rms_std_um = std::isfinite(var) ? std::sqrt(std::max(0.0, var)) : std::numeric_limits<double>::infinity();
      for (Eigen::Index k = 0; k < n; ++k) {
        const double vif = rep.vif(first + k);
        if (vif <= max_vif) continue;
        Eigen::Index partner = -1;
        double best = 0.0;
        for (Eigen::Index j = 0; j < rep.correlation.cols(); ++j) {
          const double rho = rep.correlation(first + k, j);
          if (j != first + k && std::isfinite(rho) && std::abs(rho) > std::abs(best)) {
            best = rho;
            partner = j;
          }
        }
        const std::string name = form.ParamName(g, static_cast<std::size_t>(k));
        r.confounded.push_back(partner < 0
                                   ? name + ": not determined by this design (in the null space of the fit)"
                                   : name + " and " + rep.parameters[static_cast<std::size_t>(partner)].name +
                                         internal::Format(" (correlation %+.3f, variance inflation %.3g)", best, vif) +
                                         ": this design cannot tell them apart; their split is not known");
      }
    }
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto& row : FormMap(fit, g, 1.0)) {
      lo = std::min(lo, row[2]);
      hi = std::max(hi, row[2]);
    }
    r.pv_um = hi - lo;
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace sph
