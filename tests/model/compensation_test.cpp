#include "sph/model/compensation.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "test_util.hpp"

namespace sph {
namespace {

using sph::testing::MatrixNear;

Calibration PaperCalibration() {
  Calibration cal;
  cal.geometry = {0.02 * kRadPerDeg, 0.002, 0.02 * kRadPerDeg, 0.002, 0.02 * kRadPerDeg, 0.002, -0.062};
  cal.probe_offset_mm = 25.0;
  return cal;
}

TEST(Compensate, WithoutErrorsIsSphericalCoordinates) {
  Calibration cal;
  cal.probe_offset_mm = 25.0;
  // p = (d - r) (sin phi cos theta, sin phi sin theta, cos phi), readings in deg.
  EXPECT_PRED_FORMAT3(MatrixNear, Compensate(cal, 0.0, 90.0, 5.0), Eigen::Vector3d(20, 0, 0), 1e-13);
  EXPECT_PRED_FORMAT3(MatrixNear, Compensate(cal, 0.0, 0.0, 5.0), Eigen::Vector3d(0, 0, 20), 1e-13);
  EXPECT_PRED_FORMAT3(MatrixNear, Compensate(cal, 90.0, 90.0, 15.0), Eigen::Vector3d(0, 10, 0), 1e-13);
  const double s = std::sqrt(0.5);
  EXPECT_PRED_FORMAT3(MatrixNear, Compensate(cal, 180.0, 45.0, 5.0), Eigen::Vector3d(-20 * s, 0, 20 * s), 1e-13);
}

TEST(Compensate, IsTheModelWithReadingsInDegrees) {
  const Calibration cal = PaperCalibration();
  for (const RawReading r : {RawReading{0.0, 7.5, 5.1}, RawReading{123.0, 97.5, 4.9}, RawReading{345.0, 172.5, 5.3}}) {
    const Eigen::Vector3d expected =
        ScmsPointDh(cal.geometry.data(), r.theta_deg * kPi / 180.0, r.phi_deg * kPi / 180.0, r.r_mm, 25.0);
    EXPECT_PRED_FORMAT3(MatrixNear, Compensate(cal, r), expected, 1e-13);
  }
  // An error changes the point: the probe zero lies at d + d' from the axes, so d' = -0.062 mm
  // brings every point 0.062 mm closer.
  Calibration nominal;
  nominal.probe_offset_mm = 25.0;
  Calibration dprime = nominal;
  dprime.geometry[kDPrime] = -0.062;
  EXPECT_PRED_FORMAT3(MatrixNear, Compensate(dprime, 0.0, 90.0, 5.0), Eigen::Vector3d(19.938, 0, 0), 1e-13);
}

// Readings in a type of the caller's, as a points file gives them.
struct HostReading {
  double theta_deg, phi_deg, r_mm;
  int status;
};

TEST(Compensate, BatchesEqualSingleReadings) {
  const Calibration cal = PaperCalibration();
  std::vector<RawReading> readings;
  std::vector<HostReading> host;
  for (int i = 0; i < 50; ++i) {
    readings.push_back({7.0 * i, 3.5 * i, 5.0 + 0.001 * i});
    host.push_back({7.0 * i, 3.5 * i, 5.0 + 0.001 * i, 0});
  }
  std::vector<Eigen::Vector3d> out(readings.size());
  Compensate(cal, readings.data(), readings.size(), out.data());
  const std::vector<Eigen::Vector3d> all = CompensateAll(cal, readings);
  const std::vector<Eigen::Vector3d> from_host = CompensateAll(cal, host);
  ASSERT_EQ(all.size(), readings.size());
  ASSERT_EQ(from_host.size(), readings.size());
  for (std::size_t i = 0; i < readings.size(); ++i) {
    const Eigen::Vector3d single = Compensate(cal, readings[i]);
    EXPECT_EQ(out[i], single);
    EXPECT_EQ(all[i], single);
    EXPECT_EQ(from_host[i], single);
  }
}

TEST(Calibration, IsValidOnlyWithAPositiveOffsetAndFiniteValues) {
  Calibration cal = PaperCalibration();
  EXPECT_TRUE(cal.IsValid());
  cal.covariance = ScmsCovariance::Identity() * 1e-12;
  EXPECT_TRUE(cal.IsValid());
  Calibration bad = cal;
  bad.probe_offset_mm = 0.0;
  EXPECT_FALSE(bad.IsValid());
  bad = cal;
  bad.geometry[kBeta] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(bad.IsValid());
  bad = cal;
  (*bad.covariance)(2, 3) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(bad.IsValid());
}

}  // namespace
}  // namespace sph
