// Private to sph::calib: FitEffects() on a ReadingTable and a subset of its rows, for callers that
// fit the same readings many times (the candidates and folds of a trace).
#ifndef SPH_SRC_CALIB_EFFECT_FIT_ROWS_HPP_
#define SPH_SRC_CALIB_EFFECT_FIT_ROWS_HPP_

#include <vector>

#include "fit_problem.hpp"
#include "sph/calib/effect_fit.hpp"
#include "sph/calib/observability.hpp"
#include "sph/calib/residual_structure.hpp"

namespace sph::internal {

/// FitEffects() of the samples of `table` (the readings of `points`) not marked in `left_out`
/// (table-indexed; null: all). Residuals in file order of the samples fitted.
EffectFit FitEffectsRows(const PointsData& points, const ReadingTable& table, const std::vector<bool>* left_out,
                         const CalibrationOptions& options, const EffectModel& model, const EffectFitStart& start);

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

/// (J^T J)^-1 of `fit`'s model at its parameters, over every sample of `table`.
NormalInverse NormalInverseAt(const ReadingTable& table, const CalibrationOptions& options, const EffectFit& fit);

/// The residuals [mm] of the samples of `table` not marked in `left_out` under the parameters of
/// `fit`, table-indexed (the others 0). Every setup with samples must be one of the fit's.
std::vector<double> ResidualsAt(const ReadingTable& table, const std::vector<bool>* left_out,
                                const CalibrationOptions& options, const EffectFit& fit, const std::string& source);

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_EFFECT_FIT_ROWS_HPP_
