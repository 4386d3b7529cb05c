// The Ceres problem of a SphereFitProblem: the only translation unit of the fits with Ceres in it.
#include "ceres_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

#include <ceres/cost_function.h>
#include <ceres/crs_matrix.h>
#include <ceres/iteration_callback.h>
#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/ordered_groups.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <Eigen/Cholesky>

#include "sph/core/cancellation.hpp"

namespace sph::internal {
namespace {

// Ends a solve at its next iteration when the thread's cancellation was requested (Solve() then
// throws sph::Cancelled): no exception passes through Ceres.
class CancellationCallback : public ceres::IterationCallback {
 public:
  explicit CancellationCallback(const Cancellation* cancellation) : cancellation_(cancellation) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return cancellation_ != nullptr && cancellation_->Requested() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  const Cancellation* cancellation_;
};

// A setup's parameter blocks as Ceres passes them, in the order of SetupCost's blocks.
SetupParams SetupParamsOf(const SphereFitProblem& problem, double const* const* parameters) {
  SetupParams p;
  int b = 0;
  p.geometry = parameters[b++];
  p.center = parameters[b++];
  if (problem.NumEffectParams() > 0) p.effects = parameters[b++];
  if (problem.NumFormTerms() > 0) p.form = parameters[b++];
  return p;
}

// The readings first.. first + count - 1 of one setup as a Ceres cost function, its parameter
// blocks those of SphereFitProblem::EvaluateSetupRows().
class SetupCost final : public ceres::CostFunction {
 public:
  SetupCost(const SphereFitProblem& problem, int setup, int first, int count)
      : problem_(problem), setup_(setup), first_(first), count_(count) {
    set_num_residuals(count);
    std::vector<int>& sizes = *mutable_parameter_block_sizes();
    sizes = {kNumScmsParams, 3};
    if (problem.NumEffectParams() > 0) sizes.push_back(problem.NumEffectParams());
    if (problem.NumFormTerms() > 0) sizes.push_back(problem.NumFormTerms());
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const SetupParams p = SetupParamsOf(problem_, parameters);
    return problem_.EvaluateSetupRows(setup_, p, first_, count_, residuals, jacobians);
  }

 private:
  const SphereFitProblem& problem_;
  int setup_, first_, count_;
};

// All readings of one setup as n + 1 residuals, n the columns of its parameter blocks: with
// G = [J e]^T [J e] (summed over blocks of rows, as SphereFitProblem::Evaluate() sums the normal
// equations) and F any square factor of it, F^T F = G (from a pivoted LDL^T, which takes a
// semidefinite G), the residuals are F's last column and the Jacobian its others. Then the cost is
// e^T e, the gradient J^T e and the Gauss-Newton matrix J^T J, and the model of the cost along any
// step is that of the readings: Levenberg-Marquardt takes the same steps and accepts them by the
// same costs, with n + 1 rows instead of the setup's readings for Ceres to copy and check.
// Evaluated without a Jacobian (a trial step, of which only the cost is used) the residuals are
// (|e|, 0, ..., 0).
class CompressedSetupCost final : public ceres::CostFunction {
 public:
  CompressedSetupCost(const SphereFitProblem& problem, int setup) : problem_(problem), setup_(setup) {
    std::vector<int>& sizes = *mutable_parameter_block_sizes();
    sizes = {kNumScmsParams, 3};
    if (problem.NumEffectParams() > 0) sizes.push_back(problem.NumEffectParams());
    if (problem.NumFormTerms() > 0) sizes.push_back(problem.NumFormTerms());
    n_ = 0;
    for (const int size : sizes) n_ += size;
    set_num_residuals(n_ + 1);
    e_.resize(kChunk);
    for (const int size : sizes) jac_.emplace_back(static_cast<std::size_t>(kChunk * size));
    rows_.resize(static_cast<std::size_t>(kChunk * (n_ + 1)));
  }

