// Private to sph::calib: the seven-error calibration on a ReadingTable, for callers that calibrate
// the same readings many times (the Monte Carlo study) or a subset of them.
#ifndef SPH_SRC_CALIB_CALIBRATE_ROWS_HPP_
#define SPH_SRC_CALIB_CALIBRATE_ROWS_HPP_

#include <vector>

#include "fit_problem.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/sphere/sphere_fit.hpp"

namespace sph::internal {

/// The point [mm] of sample i of `table` under options.initial_geometry.
class StartPoints {
 public:
  StartPoints(const ReadingTable& table, const CalibrationOptions& options);
  Eigen::Vector3d operator()(std::size_t i) const;

 private:
  const ReadingTable& table_;
  ScmsGeometry g_;
  ScmsErrorTrig<double> trig_;
  double probe_offset_mm_;
};

/// The algebraic sphere fit of each setup of `table` (setup index order) to the StartPoints() of
/// the samples not marked in `left_out`: where the calibration starts.
std::vector<Sphere> StartSpheres(const ReadingTable& table, const CalibrationOptions& options,
                                 const std::vector<bool>* left_out);

/// One least-squares fit of the samples of `table` (the readings of `points`) not marked in
/// `left_out` (table-indexed; null: all). Residuals in file order of the samples fitted.
/// `start_spheres`: StartSpheres() when known.
CalibrationResult CalibrateRows(const PointsData& points, const ReadingTable& table, const std::vector<bool>* left_out,
                                const CalibrationOptions& options, const std::vector<Sphere>* start_spheres = nullptr);

/// Calibrate() of `points` whose readings `table` holds.
CalibrationResult CalibrateTable(const PointsData& points, const ReadingTable& table,
                                 const CalibrationOptions& options);

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_CALIBRATE_ROWS_HPP_
