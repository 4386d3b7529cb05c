// Private to the selection: a fit's Jacobian, from the fit engine's problem, as the residual
// structure analysis takes it (JacobianBlocks of sph/select/residual_structure.hpp).
#ifndef SPH_SRC_SELECT_STRUCTURE_JACOBIAN_HPP_
#define SPH_SRC_SELECT_STRUCTURE_JACOBIAN_HPP_

#include <vector>

#include "fit_problem.hpp"
#include "sph/calib/effect_fit.hpp"
#include "sph/select/residual_structure.hpp"

namespace sph::internal {

/// The Jacobian of `fit` over every sample of `table` (the readings it was fitted to, all of them),
/// block by block, as the residual structure analysis needs it: at the readings `expected_r_mm`
/// (table-indexed) where the fit's residual vanishes (ExpectedReadings()).
class StructureJacobian final : public JacobianBlocks {
 public:
  StructureJacobian(const ReadingTable& table, const CalibrationOptions& options, const EffectFit& fit,
                    const std::vector<double>& expected_r_mm);
  Eigen::Index Cols() const override { return problem_.NumParams(); }
  void ForEach(const BlockFn& fn) const override;
  /// Each setup's centre (the rows come setup after setup).
  std::vector<Eigen::Index> GroupColumns() const override;

 private:
  SphereFitProblem problem_;
  Eigen::VectorXd x_;
  std::vector<double> offset_;  // r + offset: the readings where the fit's residual vanishes
};

}  // namespace sph::internal

#endif  // SPH_SRC_SELECT_STRUCTURE_JACOBIAN_HPP_
