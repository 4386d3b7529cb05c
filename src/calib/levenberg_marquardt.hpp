// Private to sph::calib: Levenberg-Marquardt on normal equations accumulated in one pass.
//
// The iteration is that of Ceres' trust-region minimizer with its Levenberg-Marquardt strategy
// (the solver these calibrations used before; same defaults): Jacobi scaling of the columns by
// 1 / (1 + |J_j|) fixed at the start, the step from (J^T J + D^T D / radius) dx = -J^T e with D^2
// the diagonal of J^T J clamped to [1e-6, 1e32], initial radius 1e4, a step taken when it achieves
// at least 1e-3 of the decrease the linear model predicts, the radius then divided by
// max(1/3, 1 - (2 rho - 1)^3), else halved, quartered, ...; it stops on a relative cost change
// below function_tolerance, a step below parameter_tolerance (|x| + parameter_tolerance), a
// gradient max norm below gradient_tolerance, or the iteration limit.
//
// What differs is the linear algebra: the problem gives J^T J, J^T e and the cost of a point in
// one pass over its residuals (streamed, no Jacobian held), and the step comes from a Cholesky
// factorisation of the small damped normal matrix (tens of columns). A candidate's normal equations
// are computed together with its cost; a step is taken far more often than not, and the pass
// then serves the next step. A step the linear model predicts to change the cost by less than twice
// the function tolerance, most likely the last, is tried on its cost alone first.
#ifndef SPH_SRC_CALIB_LEVENBERG_MARQUARDT_HPP_
#define SPH_SRC_CALIB_LEVENBERG_MARQUARDT_HPP_

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <string>

#include "sph/internal/format.hpp"

namespace sph::internal {

/// J^T J (full, symmetric), J^T e and the cost 1/2 e^T e at one point.
struct NormalEquations {
  Eigen::MatrixXd jtj;
  Eigen::VectorXd jte;
  double cost = 0.0;