  /// Used for a setup of this many readings or more (twice the rows it is compressed to).
  static int MinRows(const SphereFitProblem& problem) {
    return 2 * (kNumScmsParams + 3 + problem.NumEffectParams() + problem.NumFormTerms() + 1);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const SetupParams p = SetupParamsOf(problem_, parameters);
    const int m = problem_.SetupRows(setup_);
    const std::vector<int>& sizes = parameter_block_sizes();
    if (jacobians == nullptr) {
      double sum = 0.0;
      for (int first = 0; first < m; first += kChunk) {
        const int count = std::min(kChunk, m - first);
        if (!problem_.EvaluateSetupRows(setup_, p, first, count, e_.data(), nullptr)) return false;
        for (int i = 0; i < count; ++i) sum += e_[static_cast<std::size_t>(i)] * e_[static_cast<std::size_t>(i)];
      }
      residuals[0] = std::sqrt(sum);
      std::fill_n(residuals + 1, n_, 0.0);
      return true;
    }
    std::vector<double*> jp;
    for (auto& j : jac_) jp.push_back(j.data());
    const int stride = n_ + 1;
    gram_.setZero(stride, stride);
    for (int first = 0; first < m; first += kChunk) {
      const int count = std::min(kChunk, m - first);
      if (!problem_.EvaluateSetupRows(setup_, p, first, count, e_.data(), jp.data())) return false;
      for (int i = 0; i < count; ++i) {
        double* row = rows_.data() + i * stride;
        int col = 0;
        for (std::size_t k = 0; k < sizes.size(); ++k) {
          const int width = sizes[k];
          std::copy_n(jac_[k].data() + i * width, width, row + col);
          col += width;
        }
        row[n_] = e_[static_cast<std::size_t>(i)];
      }
      // The rows, row after row, are the columns of [J e]^T.
      gram_.selfadjointView<Eigen::Lower>().rankUpdate(Eigen::Map<const Eigen::MatrixXd>(rows_.data(), stride, count));
    }
    // G = P^T L D L^T P, hence F = D^(1/2) L^T P has F^T F = G. Where the readings leave a direction
    // undetermined G is singular: its pivots there are zero to rounding (clamped at 0, and Eigen's
    // "numerical issue" for them is no failure here).
    ldlt_.compute(gram_);
    const Eigen::VectorXd root = ldlt_.vectorD().cwiseMax(0.0).cwiseSqrt();
    upper_ = root.asDiagonal() * Eigen::MatrixXd(ldlt_.matrixU());
    perm_.setIdentity(stride, stride);
    perm_ = ldlt_.transpositionsP() * perm_;  // P as a matrix
    factor_.noalias() = upper_ * perm_;
    for (int i = 0; i <= n_; ++i) residuals[i] = factor_(i, n_);
    int col = 0;
    for (std::size_t k = 0; k < sizes.size(); ++k) {
      const int width = sizes[k];
      if (jacobians[k] != nullptr) {
        for (int i = 0; i <= n_; ++i) {
          for (int c = 0; c < width; ++c) jacobians[k][i * width + c] = factor_(i, col + c);
        }
      }
      col += width;
    }
    return factor_.allFinite();
  }

 private:
  static constexpr int kChunk = SphereFitProblem::kBlockRows;  // readings evaluated and summed at a time
  const SphereFitProblem& problem_;
  int setup_;
  int n_;
  // Scratch (a cost function is evaluated by one thread at a time: FitSolver is not thread-safe).
  mutable std::vector<double> e_;
  mutable std::vector<std::vector<double>> jac_;
  mutable std::vector<double> rows_;
  mutable Eigen::MatrixXd gram_, upper_, perm_, factor_;
  mutable Eigen::LDLT<Eigen::MatrixXd> ldlt_;
};

// A Gaussian prior on entry `index` of a parameter block of `size`: the residual w (x - value).
class PriorCost final : public ceres::CostFunction {
 public:
  PriorCost(int size, int index, double value, double weight) : index_(index), value_(value), weight_(weight) {
    set_num_residuals(1);
    *mutable_parameter_block_sizes() = {size};
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    residuals[0] = weight_ * (parameters[0][index_] - value_);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      std::fill_n(jacobians[0], parameter_block_sizes()[0], 0.0);
      jacobians[0][index_] = weight_;
    }
    return std::isfinite(residuals[0]);
  }

