#include "sph/measure/measure_workflow.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using ::testing::HasSubstr;

// x y z points on a sphere of radius 10 mm about (1, 2, 3), over the whole sphere.
std::string SphereXyz(const std::string& dir) {
  const std::string path = dir + "/sphere.xyz";
  std::ofstream f(path);
  f.precision(17);
  for (int i = 0; i < 12; ++i) {
    for (int j = 1; j < 12; ++j) {
      const double az = i * M_PI / 6.0, pol = j * M_PI / 12.0;
      f << 1.0 + 10.0 * std::sin(pol) * std::cos(az) << " " << 2.0 + 10.0 * std::sin(pol) * std::sin(az) << " "
        << 3.0 + 10.0 * std::cos(pol) << "\n";
    }
  }
  return path;
}

std::string RunError(const std::string& path, const MeasurementWorkflowOptions& o) {
  try {
    RunMeasurementWorkflow(path, o);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(MeasureWorkflow, FitsXyzPointsAndRendersTheReports) {
  const std::string path = SphereXyz(sph::testing::MakeTempDir("measure_workflow"));
  MeasurementWorkflowOptions o;
  o.xyz = true;
  o.noise_floor_draws = 0;
  std::vector<std::string> stages;
  o.on_progress = [&](const std::string& stage, long, long total) {
    if (total == 0) stages.push_back(stage);
  };
  const MeasurementWorkflowResult run = RunMeasurementWorkflow(path, o);
  EXPECT_NEAR(run.evaluation.ls.sphere.radius, 10.0, 1e-9);
  EXPECT_NEAR((run.evaluation.ls.sphere.center - Eigen::Vector3d(1, 2, 3)).norm(), 0.0, 1e-9);
  EXPECT_EQ(run.input.points_mm.size(), 132u);
  EXPECT_FALSE(run.uncertainty.has_value());
  EXPECT_EQ(run.uncertainty_note, "none (x y z input carries no calibration)");
  EXPECT_FALSE(run.noise_floor.floor.has_value());
  ASSERT_EQ(run.budgets.results.size(), 3u);
  EXPECT_EQ(run.budgets.results[0].mc_note, "");  // the radius has no Monte Carlo check
  EXPECT_EQ(run.budgets.results[1].mc_note, "no calibration covariance to propagate");
  EXPECT_THAT(stages, ::testing::ElementsAre("reading " + path, "fitting the spheres of 132 points"));
  EXPECT_THAT(run.JsonReport(), HasSubstr("\"created_by\": \"sph_measure "));
  std::ostringstream text;
  run.WriteTextReport(text);
  EXPECT_THAT(text.str(), HasSubstr("sph_measure "));
  EXPECT_THAT(text.str(), HasSubstr("radius_mm          10.000000000"));
  std::ostringstream points;
  run.WritePoints(points);
  EXPECT_THAT(points.str(), HasSubstr("132 points (x y z)"));
  const std::string map = run.FormMapScript("it's.png");
  EXPECT_THAT(map, HasSubstr("png = 'it''s.png'\n"));  // gnuplot's quoting of a quote
  EXPECT_THAT(map, HasSubstr("(132 points): radial residual about the least-squares sphere, R = 10.000000 mm\\n"));
  const auto data = map.find("$residuals << EOD\n"), end = map.find("EOD\nplot $residuals");
  ASSERT_NE(data, std::string::npos);
  ASSERT_NE(end, std::string::npos);
  EXPECT_EQ(std::count(map.begin() + data, map.begin() + end, '\n'), 1 + 132);  // one line per point inline
  o.program = "host 2.0";
  EXPECT_THAT(RunMeasurementWorkflow(path, o).JsonReport(), HasSubstr("\"created_by\": \"host 2.0\""));
}

TEST(MeasureWorkflow, RefusesReadingsWithoutACalibrationAndOneDraw) {
  const std::string readings = SPH_SOURCE_DIR "/data/example/points.txt";
  MeasurementWorkflowOptions o;
  EXPECT_THAT(RunError(readings, o), HasSubstr("readings (theta, phi, r) need a calibration to become points"));
  o.uncertainty_samples = 1;
  EXPECT_THAT(RunError(readings, o), HasSubstr("1 draw gives no spread"));
}

}  // namespace
}  // namespace sph