  void SetZero(Eigen::Index n) {
    jtj.setZero(n, n);
    jte.setZero(n);
    cost = 0.0;
  }
};

struct LmOptions {
  int max_iterations = 100;
  double function_tolerance = 1e-6;
  double gradient_tolerance = 1e-16;
  double parameter_tolerance = 1e-12;
};

struct LmSummary {
  bool converged = false;
  /// Iterations completed (step taken or rejected); the last step, which met a tolerance, not
  /// counted (Ceres' count).
  int iterations = 0;
  std::string message;
  double initial_cost = 0.0;
  double final_cost = 0.0;
};

/// Scratch of SolveLevenbergMarquardt(), reusable across solves of one size without allocating.
struct LmWorkspace {
  NormalEquations at_x, at_candidate;
  Eigen::MatrixXd damped;
  Eigen::LLT<Eigen::MatrixXd> llt;
  Eigen::VectorXd scale, step, candidate, rhs, product;
};

/// Minimises the cost of `problem` from `x` (updated in place). `Problem` provides
///   Eigen::Index NumParams() const;
///   bool Evaluate(const double* x, NormalEquations* ne) const;   // false: not evaluable there
///   bool EvaluateCost(const double* x, double* cost) const;       // the same cost, bit for bit
/// filling ne completely (J^T J symmetric, both triangles).
template <typename Problem>
LmSummary SolveLevenbergMarquardt(const Problem& problem, Eigen::VectorXd& x, const LmOptions& options,
                                  LmWorkspace& w) {
  constexpr double kMinDiagonal = 1e-6, kMaxDiagonal = 1e32;
  constexpr double kMinRelativeDecrease = 1e-3;
  constexpr double kMaxRadius = 1e16, kMinRadius = 1e-32;
  constexpr int kMaxConsecutiveInvalidSteps = 5;
  constexpr double kProbeCostOnly = 2.0;
  const Eigen::Index n = problem.NumParams();
  LmSummary summary;
  if (!problem.Evaluate(x.data(), &w.at_x)) {
    summary.message = "the residuals cannot be evaluated at the start";
    return summary;
  }
  summary.initial_cost = summary.final_cost = w.at_x.cost;
  w.scale.resize(n);
  for (Eigen::Index j = 0; j < n; ++j) w.scale(j) = 1.0 / (1.0 + std::sqrt(w.at_x.jtj(j, j)));
  auto gradient_small = [&] {
    const double g = w.at_x.jte.lpNorm<Eigen::Infinity>();
    if (!(g <= options.gradient_tolerance)) return false;
    summary.converged = true;
    summary.message = Format("Gradient tolerance reached. Gradient max norm: %e <= %e", g, options.gradient_tolerance);
    return true;
  };
  if (gradient_small()) return summary;

  double radius = 1e4, decrease_factor = 2.0;
  int invalid_steps = 0;
  for (summary.iterations = 1; summary.iterations <= options.max_iterations; ++summary.iterations) {
    // The step in the scaled variables y = x / scale: (S J^T J S + diag(D^2) / radius) y = -S J^T e.
    w.damped.noalias() = w.scale.asDiagonal() * w.at_x.jtj * w.scale.asDiagonal();
    for (Eigen::Index j = 0; j < n; ++j) {
      w.damped(j, j) += std::clamp(w.damped(j, j), kMinDiagonal, kMaxDiagonal) / radius;
    }
    w.rhs = -(w.scale.array() * w.at_x.jte.array()).matrix();
    w.llt.compute(w.damped);
    bool valid = w.llt.info() == Eigen::Success;
    double model_decrease = 0.0;
    if (valid) {
      w.step = w.llt.solve(w.rhs);
      w.step.array() *= w.scale.array();
      // The decrease the linear model predicts: -(dx . J^T e + dx^T J^T J dx / 2).
      w.product.noalias() = w.at_x.jtj * w.step;
      model_decrease = -(w.step.dot(w.at_x.jte) + 0.5 * w.step.dot(w.product));
      valid = w.step.allFinite() && model_decrease > 0.0;
    }
    if (!valid) {
      if (++invalid_steps >= kMaxConsecutiveInvalidSteps) {
        summary.message = "Numerical failure: the step could not be computed";
        return summary;
      }
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      continue;
    }
    invalid_steps = 0;
    const double x_norm = x.norm();
    const double step_norm = w.step.norm();
    if (step_norm <= options.parameter_tolerance * (x_norm + options.parameter_tolerance)) {
      summary.converged = true;
      summary.message = Format("Parameter tolerance reached. Relative step_norm: %e <= %e",
                               step_norm / (x_norm + options.parameter_tolerance), options.parameter_tolerance);
      --summary.iterations;
      return summary;
    }
    w.candidate = x + w.step;
    auto function_tolerance_met = [&](double candidate_cost) {
      const double cost_change = std::abs(w.at_x.cost - candidate_cost);
      if (!(cost_change <= options.function_tolerance * w.at_x.cost)) return false;
      summary.converged = true;
      summary.message = Format("Function tolerance reached. |cost_change|/cost: %e <= %e", cost_change / w.at_x.cost,
                               options.function_tolerance);
      --summary.iterations;
      return true;
    };
    // Where the linear model predicts a change within twice the function tolerance, the step most
    // likely ends the solve, and its cost alone decides that first: J^T J there would go unused. If
    // it does not end it, Evaluate() follows (the same cost, and what follows as before).
    if (model_decrease <= kProbeCostOnly * options.function_tolerance * w.at_x.cost) {
      double cost = 0.0;
      if (problem.EvaluateCost(w.candidate.data(), &cost) && function_tolerance_met(cost)) return summary;
    }
    const bool evaluated = problem.Evaluate(w.candidate.data(), &w.at_candidate);
    if (evaluated && function_tolerance_met(w.at_candidate.cost)) return summary;
    const double cost_change = evaluated ? w.at_x.cost - w.at_candidate.cost : -HUGE_VAL;
    const double rho = cost_change / model_decrease;
    if (evaluated && rho > kMinRelativeDecrease) {
      x.swap(w.candidate);
      std::swap(w.at_x, w.at_candidate);
      summary.final_cost = w.at_x.cost;
      if (gradient_small()) return summary;
      radius = std::min(kMaxRadius, radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3)));
      decrease_factor = 2.0;
    } else {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < kMinRadius) {
        summary.converged = true;
        summary.message =
            Format("Minimum trust region radius reached. Trust region radius: %e <= %e", radius, kMinRadius);
        return summary;
      }
    }
  }
  summary.iterations = options.max_iterations;
  summary.message = Format("Maximum number of iterations reached. Number of iterations: %d.", options.max_iterations);
  return summary;
}

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_LEVENBERG_MARQUARDT_HPP_
