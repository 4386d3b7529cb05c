// IdentifyForm(): the design's null space, see sph/calib/identifiability.hpp.
#include "sph/calib/identifiability.hpp"

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

}  // namespace

double FormIdentifiability::MaxVarianceInflation() const {
  return variance_inflation.empty() ? 0.0 : *std::max_element(variance_inflation.begin(), variance_inflation.end());
}

FormIdentifiability IdentifyForm(const PointsData& points, const CalibrationOptions& options, const EffectModel& model,
                                 const EffectFitStart& at, const std::vector<FormTerm>& form_terms,
                                 double max_singular_value) {
  FormIdentifiability out;
  if (form_terms.empty()) return out;
  EffectFit fit;
  fit.model = model;
  fit.model.form = FormModelOf(points, form_terms);
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

  const Eigen::MatrixXd j = JacobianAt(points, options, fit);
  if (j.rows() <= j.cols()) {
    throw Error(points.source + ": " + std::to_string(j.rows()) + " readings are too few to judge " +
                std::to_string(j.cols()) + " parameters");
  }
  const std::vector<ParameterDescription> desc =
      internal::ParameterDescriptions(fit.calibration.setup_ids, fit.model, options.sphere_radius_mm);

  // Unit columns. The machine's columns (seven errors, centres, effects) are first reduced to the
  // part the design determines by itself: directions of their own with singular values below the
  // bound are what the fit leaves out as not separable (an effect the pattern cannot see at all,
  // such as a wobble about the Phi frame's origin), and must not make the form look confounded.
  const Eigen::Index n_machine = fit.FormOffset(0), n_form = j.cols() - n_machine;
  Eigen::MatrixXd eq = j;
  Eigen::VectorXd scale(j.cols());
  for (Eigen::Index c = 0; c < j.cols(); ++c) {
    const double norm = j.col(c).norm();
    scale(c) = norm > 0.0 ? 1.0 / norm : 0.0;
    eq.col(c) *= scale(c);
  }
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

}  // namespace sph
