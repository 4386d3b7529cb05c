#include "solve_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <set>

#include <Eigen/Cholesky>

#include "block_factor.hpp"
#include "problem_eval.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/units.hpp"

namespace sph::internal {
namespace {

using internal::Format;

// The loss' usual scales in units of the noise: 95 % of the efficiency of least squares on Gaussian
// noise.
constexpr double kHuberScale = 1.345, kCauchyScale = 2.385;
// Refits until the noise the priors or the loss are scaled by holds to this, at most kMaxRounds.
constexpr double kSigmaTolerance = 1e-3;
constexpr int kMaxRounds = 20;

// The column of parameter `name` in `problem`, or -1 when its model has no such parameter.
Eigen::Index ColumnOf(const SphereFitProblem& problem, const std::string& name) {
  for (int k = 0; k < kNumScmsParams; ++k) {
    if (name == kScmsParamInfo[static_cast<std::size_t>(k)].name) return k;
  }
  Eigen::Index column = problem.FirstEffectColumn();
  for (const EffectTerm& term : problem.model().terms) {
    for (std::size_t i = 0; i < term.components.size(); ++i, ++column) {
      if (term.ParamName(i) == name) return column;
    }
  }
  return -1;
}

// The name of column `column` of `problem` (the seven errors and the effects).
std::string NameOf(const SphereFitProblem& problem, Eigen::Index column) {
  if (column < kNumScmsParams) return kScmsParamInfo[static_cast<std::size_t>(column)].name;
  Eigen::Index j = problem.FirstEffectColumn();
  for (const EffectTerm& term : problem.model().terms) {
    for (std::size_t i = 0; i < term.components.size(); ++i, ++j) {
      if (j == column) return term.ParamName(i);
    }
  }
  return "column " + std::to_string(column);
}

// A value of parameter `column` in its report unit, for messages.
std::string ValueText(const SphereFitProblem& problem, Eigen::Index column, double value) {
  const bool angle = column < kNumScmsParams
                         ? kScmsParamInfo[static_cast<std::size_t>(column)].quantity == Quantity::kAngle
                         : ParameterQuantity(NameOf(problem, column)) == Quantity::kAngle;
  return angle ? Format("%g deg", value / kRadPerDeg) : Format("%g mm", value);
}

// The options' bounds and, with `physical`, every fit's physical ones: one entry per column, the
// narrowest of both.
std::vector<ColumnBound> BoundsOf(const SphereFitProblem& problem, const CalibrationOptions& options, bool physical) {
  const double inf = std::numeric_limits<double>::infinity();
  std::map<Eigen::Index, ColumnBound> bounds;
  if (physical) {
    for (const int angle : {kAlpha, kBeta, kEpsilon}) bounds[angle] = {angle, -0.5 * kPi, 0.5 * kPi};
    bounds[kDPrime] = {kDPrime, -options.probe_offset_mm, inf};
  }
  for (const ParameterBound& b : options.bounds) {
    const Eigen::Index column = ColumnOf(problem, b.name);
    if (column < 0) continue;
    auto [it, added] = bounds.emplace(column, ColumnBound{column, b.lower, b.upper});
    if (!added) {
      it->second.lower = std::max(it->second.lower, b.lower);
      it->second.upper = std::min(it->second.upper, b.upper);
    }
  }
  std::vector<ColumnBound> out;
  for (const auto& [column, b] : bounds) out.push_back(b);
  return out;
}

double Median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// The readings' noise from their residuals (table-indexed): 1.4826 times the median absolute
// deviation, each setup about its own median, pooled; at least 1 nm (as the outlier rule's).
double RobustSigmaMm(const SphereFitProblem& problem, const std::vector<double>& residuals) {
  std::vector<double> deviations;
  for (int k = 0; k < problem.NumSetups(); ++k) {
    std::vector<double> e;
    for (const std::uint32_t row : problem.RowsOf(k)) e.push_back(residuals[row]);
    const double median = Median(e);
    for (const double v : e) deviations.push_back(std::abs(v - median));
  }
  return std::max(1.4826 * Median(deviations), 1e-6);
}

// The readings' sum of squares (weighted by `weights` when given) over the rows of `problem`.
double ReadingsRss(const SphereFitProblem& problem, const std::vector<double>& residuals,
                   const std::vector<double>& weights) {
  double rss = 0.0;
  for (int k = 0; k < problem.NumSetups(); ++k) {
    for (const std::uint32_t row : problem.RowsOf(k)) {
      rss += (weights.empty() ? 1.0 : weights[row]) * residuals[row] * residuals[row];
    }
  }
  return rss;
}

// The inverse of the normal matrix of the free columns (not held) at x, the readings' rows
// weighted by the square root of their loss weights, with the priors' rows; and the priors'
// leverage, sum_j (sigma / u_j)^2 [(J^T W J + P)^-1]_jj: what the priors determine of the
// parameters, from 0 (no information) to 1 each (a fix).
struct FreeInverse {
  NormalInverse inverse;
  double leverage = 0.0;
};

FreeInverse FreeInverseAt(const SphereFitProblem& problem, const Eigen::VectorXd& x, const std::vector<Held>& held_of,
                          const std::vector<ColumnPrior>& priors, const ColumnsPrior& form_prior, double prior_sigma_mm,
                          const std::vector<double>& weights) {
  const Eigen::Index n = problem.NumParams();
  const auto rows = static_cast<Eigen::Index>(problem.NumRows() + priors.size() + form_prior.columns.size());
  // The form prior's rows over all columns: sigma W at its columns.
  const auto k_form = static_cast<Eigen::Index>(form_prior.columns.size());
  Eigen::MatrixXd form_rows = Eigen::MatrixXd::Zero(k_form, n);
  for (Eigen::Index i = 0; i < k_form; ++i) {
    form_rows.col(form_prior.columns[static_cast<std::size_t>(i)]) = prior_sigma_mm * form_prior.whitening.col(i);
  }
  std::vector<bool> held(static_cast<std::size_t>(n), false);
  std::vector<Eigen::Index> free_index(static_cast<std::size_t>(n), -1);
  Eigen::Index n_free = 0;
  for (Eigen::Index j = 0; j < n; ++j) {
    held[static_cast<std::size_t>(j)] = held_of[static_cast<std::size_t>(j)] != Held::kNo;
    if (!held[static_cast<std::size_t>(j)]) free_index[static_cast<std::size_t>(j)] = n_free++;
  }
  std::vector<double> root;
  for (const double w : weights) root.push_back(std::sqrt(w));
  const double* row_weight = root.empty() ? nullptr : root.data();
  FreeInverse out;
  const int setups = problem.NumSetups();
  if (AnalyseByBlocks(setups, static_cast<int>(n) - 3 * setups)) {
    BlockFactor factor = problem.FactorBlocks(x.data(), nullptr, row_weight);
    for (const ColumnPrior& q : priors) {
      const auto f = static_cast<int>(q.column < kNumScmsParams ? q.column : q.column - 3 * setups);
      factor.AddSharedRow(f, prior_sigma_mm / q.u);
    }
    for (Eigen::Index r = 0; r < k_form; ++r) {
      Eigen::VectorXd row(n - 3 * setups);
      row << form_rows.row(r).head(kNumScmsParams).transpose(),
          form_rows.row(r).tail(n - kNumScmsParams - 3 * setups).transpose();
      factor.AddSharedRow(row);
    }
    out.inverse = factor.Without(held).Invert();
  } else {
    RowQr qr = problem.FactorJacobian(x.data(), nullptr, row_weight);
    for (const ColumnPrior& q : priors) {
      Eigen::VectorXd row = Eigen::VectorXd::Zero(n);
      row(q.column) = prior_sigma_mm / q.u;
      qr.AddRows(row.data(), n, 1);
    }
    for (Eigen::Index r = 0; r < k_form; ++r) {
      Eigen::VectorXd row = form_rows.row(r).transpose();
      qr.AddRows(row.data(), n, 1);
    }
    Eigen::MatrixXd r(n, n_free);
    for (Eigen::Index j = 0; j < n; ++j) {
      if (!held[static_cast<std::size_t>(j)]) r.col(free_index[static_cast<std::size_t>(j)]) = qr.r().col(j);
    }
    out.inverse = InvertNormalFactor(r, rows);
  }
  for (const ColumnPrior& q : priors) {
    const Eigen::Index j = free_index[static_cast<std::size_t>(q.column)];
    const double c = out.inverse.inverse(j, j);
    out.leverage += std::isfinite(c) ? std::pow(prior_sigma_mm / q.u, 2) * c : 1.0;
  }
  // The form prior's: trace(sigma^2 W C W^T) over its columns, C the inverse there.
  if (k_form > 0) {
    Eigen::MatrixXd c(k_form, k_form);
    for (Eigen::Index i = 0; i < k_form; ++i) {
      for (Eigen::Index j = 0; j < k_form; ++j) {
        c(i, j) =
            out.inverse.inverse(free_index[static_cast<std::size_t>(form_prior.columns[static_cast<std::size_t>(i)])],
                                free_index[static_cast<std::size_t>(form_prior.columns[static_cast<std::size_t>(j)])]);
      }
    }
    const double lev =
        prior_sigma_mm * prior_sigma_mm * (form_prior.whitening * c * form_prior.whitening.transpose()).trace();
    out.leverage += std::isfinite(lev) ? lev : static_cast<double>(k_form);
  }
  return out;
}

}  // namespace

namespace {

// One prior on the columns of the form's set `group`, appended to `out` (its whitening block
// diagonal: the sets' priors are independent).
void AppendFormPrior(const SphereFitProblem& problem, const FormPrior& prior, int group, ColumnsPrior& out) {
  const std::vector<FormTerm>& terms = problem.model().form.terms;
  std::vector<Eigen::Index> of_prior;  // the prior's index of each column taken
  const auto first = static_cast<Eigen::Index>(out.columns.size());
  for (std::size_t i = 0; i < prior.terms.size(); ++i) {
    const auto it = std::find(terms.begin(), terms.end(), prior.terms[i]);
    if (it == terms.end()) continue;
    of_prior.push_back(static_cast<Eigen::Index>(i));
    out.columns.push_back(problem.FirstFormColumn(group) + static_cast<Eigen::Index>(it - terms.begin()));
  }
  const auto k = static_cast<Eigen::Index>(of_prior.size());
  if (k == 0) return;
  Eigen::MatrixXd c(k, k);
  Eigen::VectorXd value(k);
  for (Eigen::Index i = 0; i < k; ++i) {
    value(i) = prior.mean_mm(of_prior[static_cast<std::size_t>(i)]);
    for (Eigen::Index j = 0; j < k; ++j) {
      c(i, j) = prior.covariance_mm2(of_prior[static_cast<std::size_t>(i)], of_prior[static_cast<std::size_t>(j)]);
    }
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(c);
  if (llt.info() != Eigen::Success) throw Error("the sphere form's prior: its covariance is not positive definite");
  const Eigen::Index n = first + k;
  out.value.conservativeResize(n);
  out.value.tail(k) = value;
  Eigen::MatrixXd whitening = Eigen::MatrixXd::Zero(n, n);
  whitening.topLeftCorner(first, first) = out.whitening;
  whitening.bottomRightCorner(k, k) = llt.matrixL().solve(Eigen::MatrixXd::Identity(k, k));
  out.whitening = std::move(whitening);
}

}  // namespace

ColumnsPrior FormPriorColumns(const SphereFitProblem& problem, const CalibrationOptions& options) {
  ColumnsPrior out;
  out.whitening.resize(0, 0);
  if (options.form_prior.Empty() || problem.NumFormTerms() == 0) return out;
  AppendFormPrior(problem, options.form_prior, 0, out);
  const FormModel& form = problem.model().form;
  std::set<int> groups{0};
  for (const auto& [setup, prior] : options.other_form_priors) {
    if (form.setups.count(setup) == 0) continue;  // a fit without that sphere's readings
    const int group = form.SetupOf(setup).group;
    if (group == 0 || !groups.insert(group).second) {
      throw Error("the form prior of another sphere by setup " + std::to_string(setup) +
                  ": the setup is not one of another sphere's set of known orientation, or that set has a prior "
                  "already");
    }
    AppendFormPrior(problem, prior, group, out);
  }
  return out;
}

NormalInverse InformedInverseAt(const SphereFitProblem& problem, const Eigen::VectorXd& x,
                                const CalibrationOptions& options, double prior_sigma_mm) {
  std::vector<ColumnPrior> priors;
  for (const ParameterPrior& p : options.priors) {
    const Eigen::Index column = ColumnOf(problem, p.name);
    if (column >= 0) priors.push_back({column, p.value, p.u});
  }
  const ColumnsPrior form_prior = FormPriorColumns(problem, options);
  if ((priors.empty() && form_prior.Empty()) || !(prior_sigma_mm > 0.0)) return NormalInverseAtSolution(problem, x);
  const std::vector<Held> none(static_cast<std::size_t>(problem.NumParams()), Held::kNo);
  return FreeInverseAt(problem, x, none, priors, form_prior, prior_sigma_mm, {}).inverse;
}

bool SolvedFit::Plain() const {
  return priors.empty() && form_prior.Empty() && weights.empty() &&
         std::all_of(held.begin(), held.end(), [](Held h) { return h == Held::kNo; });
}

void CheckParameterSettings(const CalibrationOptions& options, const std::string& source) {
  std::set<std::string> fixed;
  auto known = [&](const std::string& name, const char* what) {
    if (!ParameterQuantity(name)) {
      throw Error(source + ": " + what + " " + internal::Quoted(name) +
                  ": no such parameter (the seven errors alpha, a, beta, b, epsilon, c, d_prime, or an effect's, "
                  "e.g. theta_encoder.c2)");
    }
  };
  for (const FixedParameter& f : options.fixed) {
    known(f.name, "fixed parameter");
    if (!fixed.insert(f.name).second) throw Error(source + ": " + f.name + " is held twice");
    if (f.value && !std::isfinite(*f.value))
      throw Error(source + ": " + f.name + " is held at a value that is not finite");
  }
  std::set<std::string> informed;
  for (const ParameterPrior& p : options.priors) {
    known(p.name, "prior on");
    if (!informed.insert(p.name).second) throw Error(source + ": " + p.name + " has two priors");
    if (fixed.count(p.name) != 0) {
      throw Error(source + ": " + p.name + " is both held and given a prior: hold it, or inform it, not both");
    }
    if (!std::isfinite(p.value) || !(p.u > 0.0) || !std::isfinite(p.u)) {
      throw Error(source + ": the prior on " + p.name + " needs a finite value and a positive, finite uncertainty");
    }
  }
  for (const ParameterBound& b : options.bounds) {
    known(b.name, "bound on");
    if (!(b.lower < b.upper)) throw Error(source + ": the bounds of " + b.name + " leave no value between them");
  }
  if (options.robust_scale_sigma < 0.0 || !std::isfinite(options.robust_scale_sigma)) {
    throw Error(source + ": the robust loss' scale must be positive (in units of the noise)");
  }
}

SolvedFit SolveFit(const SphereFitProblem& problem, Eigen::VectorXd& x, const CalibrationOptions& options,
                   std::size_t n_samples, CalibrationResult& result, const std::string& source) {
  const Eigen::Index n = problem.NumParams();
  SolvedFit out;
  out.held.assign(static_cast<std::size_t>(n), Held::kNo);
  SolveConstraints c;
  for (const FixedParameter& f : options.fixed) {
    const Eigen::Index column = ColumnOf(problem, f.name);
    if (column < 0) continue;  // an effect this fit's model does not have
    if (f.value) x(column) = *f.value;
    c.fixed.push_back(column);
    out.held[static_cast<std::size_t>(column)] = Held::kFixed;
  }
  for (const ParameterPrior& p : options.priors) {
    const Eigen::Index column = ColumnOf(problem, p.name);
    if (column >= 0) out.priors.push_back({column, p.value, p.u});
  }
  out.form_prior = FormPriorColumns(problem, options);
  // The physical bounds go to Ceres only when a solution leaves them (below): with bounds Ceres
  // also searches along the projected step, which changes the iterations of a fit that never
  // comes near them.
  const std::vector<ColumnBound> all_bounds = BoundsOf(problem, options, true);
  c.bounds = BoundsOf(problem, options, false);
  for (const ColumnBound& b : all_bounds) {
    if (x(b.column) >= b.lower && x(b.column) <= b.upper) continue;
    throw Error(source + ": " + NameOf(problem, b.column) + " starts at " + ValueText(problem, b.column, x(b.column)) +
                ", outside its bounds (" + ValueText(problem, b.column, b.lower) + " to " +
                ValueText(problem, b.column, b.upper) + ")");
  }
  const bool loss = options.robust_loss != RobustLoss::kNone;
  result.n_points = static_cast<int>(n_samples);

  const auto m = static_cast<double>(problem.NumRows());
  const auto p = static_cast<double>(out.priors.size() + out.form_prior.columns.size());
  const double n_free = static_cast<double>(n) - static_cast<double>(c.fixed.size());
  std::vector<double> residuals(problem.table().size(), 0.0);
  SolveSummary summary;
  int iterations = 0;
  auto solve = [&](const SolveConstraints& with, std::unique_ptr<FitSolver>* keep = nullptr) {
    auto solver = std::make_unique<FitSolver>(problem, with);
    summary = solver->Solve(x, options.max_iterations);
    iterations += summary.iterations;
    problem.Residuals(x.data(), residuals.data());
    if (keep != nullptr) *keep = std::move(solver);
  };
  const Eigen::VectorXd start = x;
  const bool informed = !out.priors.empty() || !out.form_prior.Empty();
  const bool estimate_prior_sigma = informed && !(options.prior_sigma_mm > 0.0);
  const double scale_sigma = options.robust_scale_sigma > 0.0
                                 ? options.robust_scale_sigma
                                 : (options.robust_loss == RobustLoss::kCauchy ? kCauchyScale : kHuberScale);
  std::unique_ptr<FitSolver> last;
  auto run = [&] {
    x = start;
    iterations = 0;
    // The priors' sigma: given, or first that of the fit with the informed parameters held at their
    // values (then refitted below until it holds).
    double prior_sigma = options.prior_sigma_mm;
    if (estimate_prior_sigma) {
      SolveConstraints informed_held = c;
      for (const ColumnPrior& q : out.priors) {
        x(q.column) = q.value;
        informed_held.fixed.push_back(q.column);
      }
      for (Eigen::Index i = 0; i < out.form_prior.value.size(); ++i) {
        x(out.form_prior.columns[static_cast<std::size_t>(i)]) = out.form_prior.value(i);
        informed_held.fixed.push_back(out.form_prior.columns[static_cast<std::size_t>(i)]);
      }
      solve(informed_held);
      prior_sigma = std::sqrt(ReadingsRss(problem, residuals, {}) / std::max(1.0, m - (n_free - p)));
    }
    // The robust loss' noise: given, or none in the first round (least squares), then estimated.
    double loss_sigma = options.robust_sigma_mm;
    for (int round = 0; round < kMaxRounds; ++round) {
      SolveConstraints with = c;
      if (informed) {
        with.priors = out.priors;
        with.form_prior = out.form_prior;
        with.prior_sigma_mm = prior_sigma;
      }
      if (loss && loss_sigma > 0.0) {
        with.loss = options.robust_loss == RobustLoss::kCauchy ? LossKind::kCauchy : LossKind::kHuber;
        with.loss_scale_mm = scale_sigma * loss_sigma;
      }
      solve(with, &last);
      out.prior_sigma_mm = with.prior_sigma_mm;
      result.robust_sigma_mm = loss_sigma;
      result.robust_scale_mm = with.loss_scale_mm;
      bool again = false;
      if (loss && !(options.robust_sigma_mm > 0.0)) {
        const double sigma = RobustSigmaMm(problem, residuals);
        again |= !(std::abs(sigma - loss_sigma) <= kSigmaTolerance * sigma);
        loss_sigma = sigma;
      }
      if (estimate_prior_sigma) {
        // sigma^2 = the readings' sum of squares over their degrees of freedom: m - n_free plus
        // what the priors determine (their leverage at this sigma).
        std::vector<double> weights;
        if (with.loss != LossKind::kNone) {
          weights.assign(residuals.size(), 1.0);
          last->LossWeights(x, weights.data());
        }
        std::vector<Held> held(static_cast<std::size_t>(n), Held::kNo);
        for (const Eigen::Index column : c.fixed) held[static_cast<std::size_t>(column)] = Held::kFixed;
        const double leverage =
            FreeInverseAt(problem, x, held, out.priors, out.form_prior, prior_sigma, weights).leverage;
        const double sigma = std::sqrt(ReadingsRss(problem, residuals, weights) / std::max(1.0, m - n_free + leverage));
        again |= !(std::abs(sigma - prior_sigma) <= kSigmaTolerance * sigma);
        prior_sigma = sigma;
      }
      if (!again) break;
    }
  };
  run();
  const bool outside = std::any_of(all_bounds.begin(), all_bounds.end(), [&](const ColumnBound& b) {
    return !(x(b.column) >= b.lower && x(b.column) <= b.upper);
  });
  if (outside) {  // a solution beyond a physical bound: solved again within them
    c.bounds = all_bounds;
    run();
  }
  if (loss) {
    out.weights.assign(residuals.size(), 1.0);
    last->LossWeights(x, out.weights.data());
    result.robust_loss = options.robust_loss;
  }
  result.prior_sigma_mm = out.prior_sigma_mm;
  // A parameter that ended at a bound is held there.
  for (const ColumnBound& b : c.bounds) {
    Held& h = out.held[static_cast<std::size_t>(b.column)];
    if (h != Held::kNo) continue;
    const double v = x(b.column);
    auto at = [v](double bound) {
      return std::isfinite(bound) && std::abs(v - bound) <= 1e-9 * std::max(1.0, std::abs(bound));
    };
    if (at(b.lower)) h = Held::kAtLowerBound;
    if (at(b.upper)) h = Held::kAtUpperBound;
  }
  out.priors.erase(
      std::remove_if(out.priors.begin(), out.priors.end(),
                     [&](const ColumnPrior& q) { return out.held[static_cast<std::size_t>(q.column)] != Held::kNo; }),
      out.priors.end());
  result.converged = summary.converged;
  result.iterations = iterations;
  result.solver_message = summary.message;
  if (!result.converged) result.warnings.push_back("the solver did not converge: " + result.solver_message);
  return out;
}

double WeightedRss(const SphereFitProblem& problem, const SolvedFit& solved, const std::vector<double>& residuals) {
  return ReadingsRss(problem, residuals, solved.weights);
}

ObservabilityReport AnalyseSolved(const SphereFitProblem& problem, const Eigen::VectorXd& x, const SolvedFit& solved,
                                  double rss, std::vector<ParameterDescription> desc, double max_std_um) {
  const auto m = static_cast<Eigen::Index>(problem.NumRows());
  if (solved.Plain()) return AnalyseFit(NormalInverseAtSolution(problem, x), m, rss, std::move(desc), max_std_um);
  const Eigen::Index n = problem.NumParams();
  std::vector<ParameterDescription> free_desc;
  for (Eigen::Index j = 0; j < n; ++j) {
    if (solved.held[static_cast<std::size_t>(j)] == Held::kNo) free_desc.push_back(desc[static_cast<std::size_t>(j)]);
  }
  const auto n_free = static_cast<Eigen::Index>(free_desc.size());
  const FreeInverse inverse =
      FreeInverseAt(problem, x, solved.held, solved.priors, solved.form_prior, solved.prior_sigma_mm, solved.weights);
  // AnalyseFit() divides the sum of squares by (rows - free parameters): rows m + priors, and
  // the sum of squares that gives the residual variance of the readings over their degrees of
  // freedom m - n_free + the priors' leverage.
  const Eigen::Index rows = m + static_cast<Eigen::Index>(solved.priors.size() + solved.form_prior.columns.size());
  const double dof = static_cast<double>(m - n_free) + inverse.leverage;
  ObservabilityReport free = AnalyseFit(inverse.inverse, rows, rss / dof * static_cast<double>(rows - n_free),
                                        std::move(free_desc), max_std_um);
  free.degrees_of_freedom = dof;
  return WithHeldParameters(free, std::move(desc), solved.held);
}

void NoteWeightedReadings(const PointsData& points, const SolvedFit& solved, const std::vector<double>& residuals,
                          CalibrationResult& result) {
  if (solved.weights.empty()) return;
  result.weighted.clear();
  for (std::size_t i = 0; i < solved.weights.size() && i < points.samples.size(); ++i) {
    if (solved.weights[i] < 1.0) result.weighted.push_back({i, solved.weights[i], residuals[i] * kUmPerMm});
  }
  std::vector<WeightedReading> strongest = result.weighted;
  std::stable_sort(strongest.begin(), strongest.end(),
                   [](const WeightedReading& a, const WeightedReading& b) { return a.weight < b.weight; });
  result.warnings.push_back(
      Format("robust loss: %zu of %d readings weighted down (scale %.3g um, %.3g times the noise of %.3g um)",
             result.weighted.size(), result.n_points, result.robust_scale_mm * kUmPerMm,
             result.robust_scale_mm / result.robust_sigma_mm, result.robust_sigma_mm * kUmPerMm) +
      (strongest.empty() ? std::string() : ", the most: " + DescribeWeightedReadings(points, strongest)));
}

}  // namespace sph::internal