 private:
  int index_;
  double value_, weight_;
};

// A Gaussian prior on entries `index` of a parameter block of `size`: the residuals
// weight W (x_index - value), W lower triangular (the whitening of their covariance).
class WhitenedPriorCost final : public ceres::CostFunction {
 public:
  WhitenedPriorCost(int size, std::vector<int> index, Eigen::VectorXd value, Eigen::MatrixXd w)
      : index_(std::move(index)), value_(std::move(value)), w_(std::move(w)) {
    set_num_residuals(static_cast<int>(index_.size()));
    *mutable_parameter_block_sizes() = {size};
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const auto k = static_cast<Eigen::Index>(index_.size());
    Eigen::VectorXd d(k);
    for (Eigen::Index i = 0; i < k; ++i) d(i) = parameters[0][index_[static_cast<std::size_t>(i)]] - value_(i);
    Eigen::Map<Eigen::VectorXd>(residuals, k) = w_ * d;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      const int size = parameter_block_sizes()[0];
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(jacobians[0], k, size);
      jac.setZero();
      for (Eigen::Index i = 0; i < k; ++i) jac.col(index_[static_cast<std::size_t>(i)]) = w_.col(i);
    }
    return Eigen::Map<const Eigen::VectorXd>(residuals, k).allFinite();
  }

 private:
  std::vector<int> index_;
  Eigen::VectorXd value_;
  Eigen::MatrixXd w_;
};

std::unique_ptr<ceres::LossFunction> LossOf(LossKind kind, double scale) {
  switch (kind) {
    case LossKind::kHuber:
      return std::make_unique<ceres::HuberLoss>(scale);
    case LossKind::kCauchy:
      return std::make_unique<ceres::CauchyLoss>(scale);
    case LossKind::kNone:
      break;
  }
  return nullptr;
}

// Readings of one setup above which the centres are eliminated first (see Impl::Impl()).
constexpr std::size_t kSchurRows = 2000;

}  // namespace

struct FitSolver::Impl {
  const SphereFitProblem& problem;
  Eigen::VectorXd state;            // the parameter blocks' memory, laid out as x
  std::vector<double*> blocks;      // each parameter block's start in `state`
  std::vector<int> block_sizes;     // and its size
  std::vector<Eigen::Index> first;  // and its first column of x
  std::vector<Eigen::Index> fixed;  // columns held
  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
  std::unique_ptr<ceres::LossFunction> loss;
  std::vector<std::unique_ptr<ceres::Manifold>> manifolds;
  std::unique_ptr<ceres::Problem> ceres_problem;
  ceres::Solver::Options options;

  Impl(const SphereFitProblem& p, const SolveConstraints& c);
  // The block holding column `column` of x, and the column's index in it.
  std::pair<int, int> BlockOf(Eigen::Index column) const {
    const auto it = std::upper_bound(first.begin(), first.end(), column);
    const auto b = static_cast<int>(it - first.begin()) - 1;
    return {b, static_cast<int>(column - first[static_cast<std::size_t>(b)])};
  }
};

