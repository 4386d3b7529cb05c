#include "sph/core/calibration_file.hpp"

#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using ::testing::HasSubstr;

std::string ErrorReading(const std::string& path) {
  try {
    ReadCalibrationFile(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

void WriteText(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST(CalibrationFile, RoundTrips) {
  const std::string dir = sph::testing::MakeTempDir("calfile");
  CalibrationFile cal;
  cal.geometry = {3.5e-4, 0.002, 3.4e-4, 0.0019, 3.6e-4, 0.0021, -0.062};
  cal.probe_offset_mm = 25.0;
  cal.sphere_radius_mm = 20.0;
  Eigen::Matrix<double, 7, 7> cov = Eigen::Matrix<double, 7, 7>::Identity() * 1e-12;
  cov(0, 3) = cov(3, 0) = 2e-13;
  cal.covariance = cov;
  cal.created_by = "test";
  cal.source = {{"points_file", "x.txt"}};
  WriteCalibrationFile(dir + "/cal.json", cal);
  const CalibrationFile back = ReadCalibrationFile(dir + "/cal.json");
  for (int p = 0; p < kNumScmsParams; ++p) {
    EXPECT_NEAR(back.geometry[static_cast<std::size_t>(p)], cal.geometry[static_cast<std::size_t>(p)], 1e-15);
  }
  EXPECT_DOUBLE_EQ(back.probe_offset_mm, 25.0);
  ASSERT_TRUE(back.covariance.has_value());
  EXPECT_NEAR((*back.covariance)(0, 3), 2e-13, 1e-25);
  EXPECT_EQ(back.source, cal.source);
}

TEST(CalibrationFile, RejectsOtherFormatsAndMissingFields) {
  const std::string dir = sph::testing::MakeTempDir("calfile_bad");
  WriteText(dir + "/a.json", "not json");
  EXPECT_THAT(ErrorReading(dir + "/a.json"), HasSubstr("a.json: not valid JSON"));
  WriteText(dir + "/b.json", R"({"format": "other"})");
  EXPECT_THAT(ErrorReading(dir + "/b.json"), HasSubstr("not an sph calibration file"));
  WriteText(dir + "/c.json", R"({"format": "sph-calibration", "format_version": 2})");
  EXPECT_THAT(ErrorReading(dir + "/c.json"), HasSubstr("calibration format version 2 is not supported"));
  WriteText(dir + "/d.json", R"({"format": "sph-calibration", "format_version": 1, "probe_offset_mm": 25,
      "geometry": {"alpha": {"value": 0, "unit": "deg"}}, "effects": []})");
  EXPECT_THAT(ErrorReading(dir + "/d.json"), HasSubstr("missing field 'geometry.a'"));
  WriteText(dir + "/e.json", R"({"format": "sph-calibration", "format_version": 1})");
  EXPECT_THAT(ErrorReading(dir + "/e.json"), HasSubstr("missing field 'probe_offset_mm'"));
  EXPECT_THAT(ErrorReading(dir + "/none.json"), HasSubstr("none.json: cannot open"));
}

}  // namespace
}  // namespace sph
