// A small linear programme in inequality form, min c^T x s.t. A x <= h, x in R^N, solved by a
// primal active-set method (the minimum-zone sphere's step, sph/sphere/sphere_form.hpp).
// Internal: included by src/sphere/sphere_form.cpp and its tests.
#ifndef SPH_SPHERE_INEQUALITY_LP_HPP_
#define SPH_SPHERE_INEQUALITY_LP_HPP_

#include <algorithm>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/QR>

namespace sph {

namespace internal {

enum class LpStatus { kOptimal, kUnbounded, kIterationLimit };

/// Minimises c^T x subject to A x <= h for x in R^N (N small), by a primal active-set method.
/// On entry x is feasible and `working` lists linearly independent rows of A active at x; on exit x
/// is optimal (kOptimal) and `working` its active set. `iterations` accumulates the iterations.
template <int N>
LpStatus SolveInequalityLp(const Eigen::Matrix<double, Eigen::Dynamic, N>& a, const Eigen::VectorXd& h,
                           const Eigen::Matrix<double, N, 1>& c, int max_iterations, Eigen::Matrix<double, N, 1>* x,
                           std::vector<int>* working, int* iterations) {
  using Vec = Eigen::Matrix<double, N, 1>;
  using WorkT = Eigen::Matrix<double, N, Eigen::Dynamic, 0, N, N>;  // A_W^T, at most N columns, no heap
  constexpr double kMultiplierTolerance = 1e-10;                    // rows and c are O(1): multipliers are O(1)
  constexpr double kDirectionTolerance = 1e-12;
  constexpr int kDegenerateRunForBland = 20;
  const Eigen::Index m = a.rows();
  Eigen::VectorXd slack = h - a * (*x);
  Eigen::VectorXd ap(m);
  std::vector<char> in_working(static_cast<std::size_t>(m), 0);
  for (const int w : *working) in_working[static_cast<std::size_t>(w)] = 1;
  int degenerate_run = 0;
  const double c_norm = c.norm();

  for (int it = 0; it < max_iterations; ++it) {
    ++*iterations;
    const int k = static_cast<int>(working->size());
    WorkT awt(N, k);
    for (int r = 0; r < k; ++r) awt.col(r) = a.row((*working)[static_cast<std::size_t>(r)]).transpose();
    // lambda = argmin |c + A_W^T lambda|; the residual c + A_W^T lambda is c projected onto the
    // null space of A_W, so p = -(c + A_W^T lambda) is the steepest descent within the face.
    const Eigen::ColPivHouseholderQR<WorkT> qr(awt);
    const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1> lambda =
        k > 0 ? Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1>(qr.solve(-c))
              : Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1>();
    Vec p = k > 0 ? Vec(-(c + awt * lambda)) : Vec(-c);
    if (k == N || p.norm() <= kDirectionTolerance * c_norm) {
      // c is in the row space: c + A_W^T lambda = 0, optimal when every lambda >= 0.
      const bool bland = degenerate_run >= kDegenerateRunForBland;
      int leave = -1;
      for (int j = 0; j < k; ++j) {
        if (!(lambda(j) < -kMultiplierTolerance)) continue;
        const int row = (*working)[static_cast<std::size_t>(j)];
        if (leave < 0 || (bland ? row < (*working)[static_cast<std::size_t>(leave)] : lambda(j) < lambda(leave)))
          leave = j;
      }
      if (leave < 0) return LpStatus::kOptimal;
      // Leave row `leave`, keep the others active: the min-norm p with A_W p = -e_leave, for which
      // c^T p = -lambda^T A_W p = lambda_leave < 0.
      Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1> e = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1>::Zero(k);
      e(leave) = -1.0;
      const Eigen::CompleteOrthogonalDecomposition<Eigen::Matrix<double, Eigen::Dynamic, N, 0, N, N>> cod(
          awt.transpose());
      p = cod.solve(e);
      in_working[static_cast<std::size_t>((*working)[static_cast<std::size_t>(leave)])] = 0;
      working->erase(working->begin() + leave);
    }

    // Ratio test: the first constraint that the move along p makes active (smallest index on ties).
    ap.noalias() = a * p;
    const double threshold = kDirectionTolerance * p.norm();
    double step = std::numeric_limits<double>::infinity();
    Eigen::Index block = -1;
    for (Eigen::Index i = 0; i < m; ++i) {
      if (in_working[static_cast<std::size_t>(i)] || !(ap(i) > threshold)) continue;
      const double t = std::max(slack(i), 0.0) / ap(i);
      if (t < step) {
        step = t;
        block = i;
      }
    }
    if (block < 0) return LpStatus::kUnbounded;
    *x += step * p;
    slack.noalias() -= step * ap;
    slack(block) = 0.0;
    working->push_back(static_cast<int>(block));
    in_working[static_cast<std::size_t>(block)] = 1;
    degenerate_run = step * p.norm() > 0.0 ? 0 : degenerate_run + 1;
  }
  return LpStatus::kIterationLimit;
}

}  // namespace internal

}  // namespace sph

#endif  // SPH_SPHERE_INEQUALITY_LP_HPP_
