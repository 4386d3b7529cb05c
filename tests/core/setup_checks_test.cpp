#include "sph/io/setup_checks.hpp"

#include <functional>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/core/error.hpp"

namespace sph {
namespace {

PointsData Parse(const std::string& text) {
  std::istringstream in(text);
  return ParsePoints(in, "p.txt");
}

std::string MessageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(CheckReadingsInProbeRange, NamesTheFirstReadingOutsideAtItsLineAndCountsThem) {
  const PointsData p = Parse("# sph-points 1\n# probe_range_mm: 0.002\n0 45 0.001\n90 45 4.5\n180 45 -0.5\n");
  EXPECT_EQ(MessageOf([&] { CheckReadingsInProbeRange(p, 0.002, "probe_range_mm"); }),
            "p.txt:4: r_mm 4.5 lies outside the probe's measuring range, 0 to 0.002 mm (probe_range_mm): 2 of 3 "
            "readings do (they span -0.5 to 4.5 mm); a probe reads nothing beyond its range, so the range or the "
            "readings are not this probe's");
  EXPECT_THAT(MessageOf([&] { CheckReadingsInProbeRange(p, 10.0, "--probe-range-mm"); }),
              ::testing::HasSubstr("p.txt:5: r_mm -0.5 lies outside the probe's measuring range, 0 to 10 mm "
                                   "(--probe-range-mm): 1 of 3 readings do"));
}

TEST(CheckReadingsInProbeRange, TakesReadingsFromZeroToTheRangeItself) {
  const PointsData p = Parse("0 45 0\n90 45 2\n180 45 1.5\n");
  EXPECT_NO_THROW(CheckReadingsInProbeRange(p, 2.0, "probe_range_mm"));
  EXPECT_THAT(MessageOf([&] { CheckReadingsInProbeRange(p, 1.999, "--probe-range-mm"); }),
              ::testing::HasSubstr("p.txt:2: r_mm 2 lies outside the probe's measuring range, 0 to 1.999 mm "
                                   "(--probe-range-mm): 1 of 3 readings do"));
}

TEST(CheckProbeOffsetMatches, RefusesReadingsOfAnotherProbeOffset) {
  const PointsData p = Parse("# probe_offset_mm: 30\n0 45 4.9\n");
  EXPECT_EQ(MessageOf([&] { CheckProbeOffsetMatches(p, 25.0, "cal.json"); }),
            "p.txt: probe_offset_mm 30 differs from the calibration's 25 (cal.json): the calibration belongs to "
            "another probe set-up");
  EXPECT_EQ(MessageOf([&] { CheckProbeOffsetMatches(p, 25.0, ""); }),
            "p.txt: probe_offset_mm 30 differs from the calibration's 25: the calibration belongs to another probe "
            "set-up");
  EXPECT_NO_THROW(CheckProbeOffsetMatches(p, 30.0 * (1 + 1e-12), "cal.json"));
  EXPECT_NO_THROW(CheckProbeOffsetMatches(Parse("0 45 4.9\n"), 25.0, "cal.json"));  // not stated: the calibration's
}

TEST(SphereRadiusOfSetup, IsTheSetupsOwnSphereElseTheReferenceSphere) {
  const PointsData p = Parse(
      "# sphere_radius_mm: 20\n# sphere_radius_mm@1: 10\n# columns: theta_deg phi_deg r_mm setup\n0 45 4.9 0\n"
      "0 45 4.9 1\n");
  const auto zero = SphereRadiusOfSetup(p.header, 0), one = SphereRadiusOfSetup(p.header, 1);
  ASSERT_TRUE(zero && one);
  EXPECT_EQ(zero->radius_mm, 20.0);
  EXPECT_EQ(zero->key, "sphere_radius_mm");
  EXPECT_EQ(one->radius_mm, 10.0);
  EXPECT_EQ(one->key, "sphere_radius_mm@1");
  EXPECT_FALSE(SphereRadiusOfSetup(Parse("0 45 4.9\n").header, 0).has_value());
}

}  // namespace
}  // namespace sph
