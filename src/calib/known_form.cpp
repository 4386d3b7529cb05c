#include "sph/calib/known_form.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

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

// KnownFormCheck::conflict_* and difference_*: the prior (its factor l, the fitted coefficients
// whitened w, its terms `terms`) against the readings, through the fit's covariance of the form's
// columns `in_model` of the set `group`.
void PriorConflict(const EffectFit& fit, int group, const Eigen::MatrixXd& l, const Eigen::VectorXd& w,
                   const std::vector<Eigen::Index>& in_model, const std::vector<FormTerm>& terms, KnownFormCheck* k) {
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
  // The readings' own estimate less the statement, in coefficients (d = L sum_i u_i y_i), and its
  // mean square over the sphere when the statement holds (y_i of variance 1 / lambda_i).
  const auto sphere_ms = [&](const Eigen::VectorXd& c) {  // mean square over the sphere of coefficients c
    double sum = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) sum += c(i) * c(i) / (2.0 * terms[static_cast<std::size_t>(i)].l + 1.0);
    return sum;
  };
  // One test per set of directions (kConflictDetermined), each at the level over their number: the
  // one of the smaller p is reported, its p multiplied by their number (Bonferroni).
  constexpr auto kTests = static_cast<double>(std::size(kConflictDetermined));
  double best_p = 2.0;
  for (const double at_least : kConflictDetermined) {
    double chi_square = 0.0, expected_ms = 0.0;
    int dof = 0;
    Eigen::VectorXd difference = Eigen::VectorXd::Zero(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double lambda = std::min(eig.eigenvalues()(i), 1.0);
      if (!(lambda >= at_least)) continue;
      const double along = eig.eigenvectors().col(i).dot(w);
      chi_square += along * along / lambda;
      ++dof;
      const Eigen::VectorXd direction = l.triangularView<Eigen::Lower>() * eig.eigenvectors().col(i);
      difference += direction * (along / lambda);
      expected_ms += sphere_ms(direction) / lambda;
    }
    if (dof == 0) continue;
    const double p = gum::ChiSquareSf(chi_square, dof);
    if (!(p < best_p)) continue;
    best_p = p;
    k->conflict_chi_square = chi_square;
    k->conflict_dof = dof;
    k->conflict_p_value = std::min(1.0, kTests * p);
    k->difference_rms_um = std::sqrt(sphere_ms(difference)) * kUmPerMm;
    k->difference_expected_um = std::sqrt(expected_ms) * kUmPerMm;
  }
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
  std::vector<FormTerm> informed;
  for (const Eigen::Index i : in_prior) informed.push_back(prior.terms[static_cast<std::size_t>(i)]);
  PriorConflict(fit, group, l, w, in_model, informed, &k);
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
  const bool rejected = k.conflict_dof > 0 && k.conflict_p_value < kKnownFormP;
  k.exceeds_bound = !from_file && bound_rms_um && rejected;
  k.agrees = !rejected;
  const std::string test =
      k.conflict_dof == 0
          ? std::string("the readings determine none of its coefficients beside the model: not tested")
          : Format(
                "chi-square %.3g for %d directions they determine, p %s; their own estimate differs from it "
                "by %.3g um RMS over the sphere there, %.3g um expected from both uncertainties",
                k.conflict_chi_square, k.conflict_dof, PValueText(k.conflict_p_value).c_str(), k.difference_rms_um,
                k.difference_expected_um);
  if (k.exceeds_bound) {
    k.verdict = Format(
        "the sphere's form exceeds its certificate's bound sphere_form_rms_um %.3g um (k = 1): the readings "
        "reject the bound as a prior (%s)",
        *bound_rms_um, test.c_str());
    k.warnings.push_back(k.verdict +
                         ". The prior held the form small and the residual took the rest: the residual sigma, the "
                         "uncertainties and the effects found are not to be trusted. Check the sphere (damaged or "
                         "dirty, or not the certified one), or separate its form (--sphere-form)");
  } else if (k.agrees) {
    k.verdict = "the readings agree with the known form of " + source + " (" + test + ")";
  } else {
    k.verdict = "the readings reject the known form of " + source + " (" + test + ")";
    k.warnings.push_back(
        k.verdict +
        ". Likely causes: its orientation on the mount not the one the points file states "
        "(mount_rotation_deg@<setup>; none: the reference orientation), or the sphere damaged or dirty since its "
        "form was separated, or the form of another sphere");
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

StatementCheck StatementOf(const KnownFormCheck& k, StatementKind kind, const std::string& statement) {
  StatementCheck s;
  s.kind = kind;
  s.statement = statement;
  s.stated = kind == StatementKind::kFormBound
                 ? Format("a form of RMS %.3g um over the sphere at most (k = 1)", k.bound_rms_um.value_or(0.0))
                 : Format("a form of RMS %.3g um over the sphere, %d coefficients", k.known_rms_um, k.terms);
  s.readings = k.conflict_dof == 0 ? std::string("not determined")
               : kind == StatementKind::kFormBound
                   ? Format(
                         "a form of %.3g um RMS in the %d directions they determine (%.3g um expected within "
                         "the bound)",
                         k.difference_rms_um, k.conflict_dof, k.difference_expected_um)
                   : Format(
                         "a form that differs from it by %.3g um RMS in the %d directions they determine (%.3g um "
                         "expected from both uncertainties)",
                         k.difference_rms_um, k.conflict_dof, k.difference_expected_um);
  s.chi_square = k.conflict_chi_square;
  s.dof = k.conflict_dof;
  s.p_value = k.conflict_p_value;
  s.rejected = !k.agrees;
  s.verdict = k.verdict;
  return s;
}

namespace {

Eigen::Vector3d RotationVectorDeg(const Eigen::Matrix3d& r) {
  const Eigen::AngleAxisd aa(r);
  if (!(std::abs(aa.angle()) > 0.0)) return Eigen::Vector3d::Zero();
  return aa.axis() * aa.angle() / kRadPerDeg;
}

double AngleBetweenDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return std::abs(Eigen::AngleAxisd(a.transpose() * b).angle()) / kRadPerDeg;
}

// The 24 turns of a cube onto itself: the signed permutation matrices of determinant 1.
std::vector<Eigen::Matrix3d> RightAngleTurns() {
  std::vector<Eigen::Matrix3d> turns;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& p : perms) {
    for (int signs = 0; signs < 8; ++signs) {
      Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
      for (int row = 0; row < 3; ++row) m(row, p[row]) = (signs >> row) & 1 ? -1.0 : 1.0;
      if (m.determinant() > 0.0) turns.push_back(m);
    }
  }
  return turns;
}

