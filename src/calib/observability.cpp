#include "sph/calib/observability.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

// Right singular vectors whose relative singular value is below this are listed as nearly
// dependent combinations (the weakest one is always listed).
constexpr double kWeakRatio = 1e-2;
// Coefficients below this fraction of the largest are left out of a combination.
constexpr double kTermCutoff = 0.1;

}  // namespace

bool ObservabilityReport::AllDetermined() const {
  return std::all_of(determined.begin(), determined.end(), [](bool d) { return d; });
}

double ObservabilityReport::StdAsDisplacementUm(int i) const {
  const ParameterDescription& p = parameters[static_cast<std::size_t>(i)];
  const double arm = p.quantity == Quantity::kAngle ? p.lever_mm : 1.0;
  return std(i) * arm * kUmPerMm;
}

std::string ObservabilityReport::UndeterminedText() const {
  std::string names;
  for (std::size_t i = 0; i < parameters.size(); ++i) {
    if (determined[i]) continue;
    const double disp = StdAsDisplacementUm(static_cast<int>(i));
    names += (names.empty() ? "" : ", ") + parameters[i].name +
             (std::isfinite(disp) ? " (std " + internal::Format("%.3g", disp) + " um)" : " (no information at all)");
  }
  return names;
}

namespace {

// The inverse, null space and condition of a Jacobian with `rows` rows from the singular values
// (descending) and right singular vectors of its column-equilibrated form, out.scale set.
NormalInverse& Finish(NormalInverse& out, Eigen::Index rows) {
  const Eigen::Index m = rows;
  const Eigen::Index n = out.scale.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out.inverse = Eigen::MatrixXd::Constant(n, n, nan);
  out.in_null.assign(static_cast<std::size_t>(n), true);
  out.condition_number = std::numeric_limits<double>::infinity();
  const Eigen::VectorXd& sv = out.singular_values;
  if (n == 0 || !(sv(0) > 0.0)) return out;
  out.condition_number = sv(n - 1) > 0.0 ? sv(0) / sv(n - 1) : std::numeric_limits<double>::infinity();

  // Numerical rank: singular values below this carry no information.
  const double tol = static_cast<double>(std::max(m, n)) * std::numeric_limits<double>::epsilon() * sv(0);
  for (Eigen::Index j = 0; j < n; ++j) out.in_null[static_cast<std::size_t>(j)] = out.scale(j) == 0.0;
  Eigen::MatrixXd inv_scaled = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    if (sv(k) > tol) {
      inv_scaled.noalias() += out.v.col(k) * out.v.col(k).transpose() / (sv(k) * sv(k));
    } else {
      for (Eigen::Index j = 0; j < n; ++j) {
        if (std::abs(out.v(j, k)) > 1e-6) out.in_null[static_cast<std::size_t>(j)] = true;
      }
    }
  }
  const Eigen::MatrixXd inverse = out.scale.asDiagonal() * inv_scaled * out.scale.asDiagonal();
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) {
      if (!out.in_null[static_cast<std::size_t>(i)] && !out.in_null[static_cast<std::size_t>(j)]) {
        out.inverse(i, j) = inverse(i, j);
      }
    }
  }
  return out;
}

// 1 / |column| (0 for a zero column) of a matrix whose column norms are `norms`.
Eigen::VectorXd InverseNorms(const Eigen::VectorXd& norms) {
  return norms.unaryExpr([](double v) { return v > 0.0 ? 1.0 / v : 0.0; });
}

// NormalInverse of a Jacobian with `rows` rows from the SVD of its column-equilibrated form A D,
// where A is the Jacobian or its triangular factor (same singular values and V).
NormalInverse FromEquilibrated(const Eigen::MatrixXd& a, Eigen::Index rows) {
  NormalInverse out;
  out.scale = InverseNorms(a.colwise().norm().transpose());
  const Eigen::JacobiSVD<Eigen::MatrixXd, Eigen::ColPivHouseholderQRPreconditioner> svd(a * out.scale.asDiagonal(),
                                                                                        Eigen::ComputeThinV);
  out.singular_values = svd.singularValues();
  out.v = svd.matrixV();
  return Finish(out, rows);
}

}  // namespace