FitSolver::Impl::Impl(const SphereFitProblem& p, const SolveConstraints& c)
    : problem(p), state(Eigen::VectorXd::Zero(p.NumParams())), fixed(c.fixed) {
  // Parameter blocks in the column order of x.
  auto add_block = [&](Eigen::Index column, int size) {
    first.push_back(column);
    blocks.push_back(state.data() + column);
    block_sizes.push_back(size);
  };
  add_block(0, kNumScmsParams);
  for (int k = 0; k < p.NumSetups(); ++k) add_block(kNumScmsParams + 3 * k, 3);
  const int effects_block = p.NumEffectParams() > 0 ? static_cast<int>(blocks.size()) : -1;
  if (effects_block >= 0) add_block(p.FirstEffectColumn(), p.NumEffectParams());
  const int first_form_block = static_cast<int>(blocks.size());
  const int groups = p.NumFormTerms() > 0 ? p.model().form.NumGroups() : 0;
  for (int g = 0; g < groups; ++g) add_block(p.FirstFormColumn(g), p.NumFormTerms());

  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres_problem = std::make_unique<ceres::Problem>(po);
  ceres::Problem& problem_ = *ceres_problem;
  for (std::size_t b = 0; b < blocks.size(); ++b) problem_.AddParameterBlock(blocks[b], block_sizes[b]);
  loss = LossOf(c.loss, c.loss_scale_mm);
  for (int k = 0; k < p.NumSetups(); ++k) {
    std::vector<double*> used{blocks[0], blocks[static_cast<std::size_t>(1 + k)]};
    if (effects_block >= 0) used.push_back(blocks[static_cast<std::size_t>(effects_block)]);
    if (groups > 0) used.push_back(blocks[static_cast<std::size_t>(first_form_block + p.FormGroupOf(k))]);
    // Under a loss each reading is a residual block of its own (Ceres applies a loss to a block's
    // squared norm); without one a setup's readings are one block, compressed where they are many.
    const int rows = p.SetupRows(k);
    if (!loss && rows >= CompressedSetupCost::MinRows(p)) {
      costs.push_back(std::make_unique<CompressedSetupCost>(p, k));
      problem_.AddResidualBlock(costs.back().get(), nullptr, used);
      continue;
    }
    const int piece = loss ? 1 : rows;
    for (int first_row = 0; first_row < rows; first_row += piece) {
      costs.push_back(std::make_unique<SetupCost>(p, k, first_row, std::min(piece, rows - first_row)));
      problem_.AddResidualBlock(costs.back().get(), loss.get(), used);
    }
  }
  for (const ColumnPrior& prior : c.priors) {
    const auto [b, index] = BlockOf(prior.column);
    costs.push_back(std::make_unique<PriorCost>(block_sizes[static_cast<std::size_t>(b)], index, prior.value,
                                                c.prior_sigma_mm / prior.u));
    problem_.AddResidualBlock(costs.back().get(), nullptr, blocks[static_cast<std::size_t>(b)]);
  }
  // The form's prior, one residual block per set of coefficients (its whitening is block diagonal
  // by set: FormPriorColumns()).
  const auto n_form = static_cast<Eigen::Index>(c.form_prior.columns.size());
  for (Eigen::Index start = 0; start < n_form;) {
    const int b = BlockOf(c.form_prior.columns[static_cast<std::size_t>(start)]).first;
    Eigen::Index end = start;
    std::vector<int> index;
    while (end < n_form && BlockOf(c.form_prior.columns[static_cast<std::size_t>(end)]).first == b) {
      index.push_back(BlockOf(c.form_prior.columns[static_cast<std::size_t>(end)]).second);
      ++end;
    }
    const Eigen::Index k = end - start;
    costs.push_back(std::make_unique<WhitenedPriorCost>(
        block_sizes[static_cast<std::size_t>(b)], std::move(index), c.form_prior.value.segment(start, k),
        c.prior_sigma_mm * c.form_prior.whitening.block(start, start, k, k)));
    problem_.AddResidualBlock(costs.back().get(), nullptr, blocks[static_cast<std::size_t>(b)]);
    start = end;
  }
  // Fixed columns: a block wholly fixed is constant, a block partly fixed moves on the others.
  std::map<int, std::vector<int>> fixed_of_block;
  for (const Eigen::Index column : c.fixed) {
    const auto [b, index] = BlockOf(column);
    fixed_of_block[b].push_back(index);
  }
  for (auto& [b, indices] : fixed_of_block) {
    std::sort(indices.begin(), indices.end());
    indices.erase(std::unique(indices.begin(), indices.end()), indices.end());
    const int size = block_sizes[static_cast<std::size_t>(b)];
    if (static_cast<int>(indices.size()) == size) {
      problem_.SetParameterBlockConstant(blocks[static_cast<std::size_t>(b)]);
    } else {
      manifolds.push_back(std::make_unique<ceres::SubsetManifold>(size, indices));
      problem_.SetManifold(blocks[static_cast<std::size_t>(b)], manifolds.back().get());
    }
  }
  for (const ColumnBound& bound : c.bounds) {
    const auto [b, index] = BlockOf(bound.column);
    if (std::isfinite(bound.lower))
      problem_.SetParameterLowerBound(blocks[static_cast<std::size_t>(b)], index, bound.lower);
    if (std::isfinite(bound.upper))
      problem_.SetParameterUpperBound(blocks[static_cast<std::size_t>(b)], index, bound.upper);
  }

  // The linear solver (measured, bench/calibrate_bench.cpp): one setup of up to a few thousand
  // readings solves fastest on the normal equations; several setups, or more readings, eliminate
  // the centres first (a Schur complement over the seven errors, the effects and the form), which
  // keeps the cost linear in the number of setups.
  bool free_f = false;  // a block other than a centre that moves
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const bool centre = b >= 1 && b <= static_cast<std::size_t>(p.NumSetups());
    const auto it = fixed_of_block.find(static_cast<int>(b));
    if (!centre && (it == fixed_of_block.end() || static_cast<int>(it->second.size()) < block_sizes[b])) free_f = true;
  }
  const bool schur = free_f && (p.NumSetups() > 1 || p.NumRows() > kSchurRows);
  options.linear_solver_type = schur ? ceres::DENSE_SCHUR : ceres::DENSE_NORMAL_CHOLESKY;
  if (schur) {
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (std::size_t b = 0; b < blocks.size(); ++b) {
      const bool centre = b >= 1 && b <= static_cast<std::size_t>(p.NumSetups());
      ordering->AddElementToGroup(blocks[b], centre ? 0 : 1);
    }
    options.linear_solver_ordering = ordering;
  }
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  options.function_tolerance = 1e-6;
  options.gradient_tolerance = 1e-16;
  options.parameter_tolerance = 1e-12;
}

