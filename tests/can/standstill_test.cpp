#include "sph/can/standstill.hpp"

#include <gtest/gtest.h>

namespace sph::can {
namespace {

Sample At(double theta, double phi, double r, double t) { return Sample{theta, phi, r, t, 0}; }

// Feeds a sample at its own time (small times: t_s holds whole nanoseconds).
std::optional<StopPoint> Add(StandstillDetector& d, const Sample& s) { return d.Add(s, std::llround(s.t_s * 1e9)); }

TEST(Standstill, DwellExcludesSettlingAndScatterIsTheSampleSd) {
  StandstillDetector d({0.01, 0.1, 0.0, 2});
  std::optional<StopPoint> p;
  for (int k = 0; k <= 30; ++k) EXPECT_FALSE(Add(d, At(10.0, 20.0, k < 10 ? 9.0 : (k % 2 ? 1.0 : 3.0), k * 0.01)));
  p = Add(d, At(11.0, 20.0, 0.0, 0.31));  // moved: the stop ends
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->n, 21);  // t = 0.10 .. 0.30
  EXPECT_NEAR(p->mean.r_mm, (11 * 3.0 + 10 * 1.0) / 21, 1e-12);
  EXPECT_NEAR(p->sd_r_mm, std::sqrt(21.0 / 20.0 * (1.0 - std::pow((11 * 3.0 + 10 * 1.0) / 21 - 2.0, 2))), 1e-12);
  EXPECT_NEAR(p->mean.t_s, 0.20, 1e-12);
  EXPECT_NEAR(p->duration_s, 0.20, 1e-12);
}

TEST(Standstill, ThetaAveragesAcrossZero) {
  StandstillDetector d({0.01, 0.0, 0.0, 1});
  Add(d, At(359.999, 5.0, 1.0, 0.0));
  Add(d, At(0.001, 5.0, 1.0, 0.1));
  Add(d, At(359.999, 5.0, 1.0, 0.2));
  Add(d, At(0.001, 5.0, 1.0, 0.3));
  const auto p = d.Finish();
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR(p->mean.theta_deg, 0.0, 1e-9);  // 359.999 and 0.001 are 0.002 deg apart, mean 0 (not 180)
}

TEST(Standstill, ShortStopsAreCountedNotEmitted) {
  StandstillDetector d({0.01, 0.0, 0.0, 5});
  Add(d, At(1.0, 1.0, 1.0, 0.0));
  Add(d, At(1.0, 1.0, 1.0, 0.1));
  EXPECT_FALSE(Add(d, At(2.0, 1.0, 1.0, 0.2)).has_value());
  EXPECT_EQ(d.short_stops(), 1);
}

TEST(Standstill, AverageTimeLimitsThePoint) {
  StandstillDetector d({0.01, 0.0, 0.05, 1});
  std::optional<StopPoint> p;
  for (int k = 0; k < 20 && !p; ++k) p = Add(d, At(1.0, 1.0, 1.0, k * 0.01));
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->n, 6);  // t = 0.00 .. 0.05
  for (int k = 20; k < 40; ++k) EXPECT_FALSE(Add(d, At(1.0, 1.0, 1.0, k * 0.01)).has_value());
  EXPECT_FALSE(d.Finish().has_value());  // the rest of this stop is not a second point
}

TEST(Standstill, MotionNeverMakesAPoint) {
  StandstillDetector d({0.001, 0.005, 0.0, 1});
  for (int k = 0; k < 100; ++k) EXPECT_FALSE(Add(d, At(k * 0.01, 1.0, 1.0, k * 0.001)).has_value());
  EXPECT_EQ(d.short_stops(), 0);
}

}  // namespace
}  // namespace sph::can
