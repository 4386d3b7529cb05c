#include "sph/calib/calibrate_workflow.hpp"

#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "sph/io/points_file.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using ::testing::HasSubstr;

const std::string kPoints = SPH_SOURCE_DIR "/data/example/points.txt";
const std::string kUndeclared = SPH_SOURCE_DIR "/data/example/undeclared/points.txt";

std::string CheckMessage(const CalibrationWorkflowOptions& o) {
  try {
    o.Check();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(CalibrateWorkflow, SevenErrorsAreTheFitsOwnWithTheHeadersSettings) {
  CalibrationWorkflowOptions o;
  o.trace = false;
  std::vector<std::string> stages;
  o.on_stage = [&](const std::string& s) { stages.push_back(s); };
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kPoints, o);
  CalibrationOptions direct;
  direct.sphere_radius_mm = 20.0;  // the file's header
  direct.probe_offset_mm = 25.0;
  const CalibrationResult expected = Calibrate(ReadPointsFile(kPoints), direct);
  EXPECT_FALSE(run.Extended());
  EXPECT_FALSE(run.trace.has_value());
  for (int p = 0; p < kNumScmsParams; ++p) {
    EXPECT_EQ(run.Reported().geometry[static_cast<std::size_t>(p)], expected.geometry[static_cast<std::size_t>(p)]);
  }
  EXPECT_DOUBLE_EQ(run.settings.sphere_radius_mm, 20.0);
  EXPECT_DOUBLE_EQ(run.settings.probe_offset_mm, 25.0);
  EXPECT_TRUE(run.usability.usable);
  ASSERT_TRUE(run.budget.has_value());
  EXPECT_THAT(stages,
              ::testing::ElementsAre("reading " + kPoints, "checking 288 samples", "calibrating the seven errors"));
  EXPECT_THAT(run.JsonReport(), HasSubstr("\"program\": \"sph_calibrate "));
  std::ostringstream text;
  run.WriteTextReport(text);
  EXPECT_THAT(text.str(), HasSubstr(kPoints));
  EXPECT_EQ(run.MakeCalibrationFile().probe_offset_mm, 25.0);
}

TEST(CalibrateWorkflow, OptionsWinOverTheHeaderAndNameTheProgram) {
  CalibrationWorkflowOptions o;
  o.trace = false;
  o.sphere_radius_mm = 20.001;
  o.probe_offset_mm = 24.5;
  o.program = "host 2.0";
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kPoints, o);
  EXPECT_DOUBLE_EQ(run.settings.sphere_radius_mm, 20.001);
  EXPECT_DOUBLE_EQ(run.settings.probe_offset_mm, 24.5);
  EXPECT_THAT(run.JsonReport(), HasSubstr("\"program\": \"host 2.0\""));
}

TEST(CalibrateWorkflow, TracesAndValidatesOnAnotherFile) {
  CalibrationWorkflowOptions o;
  o.validate_path = SPH_SOURCE_DIR "/data/example/undeclared/validate.txt";
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kUndeclared, o);
  ASSERT_TRUE(run.trace.has_value());
  EXPECT_TRUE(run.Extended());  // the example's undeclared effects are found
  ASSERT_TRUE(run.validation.has_value());
  EXPECT_EQ(run.validation->path, o.validate_path);
  EXPECT_EQ(run.validation->n_points, 288);
  EXPECT_THAT(run.validation->note, ::testing::Not(HasSubstr("own points file")));
  bool drift_left_out = false;
  const CalibrationFile file = run.MakeCalibrationFile(&drift_left_out);
  EXPECT_FALSE(file.effects.Empty());
}

// The same readings calibrated again and compared with the first calibration's file: the compare
// file is read before the fit, every parameter is found in both, unchanged, and the reports say so.
TEST(CalibrateWorkflow, ComparesWithAnEarlierCalibrationFile) {
  CalibrationWorkflowOptions o;
  o.trace = false;
  o.conditions.sphere_radius_u_um = 0.1;
  const std::string previous = sph::testing::MakeTempDir("workflow_compare") + "/previous.json";
  WriteCalibrationFile(previous, RunCalibrationWorkflow(kPoints, o).MakeCalibrationFile());
  o.compare_path = previous;
  std::vector<std::string> stages;
  o.on_stage = [&](const std::string& s) { stages.push_back(s); };
  const CalibrationWorkflowResult run = RunCalibrationWorkflow(kPoints, o);
  EXPECT_THAT(stages, ::testing::ElementsAre("reading " + kPoints, "reading " + previous, "checking 288 samples",
                                             "calibrating the seven errors", "comparing with " + previous));
  ASSERT_TRUE(run.comparison.has_value());
  ASSERT_EQ(run.comparison->parameters.size(), 7u);
  for (const ComparedParameter& c : run.comparison->parameters) {
    EXPECT_TRUE(c.Compared()) << c.parameter;
    EXPECT_NEAR(c.difference, 0.0, 1e-9) << c.parameter;
  }
  EXPECT_EQ(run.comparison->correlated_inputs, std::vector<std::string>{"R0 (certificate)"});
  std::ostringstream text;
  run.WriteTextReport(text);
  EXPECT_THAT(text.str(), HasSubstr("comparison with " + previous));
  EXPECT_THAT(text.str(), HasSubstr("verdict: unchanged within uncertainty (7 parameters compared"));
  EXPECT_THAT(run.JsonReport(), HasSubstr("\"comparison\": ["));
  EXPECT_THAT(run.HtmlReport(), HasSubstr("Comparison with an earlier calibration"));
}

TEST(CalibrateWorkflow, RefusesPointsWithoutARadius) {
  PointsData points = ReadPointsFile(kPoints);
  points.header.sphere_radius_mm.reset();
  CalibrationWorkflowOptions o;
  try {
    RunCalibrationWorkflow(points, "mine.txt", o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("mine.txt: the reference sphere radius R0 is not given"));
  }
}

TEST(CalibrateWorkflow, CheckNamesTheSettingOutOfRange) {
  CalibrationWorkflowOptions o;
  EXPECT_EQ(CheckMessage(o), "");
  o.fit.max_std_um = 0.0;
  EXPECT_THAT(CheckMessage(o), HasSubstr("fit.max_std_um: must be > 0 and <= 1e+06 um, got 0"));
  o = {};
  o.sphere_radius_mm = -1.0;
  EXPECT_THAT(CheckMessage(o), HasSubstr("sphere_radius_mm: must be > 0 and <= 1000 mm, got -1"));
  o = {};
  o.trace_options.drift_order = 4;
  EXPECT_THAT(CheckMessage(o), HasSubstr("trace_options.drift_order: must be >= 1 and <= 3, got 4"));
  o = {};
  o.trace = false;
  o.effects = {Effect::kProbeGain};
  EXPECT_THAT(CheckMessage(o), HasSubstr("effects need trace"));
  o = {};
  o.coverage = 1.0;
  EXPECT_THAT(CheckMessage(o), HasSubstr("coverage: must be >= 0.5 and <= 0.9999, got 1"));
  // The run refuses them as Check() does.
  EXPECT_THROW(RunCalibrationWorkflow(ReadPointsFile(kPoints), kPoints, o), Error);
}

}  // namespace
}  // namespace sph
