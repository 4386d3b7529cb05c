// IdentifyForm(): the design's null space, see sph/select/identifiability.hpp.
#include "sph/select/identifiability.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <Eigen/SVD>

#include "problem_eval.hpp"
#include "sph/calib/observability.hpp"
#include "sph/core/error.hpp"

namespace sph {
namespace {

// "sphere_form.S(3,-2)" -> the form term, or false for any other parameter name.
bool FormTermOfName(const std::string& name, FormTerm* term) {
  if (name.rfind("sphere_form", 0) != 0) return false;
  const std::size_t open = name.find(".S(");
  return open != std::string::npos && std::sscanf(name.c_str() + open, ".S(%d,%d)", &term->l, &term->m) == 2;
}

std::string Words(const ConfoundedCombination& c) {
  std::string form, other;
  for (const auto& [name, coefficient] : c.terms) {
    FormTerm t;
    std::string& list = FormTermOfName(name, &t) ? form : other;
    list += (list.empty() ? "" : ", ") + name;
  }
  char ratio[32];
  std::snprintf(ratio, sizeof ratio, "%.2g", c.relative_singular_value);
  if (other.empty()) {
    return form + " move the readings alike (relative singular value " + ratio +
           "): the design cannot tell these terms of the sphere's form apart";
  }
  return form + " and " + other + " move the readings alike (relative singular value " + ratio +
         "): the design cannot tell this part of the sphere's form from the machine; its split is not known";
}

// The fit of `model` with the form terms `form_terms` (none: no form) at `at`, for judging the
// design of `points`: every setup's centre and every block as `at` gives it, or zero.
EffectFit FitToJudge(const PointsData& points, const EffectModel& model, const EffectFitStart& at,
                     const std::vector<FormTerm>& form_terms) {
  EffectFit fit;
  fit.model = model;
  fit.model.form = form_terms.empty() ? FormModel{} : FormModelOf(points, form_terms);
  fit.calibration.geometry = at.geometry;
  fit.calibration.centers_mm = at.centers_mm;
  fit.calibration.setup_ids = points.SetupIds();
  if (fit.calibration.centers_mm.size() != fit.calibration.setup_ids.size()) {
    throw Error(points.source + ": the design needs one centre per setup");
  }
  for (std::size_t t = 0; t < model.terms.size(); ++t) {
    const auto size = static_cast<std::size_t>(model.terms[t].size());
    fit.values.push_back(t < at.values.size() && at.values[t].size() == size ? at.values[t]
                                                                             : std::vector<double>(size, 0.0));
  }
  fit.form_values.assign(static_cast<std::size_t>(fit.model.form.NumGroups()),
                         std::vector<double>(form_terms.size(), 0.0));
  return fit;
}

// The Jacobian of `fit` on `points`, checked to have more readings than parameters.
Eigen::MatrixXd JacobianToJudge(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit) {
  Eigen::MatrixXd j = JacobianAt(points, options, fit);
  if (j.rows() <= j.cols()) {
    throw Error(points.source + ": " + std::to_string(j.rows()) + " readings are too few to judge " +
                std::to_string(j.cols()) + " parameters");
  }
  return j;
}

// A column whose rms sensitivity, displacement-equivalent (mm of reading per mm of parameter; an
// angle's column divided by its lever), is below this moves no reading: what is left of it is rounding (the derivative
// of the distance to a sphere's centre under a turn about an axis through that centre, for one), which unit columns
// would magnify into a direction of its own.
constexpr double kNoSensitivity = 1e-9;

// `j` with unit columns; a column that moves no reading (kNoSensitivity) is set to zero.
Eigen::MatrixXd UnitColumns(const Eigen::MatrixXd& j, const std::vector<ParameterDescription>& desc,
                            Eigen::VectorXd* scale = nullptr) {
  Eigen::MatrixXd eq = j;
  if (scale != nullptr) scale->resize(j.cols());
  const double rows = std::sqrt(static_cast<double>(std::max<Eigen::Index>(1, j.rows())));
  for (Eigen::Index c = 0; c < j.cols(); ++c) {
    const ParameterDescription& p = desc[static_cast<std::size_t>(c)];
    const double norm = j.col(c).norm();
    const double per_mm = norm / rows / (p.quantity == Quantity::kAngle ? p.lever_mm : 1.0);
    const double s = per_mm > kNoSensitivity ? 1.0 / norm : 0.0;
    eq.col(c) *= s;
    if (scale != nullptr) (*scale)(c) = s;
  }
  return eq;
}

// The orthonormal basis of what the unit columns `base` determine by themselves: their left
// singular vectors of relative singular value at least `max_singular_value`.
Eigen::MatrixXd DeterminedBasis(const Eigen::MatrixXd& base, double max_singular_value) {
  if (base.cols() == 0) return Eigen::MatrixXd(base.rows(), 0);
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(base, Eigen::ComputeThinU);
  Eigen::Index kept = 0;
  while (kept < svd.singularValues().size() && svd.singularValues()(kept) >= max_singular_value) ++kept;
  return svd.matrixU().leftCols(kept);
}

// The variance inflation of each column of m (the diagonal of (m^T m)^-1 for columns that were of
// unit norm before a projection). A column with a part in m's null space (a singular value below
// 1e-12 of the largest) has +inf; the others keep their finite value, so that the column to leave
// out is the one that is not determined, not the first.
Eigen::VectorXd VarianceInflations(const Eigen::MatrixXd& m) {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(m.cols());
  if (m.cols() == 0) return out;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(m, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const Eigen::MatrixXd& v = svd.matrixV();
  const double tiny = sv(0) * 1e-12;
  constexpr double kInNull = 1e-6;  // a column's share of a null direction that counts (as NormalInverse)
  for (Eigen::Index c = 0; c < m.cols(); ++c) {
    for (Eigen::Index k = 0; k < sv.size(); ++k) {
      if (sv(k) > tiny) {
        out(c) += v(c, k) * v(c, k) / (sv(k) * sv(k));
      } else if (std::abs(v(c, k)) > kInNull) {
        out(c) = std::numeric_limits<double>::infinity();
      }
    }
    if (std::isnan(out(c))) out(c) = std::numeric_limits<double>::infinity();
  }
  return out;
}

// The columns of `m` listed in `cols`.
Eigen::MatrixXd Columns(const Eigen::MatrixXd& m, const std::vector<Eigen::Index>& cols) {
  Eigen::MatrixXd out(m.rows(), static_cast<Eigen::Index>(cols.size()));
  for (std::size_t k = 0; k < cols.size(); ++k) out.col(static_cast<Eigen::Index>(k)) = m.col(cols[k]);
  return out;
}

}  // namespace

double FormIdentifiability::MaxVarianceInflation() const {
  return variance_inflation.empty() ? 0.0 : *std::max_element(variance_inflation.begin(), variance_inflation.end());
}

FormIdentifiability IdentifyForm(const PointsData& points, const CalibrationOptions& options, const EffectModel& model,
                                 const EffectFitStart& at, const std::vector<FormTerm>& form_terms,
                                 double max_singular_value) {
  FormIdentifiability out;
  if (form_terms.empty()) return out;
  const EffectFit fit = FitToJudge(points, model, at, form_terms);
  const Eigen::MatrixXd j = JacobianToJudge(points, options, fit);
  const std::vector<ParameterDescription> desc =
      internal::ParameterDescriptions(fit.calibration.setup_ids, fit.model, options.sphere_radius_mm);

  // Unit columns. The machine's columns (seven errors, centres, effects) are first reduced to the
  // part the design determines by itself: directions of their own with singular values below the
  // bound are what the fit leaves out as not separable (an effect the pattern cannot see at all,
  // such as a wobble about the Phi frame's origin), and must not make the form look confounded.
  const Eigen::Index n_machine = fit.FormOffset(0), n_form = j.cols() - n_machine;
  Eigen::VectorXd scale;
  const Eigen::MatrixXd eq = UnitColumns(j, desc, &scale);
  const Eigen::JacobiSVD<Eigen::MatrixXd> machine(eq.leftCols(n_machine), Eigen::ComputeThinU | Eigen::ComputeThinV);
  Eigen::Index kept = 0;
  while (kept < n_machine && machine.singularValues()(kept) >= max_singular_value) ++kept;
  // [U_kept F]: U_kept orthonormal, F the form's unit columns. A form column's variance inflation in
  // it is how much of it the determinable machine and the other form terms reproduce.
  Eigen::MatrixXd a(j.rows(), kept + n_form);
  a << machine.matrixU().leftCols(kept), eq.rightCols(n_form);
  const Eigen::JacobiSVD<Eigen::MatrixXd> joint(a, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = joint.singularValues();
  const Eigen::MatrixXd& v = joint.matrixV();
  const double max_vif = 1.0 / (max_singular_value * max_singular_value);
  // A term's inflation is its largest over the form's groups (one per orientation not known).
  out.variance_inflation.assign(form_terms.size(), 0.0);
  for (Eigen::Index c = kept; c < a.cols(); ++c) {
    double vif = 0.0;
    for (Eigen::Index k = 0; k < sv.size(); ++k) {
      vif += sv(k) > 0.0 ? v(c, k) * v(c, k) / (sv(k) * sv(k)) : std::numeric_limits<double>::infinity();
    }
    double& term = out.variance_inflation[static_cast<std::size_t>(c - kept) % form_terms.size()];
    term = std::isnan(vif) ? std::numeric_limits<double>::infinity() : std::max(term, vif);
  }
  for (std::size_t k = 0; k < form_terms.size(); ++k) {
    (out.variance_inflation[k] <= max_vif ? out.separable : out.confounded).push_back(form_terms[k]);
  }

  // The combinations, weakest first: the form's coefficients as they are, the machine's mapped back
  // from U_kept to its own parameters (x = V S^-1 U^T), displacement-equivalent as in the fit's
  // analysis (angles times R0).
  for (Eigen::Index k = sv.size() - 1; k >= 0 && sv(k) < max_singular_value; --k) {
    ConfoundedCombination comb;
    comb.relative_singular_value = sv(k) / sv(0);
    Eigen::VectorXd coef(j.cols());
    coef.head(n_machine) = machine.matrixV().leftCols(kept) *
                           (v.col(k).head(kept).array() / machine.singularValues().head(kept).array()).matrix();
    coef.tail(n_form) = v.col(k).tail(n_form);
    for (Eigen::Index c = 0; c < j.cols(); ++c) {
      const ParameterDescription& p = desc[static_cast<std::size_t>(c)];
      coef(c) *= scale(c) * (p.quantity == Quantity::kAngle ? p.lever_mm : 1.0);
    }
    const double top = coef.cwiseAbs().maxCoeff();
    if (!(top > 0.0)) continue;
    for (Eigen::Index c = 0; c < j.cols(); ++c) {
      if (std::abs(coef(c)) < 0.1 * top) continue;
      comb.terms.emplace_back(desc[static_cast<std::size_t>(c)].name, coef(c) / top);
      FormTerm t;
      if (FormTermOfName(desc[static_cast<std::size_t>(c)].name, &t) &&
          std::find(comb.form_terms.begin(), comb.form_terms.end(), t) == comb.form_terms.end()) {
        comb.form_terms.push_back(t);
      }
    }
    if (comb.form_terms.empty()) continue;
    comb.words = Words(comb);
    out.combinations.push_back(std::move(comb));
  }
  return out;
}

EffectSeparability IdentifyEffectPairs(const PointsData& points, const CalibrationOptions& options,
                                       const EffectModel& model, const EffectFitStart& at,
                                       const std::vector<FormTerm>& form_terms) {
  EffectSeparability out;
  const EffectFit fit = FitToJudge(points, model, at, form_terms);
  const Eigen::MatrixXd eq =
      UnitColumns(JacobianToJudge(points, options, fit),
                  internal::ParameterDescriptions(fit.calibration.setup_ids, fit.model, options.sphere_radius_mm));

  // The base (seven errors, centres, form) reduced to what it determines; every effect's columns
  // projected off it. A component's variance inflation in the whole model is then its own in the
  // projected columns of the effects beside it.
  const Eigen::Index n_base = fit.TermOffset(0);
  const Eigen::Index n_form = fit.model.form.Empty() ? 0 : eq.cols() - fit.FormOffset(0);
  Eigen::MatrixXd base(eq.rows(), n_base + n_form);
  base << eq.leftCols(n_base), eq.rightCols(n_form);
  const Eigen::MatrixXd u = DeterminedBasis(base, kConfoundedSingularValue);
  const Eigen::Index first = n_base, n_effects = eq.cols() - n_base - n_form;
  Eigen::MatrixXd q = eq.middleCols(first, n_effects);
  q -= u * (u.transpose() * q);

  // Each effect's determinable components (columns of q) and their inflation with it alone.
  const double max_vif = 1.0 / (kConfoundedSingularValue * kConfoundedSingularValue);
  struct Kept {
    Effect effect;
    std::vector<Eigen::Index> cols;
    Eigen::VectorXd alone;
  };
  std::vector<Kept> kept;
  for (std::size_t t = 0; t < model.terms.size(); ++t) {
    Kept k{model.terms[t].effect, {}, {}};
    for (int c = 0; c < model.terms[t].size(); ++c) k.cols.push_back(fit.TermOffset(t) - first + c);
    for (;;) {
      k.alone = VarianceInflations(Columns(q, k.cols));
      Eigen::Index worst = 0;
      if (k.cols.empty() || k.alone.maxCoeff(&worst) <= max_vif) break;
      k.cols.erase(k.cols.begin() + worst);
    }
    if (k.cols.empty()) {
      out.undetermined.push_back(k.effect);
    } else {
      kept.push_back(std::move(k));
    }
  }
  for (std::size_t i = 0; i < kept.size(); ++i) {
    for (std::size_t k = i + 1; k < kept.size(); ++k) {
      std::vector<Eigen::Index> cols = kept[i].cols;
      cols.insert(cols.end(), kept[k].cols.begin(), kept[k].cols.end());
      Eigen::VectorXd alone(static_cast<Eigen::Index>(cols.size()));
      alone << kept[i].alone, kept[k].alone;
      const Eigen::VectorXd both = VarianceInflations(Columns(q, cols));
      double factor = 1.0;
      for (Eigen::Index c = 0; c < both.size(); ++c) factor = std::max(factor, both(c) / alone(c));
      out.pairs.push_back({kept[i].effect, kept[k].effect, factor});
    }
  }
  return out;
}

}  // namespace sph