NormalInverse InvertNormalMatrix(const Eigen::MatrixXd& jacobian) {
  return FromEquilibrated(jacobian, jacobian.rows());
}

NormalInverse InvertNormalFactor(const Eigen::MatrixXd& r, Eigen::Index rows) { return FromEquilibrated(r, rows); }

std::optional<NormalInverse> InvertNormalEquations(const Eigen::MatrixXd& jtj, Eigen::Index rows) {
  NormalInverse out;
  out.scale = InverseNorms(jtj.diagonal().cwiseMax(0.0).cwiseSqrt());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(out.scale.asDiagonal() * jtj * out.scale.asDiagonal());
  if (eig.info() != Eigen::Success) return std::nullopt;
  const Eigen::VectorXd& lambda = eig.eigenvalues();  // ascending
  const Eigen::Index n = lambda.size();
  if (n == 0 || !(lambda(0) > 0.0) || !(lambda(n - 1) < kMaxNormalCondition * lambda(0))) return std::nullopt;
  out.singular_values = lambda.reverse().cwiseSqrt();
  out.v = eig.eigenvectors().rowwise().reverse();
  return Finish(out, rows);
}

namespace {

// The report from the rows of J, its residual sum of squares and a way to get (J^T J)^-1.
template <typename Invert>
ObservabilityReport Analyse(const Invert& invert, Eigen::Index m, Eigen::Index n, double rss,
                            std::vector<ParameterDescription> params, double max_std_um) {
  ObservabilityReport rep;
  rep.parameters = std::move(params);
  rep.std = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  rep.covariance = Eigen::MatrixXd::Constant(n, n, std::numeric_limits<double>::quiet_NaN());
  rep.correlation = Eigen::MatrixXd::Constant(n, n, std::numeric_limits<double>::quiet_NaN());
  rep.determined.assign(static_cast<std::size_t>(n), false);
  rep.vif = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  rep.condition_number = std::numeric_limits<double>::infinity();
  if (m <= n || n == 0) return rep;

  rep.degrees_of_freedom = static_cast<double>(m - n);
  rep.residual_sigma_mm = std::sqrt(rss / rep.degrees_of_freedom);

  const NormalInverse inv = invert();
  rep.condition_number = inv.condition_number;
  const double s2 = rep.residual_sigma_mm * rep.residual_sigma_mm;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (inv.in_null[static_cast<std::size_t>(i)]) continue;
    // The column-equilibrated normal matrix has a unit diagonal, so its inverse's diagonal is the VIF.
    rep.vif(i) = inv.inverse(i, i) / (inv.scale(i) * inv.scale(i));
    rep.std(i) = std::sqrt(std::max(s2 * inv.inverse(i, i), 0.0));
    for (Eigen::Index j = 0; j < n; ++j) {
      if (!inv.in_null[static_cast<std::size_t>(j)]) rep.covariance(i, j) = s2 * inv.inverse(i, j);
    }
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) {
      const double denom = rep.std(i) * rep.std(j);
      if (std::isfinite(denom) && denom > 0.0) rep.correlation(i, j) = rep.covariance(i, j) / denom;
    }
    const double disp_um = rep.StdAsDisplacementUm(static_cast<int>(i));
    rep.determined[static_cast<std::size_t>(i)] = std::isfinite(disp_um) && disp_um <= max_std_um;
  }
  const Eigen::VectorXd& sv = inv.singular_values;
  const Eigen::MatrixXd& v = inv.v;
  const Eigen::VectorXd& scale = inv.scale;
  const double sv_max = sv(0);
  if (!(sv_max > 0.0)) return rep;

  // Nearly dependent combinations, weakest first, in displacement-equivalent coefficients.
  const Eigen::Index listed = sv.size();  // n, or fewer where only the weakest are known (many setups)
  for (Eigen::Index k = listed - 1; k >= 0; --k) {
    const double ratio = sv(k) / sv_max;
    if (ratio >= kWeakRatio && k != listed - 1) break;
    WeakCombination w;
    w.relative_singular_value = ratio;
    Eigen::VectorXd coef(n);
    for (Eigen::Index j = 0; j < n; ++j) {
      const ParameterDescription& p = rep.parameters[static_cast<std::size_t>(j)];
      coef(j) = v(j, k) * scale(j) * (p.quantity == Quantity::kAngle ? p.lever_mm : 1.0);
    }
    const double cmax = coef.cwiseAbs().maxCoeff();
    if (!(cmax > 0.0)) continue;
    coef /= cmax;
    // Sign convention: the largest coefficient is positive.
    Eigen::Index jmax = 0;
    coef.cwiseAbs().maxCoeff(&jmax);
    if (coef(jmax) < 0.0) coef = -coef;
    for (Eigen::Index j = 0; j < n; ++j) {
      if (std::abs(coef(j)) >= kTermCutoff) w.terms.emplace_back(static_cast<int>(j), coef(j));
    }
    std::sort(w.terms.begin(), w.terms.end(),
              [](const auto& a, const auto& b) { return std::abs(a.second) > std::abs(b.second); });
    rep.weak.push_back(std::move(w));
  }
  return rep;
}

}  // namespace

