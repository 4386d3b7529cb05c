// What a firmware host links to compensate readings and evaluate a sphere: the header-only model
// and sph::sphere, nothing else (no Ceres, no files).
#include "sph/model/compensation.hpp"
#include "sph/sphere/sphere_fit.hpp"
#include "sph/sphere/sphere_form.hpp"

#include <vector>

#include <gtest/gtest.h>

#ifdef CERES_VERSION_MAJOR
#error "a model or sphere header pulled in Ceres"
#endif

namespace sph {
namespace {

TEST(Host, CompensateAndEvaluateASphere) {
  // What a host does: readings of a sphere of radius 20 at the axes' common point, compensated
  // with a nominal calibration, then its least-squares and minimum-zone form.
  Calibration cal;
  cal.probe_offset_mm = 25.0;
  std::vector<RawReading> readings;
  for (int i = 0; i < 24; ++i) {
    for (int j = 0; j < 12; ++j) readings.push_back({15.0 * i, 7.5 + 15.0 * j, 5.0 + (j == 6 ? 1e-4 : 0.0)});
  }
  std::vector<Eigen::Vector3d> points(readings.size());
  Compensate(cal, readings.data(), readings.size(), points.data());
  const LeastSquaresSphere ls = FitSphereLeastSquares(points);
  ASSERT_TRUE(ls.sphere.ok);
  const MinimumZoneSphere mz = FitSphereMinimumZone(points, ls.sphere.center);
  ASSERT_TRUE(mz.ok);
  // One ring (phi = 97.5 deg) is 0.1 um low: the zone is exactly that, about the true centre.
  EXPECT_NEAR(mz.width, 1e-4, 1e-12);
  EXPECT_NEAR(mz.center.norm(), 0.0, 1e-10);
  EXPECT_LE(mz.width, RadialPeakToValley(points, ls.sphere.center));
}

}  // namespace
}  // namespace sph
