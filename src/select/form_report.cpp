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

CorrectedRms CorrectedFormRms(const std::vector<FormTerm>& terms, const Eigen::VectorXd& c_mm,
                              const Eigen::MatrixXd& cov_mm2, int l_min) {
  std::vector<Eigen::Index> kept;
  for (std::size_t k = 0; k < terms.size(); ++k) {
    if (terms[k].l >= l_min) kept.push_back(static_cast<Eigen::Index>(k));
  }
  const auto n = static_cast<Eigen::Index>(kept.size());
  Eigen::VectorXd c(n), w(n);
  Eigen::MatrixXd cov(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    c(i) = c_mm(kept[static_cast<std::size_t>(i)]) * kUmPerMm;
    w(i) = 1.0 / (2.0 * terms[static_cast<std::size_t>(kept[static_cast<std::size_t>(i)])].l + 1.0);
    for (Eigen::Index j = 0; j < n; ++j) {
      cov(i, j) = cov_mm2(kept[static_cast<std::size_t>(i)], kept[static_cast<std::size_t>(j)]) * kUmPerMm * kUmPerMm;
    }
  }
  CorrectedRms out;
  const double fitted2 = c.dot(w.asDiagonal() * c);
  const Eigen::MatrixXd wc = w.asDiagonal() * cov;  // W C
  const double noise2 = wc.trace();
  const double var2 = 4.0 * c.dot(wc * (w.asDiagonal() * c)) + 2.0 * (wc * wc).trace();  // of the corrected square
  out.fitted_um = std::sqrt(fitted2);
  if (!std::isfinite(noise2) || !std::isfinite(var2)) {
    out.rms_um = out.fitted_um;
    out.noise_um = out.std_um = std::numeric_limits<double>::infinity();
    return out;
  }
  out.noise_um = std::sqrt(std::max(0.0, noise2));
  const double corrected2 = std::max(0.0, fitted2 - noise2);
  out.rms_um = std::sqrt(corrected2);
  // The square's uncertainty carried to the RMS: u2 / (2 rms) well above the noise, sqrt(u2) near zero.
  out.std_um = std::sqrt(corrected2 + std::sqrt(std::max(0.0, var2))) - out.rms_um;
  return out;
}

std::vector<SphereFormResult> SphereFormOf(const TraceResult& r, double max_vif) {
  std::vector<SphereFormResult> forms = SphereFormOf(r.after.fit, max_vif);
  for (std::size_t g = 0; g < forms.size() && g < r.form.higher_rms_um.size(); ++g) {
    SphereFormResult& f = forms[g];
    const auto [rms_um, std_um] = r.form.higher_rms_um[g];
    f.higher_degree_limit = r.form.degree_limit;
    f.higher_rms_max_um = rms_um + 2.0 * std_um;
    const double change = std::hypot(f.rms_um, f.higher_rms_max_um) - f.rms_um;  // what they would add to the RMS
    f.rms_std_um = std::sqrt(f.rms_noise_std_um * f.rms_noise_std_um + change * change / 3.0);
  }
  return forms;
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
    r.rms_fitted_um = FormRms(form.terms, c) * kUmPerMm;
    r.rms_um = r.rms_fitted_um;
    const int first = fit.FormOffset(g);
    const auto n = static_cast<Eigen::Index>(form.terms.size());
    for (Eigen::Index k = 0; k < n; ++k) {
      const FormTerm& t = form.terms[static_cast<std::size_t>(k)];
      FormTermValue v{t.l, t.m, c[static_cast<std::size_t>(k)] * kUmPerMm, nan};
      if (!rep.Empty()) v.std_um = rep.std(first + k) * kUmPerMm;
      r.terms.push_back(v);
    }
    r.rms_std_um = nan;
    r.rms_noise_std_um = nan;
    if (!rep.Empty()) {
      const CorrectedRms corrected = CorrectedFormRms(form.terms, Eigen::Map<const Eigen::VectorXd>(c.data(), n),
                                                      rep.covariance.block(first, first, n, n));
      r.rms_um = corrected.rms_um;
      r.rms_noise_um = corrected.noise_um;
      r.rms_std_um = r.rms_noise_std_um = corrected.std_um;
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