FitSolver::FitSolver(const SphereFitProblem& problem, const SolveConstraints& constraints)
    : impl_(std::make_unique<Impl>(problem, constraints)) {}

FitSolver::~FitSolver() = default;

SolveSummary FitSolver::Solve(Eigen::VectorXd& x, int max_iterations) {
  Impl& s = *impl_;
  s.state = x;
  s.options.max_num_iterations = max_iterations;
  ThrowIfCancelled();
  CancellationCallback cancellation(CurrentCancellation());
  s.options.callbacks = {&cancellation};
  ceres::Solver::Summary summary;
  ceres::Solve(s.options, s.ceres_problem.get(), &summary);
  s.options.callbacks.clear();
  ThrowIfCancelled();
  x = s.state;
  SolveSummary out;
  out.converged = summary.termination_type == ceres::CONVERGENCE;
  out.iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);  // iteration 0 is the start
  out.message = summary.message;
  return out;
}

void FitSolver::Evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* residuals, Eigen::MatrixXd* jacobian) {
  Impl& s = *impl_;
  s.state = x;
  ceres::Problem::EvaluateOptions eval;
  eval.parameter_blocks = s.blocks;
  eval.apply_loss_function = false;
  double cost = 0.0;
  std::vector<double> e;
  ceres::CRSMatrix crs;
  s.ceres_problem->Evaluate(eval, &cost, &e, nullptr, &crs);
  *residuals = Eigen::Map<const Eigen::VectorXd>(e.data(), static_cast<Eigen::Index>(e.size()));
  // Columns: the blocks in `blocks` order, which is the column order of x; a block partly fixed
  // (SubsetManifold) has a column for each of its free entries only.
  *jacobian = Eigen::MatrixXd::Zero(crs.num_rows, x.size());
  std::vector<Eigen::Index> column_of;
  for (std::size_t b = 0; b < s.blocks.size(); ++b) {
    const bool partly_fixed = s.ceres_problem->ParameterBlockTangentSize(s.blocks[b]) < s.block_sizes[b];
    for (int j = 0; j < s.block_sizes[b]; ++j) {
      const Eigen::Index column = s.first[b] + j;
      if (partly_fixed && std::find(s.fixed.begin(), s.fixed.end(), column) != s.fixed.end()) continue;
      column_of.push_back(column);
    }
  }
  for (int row = 0; row < crs.num_rows; ++row) {
    for (int k = crs.rows[static_cast<std::size_t>(row)]; k < crs.rows[static_cast<std::size_t>(row) + 1]; ++k) {
      (*jacobian)(row, column_of[static_cast<std::size_t>(crs.cols[static_cast<std::size_t>(k)])]) =
          crs.values[static_cast<std::size_t>(k)];
    }
  }
}

void FitSolver::LossWeights(const Eigen::VectorXd& x, double* weights) const {
  const Impl& s = *impl_;
  const SphereFitProblem& p = s.problem;
  std::vector<double> e;
  for (int k = 0; k < p.NumSetups(); ++k) {
    const std::vector<std::uint32_t>& rows = p.RowsOf(k);
    e.resize(rows.size());
    p.EvaluateSetupRows(k, p.ParamsOf(x.data(), k), 0, static_cast<int>(rows.size()), e.data(), nullptr);
    for (std::size_t i = 0; i < rows.size(); ++i) {
      double rho[3] = {e[i] * e[i], 1.0, 0.0};
      if (s.loss) s.loss->Evaluate(e[i] * e[i], rho);
      weights[rows[i]] = rho[1];
    }
  }
}

}  // namespace sph::internal
