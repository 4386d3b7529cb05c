#include "sph/io/xyz_file.hpp"

#include <fstream>
#include <limits>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using sph::testing::MatrixNear;
using ::testing::HasSubstr;

std::vector<Eigen::Vector3d> Parse(const std::string& text) {
  std::istringstream in(text);
  return ParseXyz(in, "p.xyz");
}

std::string ErrorParsing(const std::string& text) {
  try {
    Parse(text);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(XyzFile, ReadsPlainLinesWithCommentsTabsCommasAndCrlf) {
  const auto pts = Parse("# x y z\n1 2 3\r\n\n\t-4.5\t5e-3\t+6\r\n7,8,9\n  # indented comment\n");
  ASSERT_EQ(pts.size(), 3u);
  EXPECT_PRED_FORMAT3(MatrixNear, pts[0], Eigen::Vector3d(1, 2, 3), 0.0);
  EXPECT_PRED_FORMAT3(MatrixNear, pts[1], Eigen::Vector3d(-4.5, 5e-3, 6), 0.0);
  EXPECT_PRED_FORMAT3(MatrixNear, pts[2], Eigen::Vector3d(7, 8, 9), 0.0);
}

TEST(XyzFile, ReadsTheNistLayoutWithItsCountLine) {
  const auto pts = Parse("2\r\n-648.78997\t244.45589\t710.25315\r\n-646.3582\t244.08709\t710.28793\r\n");
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_EQ(pts[1].x(), -646.3582);
  EXPECT_THAT(ErrorParsing("3\n1 2 3\n4 5 6\n"),
              HasSubstr("p.xyz:1: the count line announces 3 points, but the file holds 2"));
}

TEST(XyzFile, ReadsTheCopiedNistFile) {
  const auto pts = ReadXyzFile(SPH_TEST_DATA_DIR "/nist-ats-l2-sphere/sph1.ds");
  ASSERT_EQ(pts.size(), 169u);
  EXPECT_PRED_FORMAT3(MatrixNear, pts.front(), Eigen::Vector3d(-648.78997, 244.45589, 710.25315), 0.0);
}

TEST(XyzFile, NamesFileLineAndProblem) {
  EXPECT_THAT(ErrorParsing("1 2 3\n1 2\n"), HasSubstr("p.xyz:2: expected 3 numbers (x y z), found 2 fields"));
  EXPECT_THAT(ErrorParsing("1 2 3 4\n"), HasSubstr("p.xyz:1: expected 3 numbers (x y z), found 4 fields"));
  EXPECT_THAT(ErrorParsing("1 2 3\n1 abc 3\n"), HasSubstr("p.xyz:2: y: 'abc' is not a number"));
  EXPECT_THAT(ErrorParsing("nan 2 3\n"), HasSubstr("p.xyz:1: x: 'nan' is not a finite number"));
  EXPECT_THAT(ErrorParsing("1 2 1e999\n"), HasSubstr("p.xyz:1: z: '1e999' is out of the range of a double"));
  EXPECT_THAT(ErrorParsing("# nothing\n\n"), HasSubstr("p.xyz: no points"));
  EXPECT_THAT(ErrorParsing("0\n"), HasSubstr("p.xyz: no points"));
  EXPECT_THAT(ErrorParsing(std::string("1 2 3\n4 \0 6\n", 12)), HasSubstr("p.xyz:2: binary data"));
  EXPECT_THROW(ReadXyzFile("/nonexistent/p.xyz"), Error);
}

TEST(XyzFile, RoundTripsWithTenDecimals) {
  const std::string dir = sph::testing::MakeTempDir("xyz");
  const std::vector<Eigen::Vector3d> pts{Eigen::Vector3d(1.0 / 3.0, -2.0, 1e-7),
                                         Eigen::Vector3d(-650.123456789012, 0, 3)};
  WriteXyzFile(dir + "/p.xyz", pts, {"made by a test", "columns: x_mm y_mm z_mm"});
  std::ifstream in(dir + "/p.xyz");
  std::string first;
  std::getline(in, first);
  EXPECT_EQ(first, "# made by a test");
  const auto back = ReadXyzFile(dir + "/p.xyz");
  ASSERT_EQ(back.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) EXPECT_PRED_FORMAT3(MatrixNear, back[i], pts[i], 5e-11);
}

TEST(XyzFile, WritesTheLargestFiniteValuesWhole) {
  constexpr double kMax = std::numeric_limits<double>::max();
  const std::vector<Eigen::Vector3d> pts{Eigen::Vector3d(-kMax, kMax, -kMax), Eigen::Vector3d(1, 2, 3)};
  std::ostringstream out;
  WriteXyz(out, pts, {});
  const auto back = Parse(out.str());
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0], pts[0]);
  EXPECT_EQ(back[1], pts[1]);
}

}  // namespace
}  // namespace sph
