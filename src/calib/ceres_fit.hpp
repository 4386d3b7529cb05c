// Private to sph::calib: every fit's solve, by Ceres (ceres::Problem, ceres::Solve).
//
// The parameters are those of a SphereFitProblem, x = [g | centre of each setup | effects | form
// of each group]; Ceres sees them as parameter blocks: the seven errors, each centre, all effect
// parameters, each form group's coefficients. Each setup's readings are one residual block whose
// cost function evaluates them with the problem's hand-derived Jacobian in blocks of rows
// (SphereFitProblem::EvaluateSetupRows()); a setup of many readings is compressed to n + 1
// residuals with the same cost, gradient and J^T J (n its parameters), so that Ceres' own work per
// iteration does not grow with the readings. Under a robust loss each reading is a residual block
// of its own, for Ceres' loss functions apply to a residual block as a whole. What a solve holds,
// informs and bounds (SolveConstraints) maps onto Ceres: fixed columns onto constant blocks or a
// SubsetManifold, priors onto residual blocks of their own, bounds onto the problem's bounds.
//
// No Ceres type appears here: this header is included where the fits are set up, the Ceres
// templates are compiled once, in ceres_fit.cpp.
#ifndef SPH_SRC_CALIB_CERES_FIT_HPP_
#define SPH_SRC_CALIB_CERES_FIT_HPP_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fit_problem.hpp"

namespace sph::internal {

/// A Gaussian prior on one column of x: its value and standard uncertainty (internal units).
struct ColumnPrior {
  Eigen::Index column = 0;
  double value = 0.0;
  double u = 0.0;  ///< > 0
};

/// A Gaussian prior on several columns of x at once: the residuals whitening (x_cols - value),
/// whitening = L^-1 with L L^T their covariance (internal units), times the priors' sigma.
struct ColumnsPrior {
  std::vector<Eigen::Index> columns;  ///< of one parameter block
  Eigen::VectorXd value;
  Eigen::MatrixXd whitening;  ///< lower triangular, columns.size() square
  bool Empty() const { return columns.empty(); }
};

/// Bounds of one column of x (internal units; -inf or +inf where it has none).
struct ColumnBound {
  Eigen::Index column = 0;
  double lower = 0.0;
  double upper = 0.0;
};

enum class LossKind { kNone, kHuber, kCauchy };

/// What a solve holds at its value, informs by a prior and bounds, in columns of x, and the loss
/// of each reading.
struct SolveConstraints {
  std::vector<Eigen::Index> fixed;  ///< held at their value in x
  /// Each prior is the residual (x_j - value) sigma / u beside the readings' residuals [mm]: with
  /// sigma the readings' noise, the sum of squares is then sigma^2 times the weighted one.
  std::vector<ColumnPrior> priors;
  ColumnsPrior form_prior;      ///< the sphere's form as known: sigma whitening (c - value)
  double prior_sigma_mm = 0.0;  ///< sigma of the priors' weights (> 0 when there are priors)
  std::vector<ColumnBound> bounds;
  LossKind loss = LossKind::kNone;
  double loss_scale_mm = 0.0;  ///< the loss' scale: residuals beyond it are weighted down

  bool Empty() const {
    return fixed.empty() && priors.empty() && form_prior.Empty() && bounds.empty() && loss == LossKind::kNone;
  }
};

/// How a solve ended.
struct SolveSummary {
  bool converged = false;
  /// Iterations completed (step taken or rejected); the last, which met a tolerance, not counted.
  int iterations = 0;
  std::string message;  ///< Ceres' termination message
};

/// The Ceres problem of a SphereFitProblem (which must outlive it), solved from any start. Every fit
/// builds its own: kept across the Monte Carlo's trials (the same rows, other readings) it saved
/// nothing measurable (bench/montecarlo_bench.cpp), for with one residual block per setup building
/// it costs microseconds. Not thread-safe.
class FitSolver {
 public:
  explicit FitSolver(const SphereFitProblem& problem, const SolveConstraints& constraints = {});
  ~FitSolver();
  FitSolver(const FitSolver&) = delete;
  FitSolver& operator=(const FitSolver&) = delete;

  /// Minimises from x (updated in place; the fixed columns keep their values) with the
  /// calibrations' settings: Levenberg-Marquardt stopping on a relative cost change of 1e-6 or a
  /// relative step of 1e-12, at most max_iterations iterations. Throws sph::Cancelled when the
  /// thread's cancellation (sph/core/cancellation.hpp) is requested before or during the solve.
  SolveSummary Solve(Eigen::VectorXd& x, int max_iterations);

  /// The residuals and the Jacobian (columns as x) of every residual block at x as Ceres evaluates
  /// them (ceres::Problem::Evaluate, no loss applied): setup after setup, its readings (rows
  /// ascending) or, for a setup compressed, its n + 1 rows, then the priors. The readings' own
  /// residuals come from the SphereFitProblem, not from here.
  void Evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* residuals, Eigen::MatrixXd* jacobian);

  /// The weight rho'(e^2) of each residual of x under the loss (1 without one), table-indexed (rows
  /// not in the problem untouched): what the readings count for in the robust fit.
  void LossWeights(const Eigen::VectorXd& x, double* weights) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_CERES_FIT_HPP_
