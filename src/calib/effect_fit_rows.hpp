// Private to sph::calib: FitEffects() on a ReadingTable and a subset of its rows, for callers that
// fit the same readings many times (the candidates and folds of a trace).
#ifndef SPH_SRC_CALIB_EFFECT_FIT_ROWS_HPP_
#define SPH_SRC_CALIB_EFFECT_FIT_ROWS_HPP_

#include <string>
#include <vector>

#include "fit_problem.hpp"
#include "sph/calib/effect_fit.hpp"
#include "sph/calib/observability.hpp"

namespace sph::internal {

/// FitEffects() of the samples of `table` (the readings of `points`) not marked in `left_out`
/// (table-indexed; null: all). Residuals in file order of the samples fitted.
EffectFit FitEffectsRows(const PointsData& points, const ReadingTable& table, const std::vector<bool>* left_out,
                         const CalibrationOptions& options, const EffectModel& model, const EffectFitStart& start);

/// The centre of each setup of `table` that has rows in `rows`, from a fit over the setups
/// `fit_ids` with centres `centers`; a setup not among them is an error naming `source`.
std::vector<Eigen::Vector3d> CentersFor(const ReadingTable& table, const RowsOfSetup& rows,
                                        const std::vector<int>& fit_ids, const std::vector<Eigen::Vector3d>& centers,
                                        const std::string& source);

/// OffsetsFromCentre() and EffectResiduals() of samples whose directions of approach are
/// `approach` (one per sample), for a part of a file: MotionDirections() of the part alone would
/// give its first rows the direction of their own first move.
std::vector<Eigen::Vector3d> OffsetsFromCentreOf(const PointsData& points, const CalibrationOptions& options,
                                                 const EffectFit& fit, const std::vector<MotionDirection>& approach);
std::vector<double> EffectResidualsOf(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit,
                                      const std::vector<MotionDirection>& approach);

/// (J^T J + P)^-1 of `fit`'s model at its parameters, over every sample of `table`, P the rows of
/// the options' priors and form prior weighted with the readings' noise (options.prior_sigma_mm, or
/// the fit's CalibrationResult::prior_sigma_mm): what is known beside the readings separates too
/// (InformedInverseAt()). Nothing informed, or no noise known: (J^T J)^-1.
NormalInverse NormalInverseAt(const ReadingTable& table, const CalibrationOptions& options, const EffectFit& fit);

/// The residuals [mm] of the samples of `table` not marked in `left_out` under the parameters of
/// `fit`, table-indexed (the others 0). Every setup with samples must be one of the fit's.
std::vector<double> ResidualsAt(const ReadingTable& table, const std::vector<bool>* left_out,
                                const CalibrationOptions& options, const EffectFit& fit, const std::string& source);

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_EFFECT_FIT_ROWS_HPP_
