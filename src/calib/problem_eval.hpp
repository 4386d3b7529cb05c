// Private to sph::calib: residuals and Jacobian of a solved ceres::Problem in file order, and the
// residual statistics every fit reports.
#ifndef SPH_SRC_CALIB_PROBLEM_EVAL_HPP_
#define SPH_SRC_CALIB_PROBLEM_EVAL_HPP_

#include <ceres/problem.h>
#include <ceres/solver.h>

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/calib/calibrator.hpp"
#include "sph/model/units.hpp"

namespace sph::internal {

/// The Levenberg-Marquardt settings of every calibration: dense QR, one thread, silent; stops on a
/// relative cost change of 1e-6 or a relative step of 1e-12.
inline ceres::Solver::Options CalibrationSolverOptions(int max_iterations) {
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::DENSE_QR;
  o.max_num_iterations = max_iterations;
  o.num_threads = 1;
  o.logging_type = ceres::SILENT;
  o.minimizer_progress_to_stdout = false;
  o.function_tolerance = 1e-6;
  o.gradient_tolerance = 1e-16;
  o.parameter_tolerance = 1e-12;
  return o;
}

/// Evaluates `problem` at its parameter blocks `blocks` (the Jacobian's column order). Ceres orders
/// the residuals by residual block; sample_of_row[k] is the sample (file row) of its k-th residual.
/// Fills the residuals in file order and, when `jacobian` is given, the dense Jacobian with its rows
/// in file order.
inline void EvaluateInFileOrder(ceres::Problem& problem, const std::vector<double*>& blocks,
                                const std::vector<std::size_t>& sample_of_row, Eigen::Index n_params,
                                std::vector<double>* residuals_mm, Eigen::MatrixXd* jacobian) {
  ceres::Problem::EvaluateOptions eval;
  eval.parameter_blocks = blocks;
  std::vector<double> residuals;
  ceres::CRSMatrix crs;
  double cost = 0.0;
  problem.Evaluate(eval, &cost, &residuals, nullptr, jacobian ? &crs : nullptr);
  residuals_mm->assign(residuals.size(), 0.0);
  for (std::size_t row = 0; row < residuals.size(); ++row) (*residuals_mm)[sample_of_row[row]] = residuals[row];
  if (!jacobian) return;
  *jacobian = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(residuals.size()), n_params);
  for (int row = 0; row < crs.num_rows; ++row) {
    const auto sample = static_cast<Eigen::Index>(sample_of_row[static_cast<std::size_t>(row)]);
    for (int idx = crs.rows[static_cast<std::size_t>(row)]; idx < crs.rows[static_cast<std::size_t>(row) + 1]; ++idx) {
      (*jacobian)(sample, crs.cols[static_cast<std::size_t>(idx)]) = crs.values[static_cast<std::size_t>(idx)];
    }
  }
}

/// The descriptions of the seven errors and of x, y, z of each setup's centre ("center_x@1" with
/// several setups), in the order of every calibration's parameter list.
inline std::vector<ParameterDescription> BaseParameterDescriptions(const std::vector<int>& setup_ids,
                                                                   double sphere_radius_mm) {
  std::vector<ParameterDescription> desc;
  for (const auto& info : kScmsParamInfo) desc.push_back({info.name, info.quantity, sphere_radius_mm});
  for (int id : setup_ids) {
    const std::string suffix = setup_ids.size() > 1 ? "@" + std::to_string(id) : "";
    for (const char* axis : {"center_x", "center_y", "center_z"}) desc.push_back({axis + suffix, Quantity::kLength, 1.0});
  }
  return desc;
}

/// result.rms_um and result.pv_um from result.residuals_mm.
inline void SetResidualStatistics(CalibrationResult& result) {
  const Eigen::Map<const Eigen::VectorXd> res(result.residuals_mm.data(),
                                              static_cast<Eigen::Index>(result.residuals_mm.size()));
  if (res.size() == 0) return;
  result.rms_um = std::sqrt(res.squaredNorm() / static_cast<double>(res.size())) * kUmPerMm;
  result.pv_um = (res.maxCoeff() - res.minCoeff()) * kUmPerMm;
}

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_PROBLEM_EVAL_HPP_
