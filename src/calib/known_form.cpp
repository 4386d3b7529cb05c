#include "sph/calib/known_form.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "sph/core/error.hpp"
#include "sph/stats/gum.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph {

using internal::Format;

FormPrior FormPriorOfFile(const CalibrationFile& file, const std::string& path, std::vector<std::string>* notes) {
  if (file.form_terms.empty()) {
    throw Error(path +
                ": holds no \"sphere_form\": the known form comes from the calibration file of a run that "
                "separated it (sph_calibrate -o on the sphere measured in two or more known orientations)");
  }
  bool correlated = false;
  const Eigen::MatrixXd c = FormCovariance(file, &correlated);
  if (c.rows() == 0) {
    throw Error(path +
                ": its \"sphere_form\" has no uncertainties (std_um, or the covariance): a form without "
                "them cannot be weighed against the readings");
  }
  FormPrior prior;
  prior.terms = file.form_terms;
  prior.mean_mm = Eigen::Map<const Eigen::VectorXd>(file.form_values_mm.data(),
                                                    static_cast<Eigen::Index>(file.form_values_mm.size()));
  prior.covariance_mm2 = c;
  if (Eigen::LLT<Eigen::MatrixXd>(c).info() != Eigen::Success) {
    throw Error(path +
                ": the covariance of its \"sphere_form\" is singular (a coefficient with no uncertainty, or "
                "a combination of them): it cannot be a prior");
  }
  if (!correlated && notes != nullptr) {
    notes->push_back(path +
                     ": the file carries the form's standard uncertainties but not their covariance: the "
                     "coefficients are taken as uncorrelated");
  }
  return prior;
}

void CheckSameSphere(const CalibrationFile& file, const std::string& path, double radius_mm, double radius_u_um,
                     const std::string& what) {
  if (!file.sphere_radius_mm) {
    throw Error(path + ": states no sphere_radius_mm, so it cannot be told whether its form is that of the sphere of " +
                what + " (sphere_radius_mm " + Format("%.9g", radius_mm) +
                " mm): the known form belongs to its own sphere");
  }
  double file_u_um = 0.0;
  for (const CalibrationFile::CovarianceInput& in : file.covariance_inputs) {
    if (in.input == "R0 (certificate)" && in.unit == "um") file_u_um = in.u;
  }
  const double difference_um = std::abs(radius_mm - *file.sphere_radius_mm) * kUmPerMm;
  const double allowed_um = radius_u_um + file_u_um + 1e-3;
  if (difference_um <= allowed_um) return;
  throw Error(what + ": sphere_radius_mm " + Format("%.9g", radius_mm) + " mm (u " + Format("%g", radius_u_um) +
              " um) is not the radius of the sphere whose form " + path + " holds, " +
              Format("%.9g", *file.sphere_radius_mm) + " mm (u " + Format("%g", file_u_um) + " um): they differ by " +
              Format("%.3g", difference_um) +
              " um, more than their standard uncertainties together; the known form belongs to its own sphere");
}

namespace {

// KnownFormCheck::conflict_*: the prior (its factor l, the fitted coefficients whitened w) against
// the readings, through the fit's covariance of the form's columns `in_model` of the set `group`.
void PriorConflict(const EffectFit& fit, int group, const Eigen::MatrixXd& l, const Eigen::VectorXd& w,
                   const std::vector<Eigen::Index>& in_model, KnownFormCheck* k) {
  const ObservabilityReport& a = fit.calibration.analysis;
  const double s = a.residual_sigma_mm, sigma = fit.calibration.prior_sigma_mm;
  if (a.Empty() || a.covariance.rows() == 0 || !(s > 0.0) || !(sigma > 0.0)) return;
  const auto n = static_cast<Eigen::Index>(in_model.size());
  const int first = fit.FormOffset(group);
  Eigen::MatrixXd cov(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) {
      cov(i, j) =
          a.covariance(first + in_model[static_cast<std::size_t>(i)], first + in_model[static_cast<std::size_t>(j)]);
    }
  }
  if (!cov.allFinite()) return;
  // The analysis' covariance is s^2 N^-1; the posterior's, at the prior's noise, sigma^2 N^-1.
  const Eigen::MatrixXd half = l.triangularView<Eigen::Lower>().solve(cov * (sigma * sigma / (s * s)));
  const Eigen::MatrixXd posterior = l.triangularView<Eigen::Lower>().solve(half.transpose());
  const Eigen::MatrixXd determined = Eigen::MatrixXd::Identity(n, n) - 0.5 * (posterior + posterior.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(determined);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double lambda = eig.eigenvalues()(i);
    if (!(lambda >= kConflictDetermined)) continue;
    const double along = eig.eigenvectors().col(i).dot(w);
    k->conflict_chi_square += along * along / std::min(lambda, 1.0);
    ++k->conflict_dof;
  }
  if (k->conflict_dof > 0) k->conflict_p_value = gum::ChiSquareSf(k->conflict_chi_square, k->conflict_dof);
}