ObservabilityReport AnalyseFit(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residuals,
                               std::vector<ParameterDescription> params, double max_std_um) {
  return Analyse([&] { return InvertNormalMatrix(jacobian); }, jacobian.rows(), jacobian.cols(),
                 residuals.squaredNorm(), std::move(params), max_std_um);
}

ObservabilityReport AnalyseFactor(const Eigen::MatrixXd& r, Eigen::Index rows, double rss,
                                  std::vector<ParameterDescription> params, double max_std_um) {
  return Analyse([&] { return InvertNormalFactor(r, rows); }, rows, r.cols(), rss, std::move(params), max_std_um);
}

ObservabilityReport AnalyseFit(const NormalInverse& inverse, Eigen::Index rows, double rss,
                               std::vector<ParameterDescription> params, double max_std_um) {
  return Analyse([&] { return inverse; }, rows, inverse.scale.size(), rss, std::move(params), max_std_um);
}

ObservabilityReport WithHeldParameters(const ObservabilityReport& free, std::vector<ParameterDescription> parameters,
                                       const std::vector<Held>& held) {
  const auto n = static_cast<Eigen::Index>(parameters.size());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Eigen::Index> full;  // the column of each free parameter among all
  for (Eigen::Index j = 0; j < n; ++j) {
    if (held[static_cast<std::size_t>(j)] == Held::kNo) full.push_back(j);
  }
  ObservabilityReport out;
  out.parameters = std::move(parameters);
  out.held = held;
  out.std = Eigen::VectorXd::Zero(n);
  out.covariance = Eigen::MatrixXd::Zero(n, n);
  out.correlation = Eigen::MatrixXd::Constant(n, n, nan);
  out.determined.assign(static_cast<std::size_t>(n), true);
  out.vif = Eigen::VectorXd::Constant(n, nan);
  out.residual_sigma_mm = free.residual_sigma_mm;
  out.degrees_of_freedom = free.degrees_of_freedom;
  out.condition_number = free.condition_number;
  for (std::size_t a = 0; a < full.size(); ++a) {
    const auto i = static_cast<Eigen::Index>(a);
    out.std(full[a]) = free.std(i);
    out.vif(full[a]) = free.vif(i);
    out.determined[static_cast<std::size_t>(full[a])] = free.determined[a];
    for (std::size_t b = 0; b < full.size(); ++b) {
      const auto j = static_cast<Eigen::Index>(b);
      out.covariance(full[a], full[b]) = free.covariance(i, j);
      out.correlation(full[a], full[b]) = free.correlation(i, j);
    }
  }
  for (WeakCombination w : free.weak) {
    for (auto& [index, coefficient] : w.terms) index = static_cast<int>(full[static_cast<std::size_t>(index)]);
    out.weak.push_back(std::move(w));
  }
  return out;
}

}  // namespace sph