// The fits of FitMountRotation(): the form held, every setup's centre and the seven errors fitted.
struct HeldFormFit {
  const PointsData& kept;
  CalibrationOptions held;
  EffectModel model;
  EffectFitStart start;
  int setup;

  // The fit with setup's mount rotation `r`.
  EffectFit At(const Eigen::Matrix3d& r) const {
    PointsData turned = kept;
    turned.header.mount_rotations[setup] = MountRotation::Known(RotationVectorDeg(r));
    EffectModel m = model;
    m.form = FormModelOf(turned, model.form.terms);
    return FitEffects(turned, held, m, start);
  }
};

}  // namespace

namespace {

// The fits with setup's mount rotation turned, the form held at its known value: `fit`'s model,
// its effects left out unless `keep_effects`.
HeldFormFit HeldFormFitOf(const PointsData& kept, const CalibrationOptions& options, const EffectFit& fit, int setup,
                          int prior_setup, bool keep_effects) {
  HeldFormFit f{kept, options, fit.model, EffectFitStart::From(fit), setup};
  f.held.analyse = false;
  f.held.prior_sigma_mm = fit.calibration.prior_sigma_mm;
  FormPrior& prior = prior_setup < 0 ? f.held.form_prior : f.held.other_form_priors.at(prior_setup);
  prior.covariance_mm2 *= 1e-6;
  if (!keep_effects) {
    f.model.terms.clear();
    f.start.values.clear();
  }
  return f;
}

Eigen::Matrix3d StatedRotation(const PointsData& points, int setup) {
  const auto it = points.header.mount_rotations.find(setup);
  return it == points.header.mount_rotations.end() || !it->second.known()
             ? Eigen::Matrix3d::Identity()
             : MountRotationMatrix(*it->second.rotation_deg);
}

}  // namespace

