// Private to sph::calib: the seven-error calibration on a ReadingTable, for callers that calibrate
// the same readings many times (the Monte Carlo study) or a subset of them.
#ifndef SPH_SRC_CALIB_CALIBRATE_ROWS_HPP_
#define SPH_SRC_CALIB_CALIBRATE_ROWS_HPP_

#include <vector>

#include "fit_problem.hpp"
#include "levenberg_marquardt.hpp"
#include "sph/calib/calibrator.hpp"

namespace sph::internal {

/// One least-squares fit of the samples of `table` (the readings of `points`) not marked in
/// `left_out` (table-indexed; null: all). Residuals in file order of the samples fitted.
/// `workspace` (optional) is reused across calls.
CalibrationResult CalibrateRows(const PointsData& points, const ReadingTable& table, const std::vector<bool>* left_out,
                                const CalibrationOptions& options, LmWorkspace* workspace = nullptr);

/// Calibrate() of `points` whose readings `table` holds.
CalibrationResult CalibrateTable(const PointsData& points, const ReadingTable& table, const CalibrationOptions& options,
                                 LmWorkspace* workspace = nullptr);

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_CALIBRATE_ROWS_HPP_
