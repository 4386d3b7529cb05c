// Private to sph::calib: FitEffects() on a ReadingTable and a subset of its rows, for callers that
// fit the same readings many times (the candidates and folds of a trace).
#ifndef SPH_SRC_CALIB_EFFECT_FIT_ROWS_HPP_
#define SPH_SRC_CALIB_EFFECT_FIT_ROWS_HPP_

#include <vector>

#include "fit_problem.hpp"
#include "levenberg_marquardt.hpp"
#include "sph/calib/effect_fit.hpp"

namespace sph::internal {

/// FitEffects() of the samples of `table` (the readings of `points`) not marked in `left_out`
/// (table-indexed; null: all). Residuals in file order of the samples fitted.
EffectFit FitEffectsRows(const PointsData& points, const ReadingTable& table, const std::vector<bool>* left_out,
                         const CalibrationOptions& options, const EffectModel& model, const EffectFitStart& start,
                         LmWorkspace* workspace = nullptr);

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_EFFECT_FIT_ROWS_HPP_