MountRotationFit BestRightAngleTurn(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                                    int setup, int prior_setup) {
  const PointsData kept = WithoutOutliers(points, fit.calibration);
  const HeldFormFit f = HeldFormFitOf(kept, options, fit, setup, prior_setup, false);
  MountRotationFit out;
  out.setup = setup;
  out.stated_rms_um = f.At(StatedRotation(kept, setup)).calibration.rms_um;
  out.rms_um = std::numeric_limits<double>::infinity();
  for (const Eigen::Matrix3d& t : RightAngleTurns()) {
    const double rms = f.At(t).calibration.rms_um;
    if (!(rms < out.rms_um)) continue;
    out.rms_um = rms;
    out.right_angle_deg = out.fitted_deg = RotationVectorDeg(t);
  }
  out.u_deg = std::numeric_limits<double>::infinity();
  return out;
}

MountRotationFit RefineMountRotation(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                                     int setup, int prior_setup) {
  const PointsData kept = WithoutOutliers(points, fit.calibration);
  const HeldFormFit f = HeldFormFitOf(kept, options, fit, setup, prior_setup, true);
  const Eigen::Matrix3d from = StatedRotation(kept, setup);
  MountRotationFit out;
  out.setup = setup;
  // Gauss-Newton on delta, R = exp(delta) from: J by central differences of the profiled residuals.
  constexpr double kStepRad = 0.25 * kRadPerDeg;
  constexpr double kMaxStepRad = 10.0 * kRadPerDeg;
  const auto turned = [&](const Eigen::Vector3d& delta) {
    return delta.norm() > 0.0 ? Eigen::Matrix3d(Eigen::AngleAxisd(delta.norm(), delta.normalized()) * from) : from;
  };
  const auto residuals = [](const EffectFit& e) {
    return Eigen::Map<const Eigen::VectorXd>(e.calibration.residuals_mm.data(),
                                             static_cast<Eigen::Index>(e.calibration.residuals_mm.size()));
  };
  Eigen::Vector3d delta = Eigen::Vector3d::Zero();
  EffectFit at = f.At(from);
  out.stated_rms_um = at.calibration.rms_um;
  Eigen::MatrixXd jac(static_cast<Eigen::Index>(at.calibration.residuals_mm.size()), 3);
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  const auto solve = [](const Eigen::Matrix3d& a, const Eigen::Vector3d& b) {  // a's pseudo-inverse times b
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(a);
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) {
      const double ev = eig.eigenvalues()(k);
      if (ev > 1e-9 * eig.eigenvalues().maxCoeff())
        x += eig.eigenvectors().col(k) * (eig.eigenvectors().col(k).dot(b) / ev);
    }
    return x;
  };
  for (int iteration = 0; iteration < 12; ++iteration) {
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d h = Eigen::Vector3d::Zero();
      h(k) = kStepRad;
      jac.col(k) = (residuals(f.At(turned(delta + h))) - residuals(f.At(turned(delta - h)))) / (2.0 * kStepRad);
    }
    normal = jac.transpose() * jac;
    Eigen::Vector3d step = -solve(normal, jac.transpose() * residuals(at));
    if (step.norm() > kMaxStepRad) step *= kMaxStepRad / step.norm();
    const EffectFit next = f.At(turned(delta + step));
    if (!(next.calibration.rms_um < at.calibration.rms_um)) break;
    delta += step;
    at = next;
    if (step.norm() < 1e-3 * kRadPerDeg) break;
  }
  const Eigen::Matrix3d fitted = turned(delta);
  out.fitted_deg = RotationVectorDeg(fitted);
  out.rms_um = at.calibration.rms_um;
  const auto m = static_cast<double>(at.calibration.residuals_mm.size());
  const double s2 = at.rss_mm2 / std::max(1.0, m - at.n_params - 3.0);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(normal);
  out.u_deg = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double ev = eig.eigenvalues()(k);
    const double var = ev > 1e-9 * eig.eigenvalues().maxCoeff() ? s2 / ev : std::numeric_limits<double>::infinity();
    out.u_deg = std::max(out.u_deg, std::sqrt(var) / kRadPerDeg);
  }
  out.offset_deg = std::numeric_limits<double>::infinity();
  for (const Eigen::Matrix3d& t : RightAngleTurns()) {
    const double angle = AngleBetweenDeg(t, fitted);
    if (angle < out.offset_deg) out.offset_deg = angle, out.right_angle_deg = RotationVectorDeg(t);
  }
  return out;
}

KnownFormCheck CheckOtherKnownForm(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                                   int setup, const std::string& source) {
  return Check(points, options, fit, source, std::nullopt, true, setup);
}

}  // namespace sph