// CheckKnownForm() of the reference sphere's form (`setup` < 0) or of another sphere's, by `setup`
// (options.other_form_priors).
KnownFormCheck Check(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                     const std::string& source, std::optional<double> bound_rms_um, bool from_file, int setup) {
  KnownFormCheck k;
  k.source = source;
  k.bound_rms_um = bound_rms_um;
  const FormPrior& prior = setup < 0 ? options.form_prior : options.other_form_priors.at(setup);
  const FormModel& form = fit.model.form;
  if (prior.Empty() || form.Empty() || fit.form_values.empty()) return k;
  const int group = setup < 0 ? 0 : form.SetupOf(setup).group;
  for (const auto& [id, fs] : form.setups) {
    if (setup >= 0 && fs.group == group) k.setups.push_back(id);
  }
  const std::vector<double>& fitted = fit.form_values[static_cast<std::size_t>(group)];
  // The prior's terms the model has, their marginal.
  std::vector<Eigen::Index> in_prior, in_model;
  for (std::size_t i = 0; i < prior.terms.size(); ++i) {
    const auto it = std::find(form.terms.begin(), form.terms.end(), prior.terms[i]);
    if (it == form.terms.end()) continue;
    in_prior.push_back(static_cast<Eigen::Index>(i));
    in_model.push_back(static_cast<Eigen::Index>(it - form.terms.begin()));
  }
  const auto n = static_cast<Eigen::Index>(in_prior.size());
  k.terms = static_cast<int>(n);
  Eigen::VectorXd d(n);
  Eigen::MatrixXd c(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    d(i) = fitted[static_cast<std::size_t>(in_model[static_cast<std::size_t>(i)])] -
           prior.mean_mm(in_prior[static_cast<std::size_t>(i)]);
    for (Eigen::Index j = 0; j < n; ++j)
      c(i, j) = prior.covariance_mm2(in_prior[static_cast<std::size_t>(i)], in_prior[static_cast<std::size_t>(j)]);
  }
  const Eigen::MatrixXd l = Eigen::LLT<Eigen::MatrixXd>(c).matrixL();
  const Eigen::VectorXd w = l.triangularView<Eigen::Lower>().solve(d);
  k.chi_square = w.squaredNorm();
  k.p_value = gum::ChiSquareSf(k.chi_square, static_cast<double>(n));
  PriorConflict(fit, group, l, w, in_model, &k);
  std::vector<double> mean(prior.terms.size());
  for (std::size_t i = 0; i < mean.size(); ++i) mean[i] = prior.mean_mm(static_cast<Eigen::Index>(i));
  k.known_rms_um = FormRms(prior.terms, mean) * kUmPerMm;
  k.fitted_rms_um = FormRms(form.terms, fitted) * kUmPerMm;
  // What the form as known explains, judged on the seven errors and the centres alone: effects
  // chosen beside a form that is not the sphere's (turned on its mount) can take its misfit, and
  // the form would then seem to fit.
  const PointsData kept = WithoutOutliers(points, fit.calibration);
  EffectModel seven = fit.model;
  seven.terms.clear();
  EffectFitStart from_fit = EffectFitStart::From(fit);
  from_fit.values.clear();
  CalibrationOptions quick = options;
  quick.analyse = false;
  quick.prior_sigma_mm = fit.calibration.prior_sigma_mm;
  // The seven errors with the form held at its known value (its covariance shrunk a million times).
  CalibrationOptions held = quick;
  FormPrior& held_prior = setup < 0 ? held.form_prior : held.other_form_priors.at(setup);
  held_prior.covariance_mm2 *= 1e-6;
  const EffectFit as_known = FitEffects(kept, held, seven, from_fit);
  // The seven errors without a form (the reference sphere's), or without this sphere's form (held
  // at zero, the other sets as they are), on the same readings.
  EffectFit none;
  if (setup < 0) {
    EffectModel plain = seven;
    plain.form = FormModel{};
    CalibrationOptions no_prior = quick;
    no_prior.prior_sigma_mm = options.prior_sigma_mm;
    no_prior.other_form_priors.clear();
    none = FitEffects(kept, no_prior, plain, EffectFitStart::From(fit.calibration));
  } else {
    CalibrationOptions zero = held;
    zero.other_form_priors.at(setup).mean_mm.setZero();
    none = FitEffects(kept, zero, seven, from_fit);
  }
  k.rms_with_um = as_known.calibration.rms_um;
  k.rms_without_um = none.calibration.rms_um;
  k.explained_rms_um = std::sqrt(std::max(0.0, k.rms_without_um * k.rms_without_um - k.rms_with_um * k.rms_with_um));
  const bool worse = k.rms_with_um > k.rms_without_um;
  k.exceeds_bound = !from_file && bound_rms_um && k.conflict_dof > 0 && k.conflict_p_value < kKnownFormP;
  k.agrees = k.p_value >= kKnownFormP && !worse && !k.exceeds_bound;
  const std::string numbers =
      Format("chi-square %.3g for %d coefficients, p = %.2g; residual RMS %.4g um with it, %.4g um without a form",
             k.chi_square, k.terms, k.p_value, k.rms_with_um, k.rms_without_um);
  if (k.exceeds_bound) {
    k.verdict = Format(
        "the sphere's form exceeds its certificate's bound sphere_form_rms_um %.3g um (k = 1): the readings "
        "reject the bound as a prior (chi-square %.3g for %d directions they determine, p = %.2g); residual RMS "
        "%.4g um with the form held to it, %.4g um without a form",
        *bound_rms_um, k.conflict_chi_square, k.conflict_dof, k.conflict_p_value, k.rms_with_um, k.rms_without_um);
    k.warnings.push_back(k.verdict +
                         ". The prior held the form small and the residual took the rest: the residual sigma, the "
                         "uncertainties and the effects found are not to be trusted. Check the sphere (damaged or "
                         "dirty, or not the certified one), or separate its form (--sphere-form)");
  } else if (k.agrees) {
    k.verdict = "the readings agree with the known form of " + source + " (" + numbers + ")";
  } else {
    k.verdict = "the readings disagree with the known form of " + source + " (" + numbers + ")";
    k.warnings.push_back(
        k.verdict + (worse ? ": it fits them worse than no form at all" : "") +
        ". Likely causes: the sphere damaged or dirty since its form was separated, or its orientation on the "
        "mount not the one the points file states (mount_rotation_deg@<setup>; none: the reference orientation). "
        "The form was not forced: it moved as far as its covariance allows; check the sphere before using this "
        "calibration");
  }
  if (bound_rms_um) {
    if (k.fitted_rms_um > *bound_rms_um) {
      k.warnings.push_back(
          Format("the form fitted, %.3g um RMS over the sphere, is larger than the certificate's "
                 "bound sphere_form_rms_um %.3g um (k = 1)",
                 k.fitted_rms_um, *bound_rms_um));
    }
    if (from_file && k.known_rms_um > *bound_rms_um) {
      k.warnings.push_back(
          Format("the known form of %s, %.3g um RMS over the sphere, exceeds the certificate's bound "
                 "sphere_form_rms_um %.3g um (k = 1)",
                 source.c_str(), k.known_rms_um, *bound_rms_um));
    }
  }
  return k;
}

}  // namespace

KnownFormCheck CheckKnownForm(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                              const std::string& source, std::optional<double> bound_rms_um, bool from_file) {
  return Check(points, options, fit, source, bound_rms_um, from_file, -1);
}

KnownFormCheck CheckOtherKnownForm(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                                   int setup, const std::string& source) {
  return Check(points, options, fit, source, std::nullopt, true, setup);
}

}  // namespace sph
