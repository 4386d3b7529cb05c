#include "calibrate_cmd.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "app_common.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/points_file.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/units.hpp"
#include "sph/sphere/sphere_fit.hpp"
#include "sph/sphere/sphere_form.hpp"
#include "test_util.hpp"

namespace sph::apps {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

struct RunOutput {
  int code;
  std::string out;
  std::string err;
};

RunOutput Calibrate(const CalibrateOptions& o) {
  std::ostringstream out, err;
  const int code = RunCalibrate(o, out, err);
  return {code, out.str(), err.str()};
}

class CalibrateCmd : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = sph::testing::MakeTempDir(::testing::UnitTest::GetInstance()->current_test_info()->name());
  }

  std::string WriteFile(const std::string& name, const std::string& text) {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }

  std::string Simulated(const std::string& name, const SimulationSpec& spec) {
    const std::string path = dir_ + "/" + name;
    WritePointsFile(path, Simulate(spec));
    return path;
  }

  // Runs on a points file written from `text` and expects exit 2 with `message` on stderr.
  void ExpectBadInput(const std::string& text, const std::string& message) {
    CalibrateOptions o;
    o.points_path = WriteFile("bad.txt", text);
    const RunOutput r = Calibrate(o);
    EXPECT_EQ(r.code, kExitBadInput) << text;
    EXPECT_THAT(r.err, HasSubstr("sph_calibrate: error: " + o.points_path + message)) << text;
  }

  std::string dir_;
};

constexpr const char* kHeader = "# sph-points 1\n# sphere_radius_mm: 20\n# probe_offset_mm: 25\n";

TEST_F(CalibrateCmd, ExampleDataGivesAUsableCalibration) {
  CalibrateOptions o;
  o.points_path = SPH_SOURCE_DIR "/data/example/points.txt";
  o.json_path = dir_ + "/report.json";
  o.output_path = dir_ + "/cal.json";
  const RunOutput r = Calibrate(o);
  EXPECT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("result: usable calibration"));
  EXPECT_THAT(r.out, HasSubstr("alpha"));
  EXPECT_THAT(r.out, HasSubstr("urad"));
  std::ifstream in(o.json_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  for (const char* p : {"alpha", "a", "beta", "b", "epsilon", "c", "d_prime", "center_x", "center_y", "center_z"}) {
    ASSERT_TRUE(j["parameters"].contains(p)) << p;
    EXPECT_TRUE(j["parameters"][p]["value"].is_number());
    EXPECT_TRUE(j["parameters"][p]["std"].is_number());
  }
  EXPECT_EQ(j["parameters"]["alpha"]["unit"], "deg");
  // ISO 230-1's names beside ours, with the sign where it differs.
  EXPECT_EQ(j["parameters"]["alpha"]["iso_name"], "EA0B");
  EXPECT_EQ(j["parameters"]["beta"]["iso_name"], "-EB0B");
  EXPECT_EQ(j["parameters"]["d_prime"]["iso_name"], "");
  EXPECT_EQ(j["parameters"]["a"]["unit"], "mm");
  EXPECT_EQ(j["fit"]["n_points"], 288);
  EXPECT_TRUE(j["fit"]["converged"].get<bool>());
  EXPECT_TRUE(j["fit"]["rms_um"].is_number());
  EXPECT_TRUE(j["fit"]["pv_um"].is_number());
  EXPECT_TRUE(j["warnings"].is_array());
  std::ifstream cal(o.output_path);
  EXPECT_TRUE(cal.good());
}

TEST_F(CalibrateCmd, ProgressOnRequestNamesEachStageAndEveryRoundOfTheTrace) {
  CalibrateOptions o;
  o.points_path = SPH_SOURCE_DIR "/data/example/points.txt";
  o.quiet = true;
  const RunOutput quiet = Calibrate(o);  // stderr is no terminal here: nothing by default
  ASSERT_EQ(quiet.code, kExitOk) << quiet.err;
  EXPECT_THAT(quiet.err, Not(HasSubstr("sph_calibrate: reading")));
  o.progress = ProgressMode::kAlways;
  const RunOutput r = Calibrate(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  for (const std::string& s : std::vector<std::string>{
           "sph_calibrate: reading " + o.points_path + "\n", "sph_calibrate: checking 288 samples\n",
           "sph_calibrate: calibrating the seven errors\n",
           "sph_calibrate: tracing the residual, round 1: candidates 100% ("}) {
    EXPECT_THAT(r.err, HasSubstr(s));
  }
}

// What the file's header holds and informs, and the options over it: a held parameter reported as
// held, a prior an input of the budget, the options winning for a parameter both name.
TEST_F(CalibrateCmd, FixAndPriorFromTheHeaderAndTheOptions) {
  std::string text = sph::testing::ReadWholeFile(SPH_SOURCE_DIR "/data/example/points.txt");
  text.insert(text.find("# columns"), "# fix: d_prime_mm=-0.05 beta\n# prior: alpha_deg=0.0202,0.0001\n");
  CalibrateOptions o;
  o.points_path = WriteFile("told.txt", text);
  o.workflow.trace = false;
  o.json_path = dir_ + "/report.json";
  o.fix = {"d_prime_mm=-0.062"};  // over the header's -0.05
  const RunOutput r = Calibrate(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("d_prime                 -62 um       fixed"));  // held: its value in full
  EXPECT_THAT(r.out, HasSubstr("beta                      0 urad     fixed"));
  EXPECT_THAT(r.out, HasSubstr("prior on alpha: u = 1.74533 urad"));
  const nlohmann::json j = nlohmann::json::parse(sph::testing::ReadWholeFile(o.json_path));
  EXPECT_EQ(j["parameters"]["d_prime"]["held"], "fixed");
  EXPECT_EQ(j["parameters"]["d_prime"]["value"], -0.062);
  EXPECT_FALSE(j["parameters"]["alpha"].contains("held"));
  EXPECT_GT(j["prior_noise_um"].get<double>(), 0.0);
}

TEST_F(CalibrateCmd, RobustLossNamesTheReadingsItWeightedDown) {
  SimulationSpec spec;
  spec.effects.outlier_fraction = 0.02;
  spec.effects.outlier_um = 20.0;
  CalibrateOptions o;
  o.points_path = Simulated("dirty.txt", spec);
  o.workflow.trace = false;
  o.robust_loss = "huber";
  o.json_path = dir_ + "/report.json";
  const RunOutput r = Calibrate(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("robust loss: "));
  EXPECT_THAT(r.out, HasSubstr("readings weighted down (scale "));
  EXPECT_THAT(r.out, HasSubstr(", weight "));
  EXPECT_THAT(r.out, Not(HasSubstr("outlier(s) left out")));
  const nlohmann::json j = nlohmann::json::parse(sph::testing::ReadWholeFile(o.json_path));
  EXPECT_EQ(j["robust_loss"]["loss"], "huber");
  EXPECT_NEAR(j["robust_loss"]["noise_um"].get<double>(), 0.05, 0.02);
  EXPECT_GE(j["robust_loss"]["weighted_readings"].size(), 5u);
  EXPECT_TRUE(j["outliers"].empty());
}

TEST_F(CalibrateCmd, CentredSphereExitsOneAndWritesNoCalibration) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(0.01, 0, 0)};
  CalibrateOptions o;
  o.points_path = Simulated("centred.txt", spec);
  o.output_path = dir_ + "/cal.json";
  o.json_path = dir_ + "/report.json";
  const RunOutput r = Calibrate(o);
  EXPECT_EQ(r.code, kExitNotUsable);
  EXPECT_THAT(r.out, HasSubstr("undetermined parameters"));
  EXPECT_THAT(r.out, HasSubstr("NOT a usable calibration"));
  EXPECT_THAT(r.err, HasSubstr("not writing"));
  EXPECT_FALSE(std::ifstream(o.output_path).good());
  std::ifstream in(o.json_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_FALSE(j["usable"].get<bool>());
  EXPECT_FALSE(j["parameters"]["c"]["determined"].get<bool>());
  EXPECT_THAT(j["undetermined"].get<std::vector<std::string>>(), ::testing::Contains("c"));
}

TEST_F(CalibrateCmd, TwoSetupsNameTheirCentres) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0)};
  CalibrateOptions o;
  o.points_path = Simulated("two.txt", spec);
  o.json_path = dir_ + "/report.json";
  EXPECT_EQ(Calibrate(o).code, kExitOk);
  std::ifstream in(o.json_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_TRUE(j["parameters"].contains("center_x@0"));
  EXPECT_TRUE(j["parameters"].contains("center_z@1"));
}

TEST_F(CalibrateCmd, OptionsOverrideTheHeader) {
  SimulationSpec spec;
  PointsData d = Simulate(spec);
  d.header.sphere_radius_mm.reset();
  d.header.probe_offset_mm.reset();
  const std::string path = dir_ + "/nohdr.txt";
  WritePointsFile(path, d);
  CalibrateOptions o;
  o.points_path = path;
  RunOutput r = Calibrate(o);
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("the reference sphere radius R0 is not given: add a header line "
                               "'# sphere_radius_mm: <R0>' to the file or pass --sphere-radius-mm"));
  o.workflow.sphere_radius_mm = 20.0;
  r = Calibrate(o);
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("'# probe_offset_mm: <d>' to the file or pass --probe-offset-mm"));
  o.workflow.probe_offset_mm = 25.0;
  EXPECT_EQ(Calibrate(o).code, kExitOk);
}

TEST_F(CalibrateCmd, BadInputCasesExitTwoWithTheirMessage) {
  const std::string h = kHeader;
  ExpectBadInput(h + "1 2\n", ":4: expected 3 columns");
  ExpectBadInput(h + "1 2 abc\n", ":4: column r_mm: 'abc' is not a number");
  ExpectBadInput(h + "1 2 nan\n", ":4: column r_mm: 'nan' is not a finite number");
  ExpectBadInput(h + "1 inf 3\n", ":4: column phi_deg: 'inf' is not a finite number");
  ExpectBadInput(h + "# columns: theta_deg phi_deg r_mm temp_c\n1 2 3 4\n", ":4: unknown column name 'temp_c'");
  ExpectBadInput(h + "# probe_offset_mm: 26\n1 2 3\n", ":4: header key 'probe_offset_mm' is given twice");
  ExpectBadInput("# sphere_radius_mm: 0\n1 2 3\n", ":1: sphere_radius_mm must be positive");
  ExpectBadInput(h, ": no samples");
  ExpectBadInput(h + "0 10 5\n90 10 5\n180 10 5\n", ": 3 samples are too few to fit 10 parameters");
}

// The bad-input matrix: each case one clear message naming the file and exit 2, and no output
// file left behind.
TEST_F(CalibrateCmd, BadFilesExitTwoAndLeaveNothingBehind) {
  const std::string garbage(
      "\x7f"
      "ELF\x02\x01\x01\0\0\0\xff\xfe\n\x01\x02",
      16);
  const std::vector<std::pair<std::string, std::string>> cases{
      {"", ": no samples"},
      {kHeader, ": no samples"},
      {garbage, ":1: "},
      {std::string(kHeader) + "0 7.5 nan\n", "is not a finite number"},
      {std::string(kHeader) + "0 7.5 inf\n", "is not a finite number"},
  };
  for (const auto& [text, message] : cases) {
    CalibrateOptions o;
    o.points_path = WriteFile("bad.txt", text);
    o.json_path = dir_ + "/report.json";
    o.output_path = dir_ + "/cal.json";
    const RunOutput r = Calibrate(o);
    EXPECT_EQ(r.code, kExitBadInput) << message;
    EXPECT_THAT(r.err, HasSubstr("sph_calibrate: error: " + o.points_path)) << message;
    EXPECT_THAT(r.err, HasSubstr(message));
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_TRUE(sph::testing::ReadWholeFile(o.json_path).empty()) << "no report is left behind";
    EXPECT_TRUE(sph::testing::ReadWholeFile(o.output_path).empty()) << "no calibration is left behind";
  }
}

TEST_F(CalibrateCmd, MissingFileAndUnwritableOutputExitTwo) {
  CalibrateOptions o;
  o.points_path = dir_ + "/missing.txt";
  RunOutput r = Calibrate(o);
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("missing.txt: cannot open for reading"));

  o.points_path = SPH_SOURCE_DIR "/data/example/points.txt";
  o.json_path = dir_ + "/no/such/dir/report.json";
  r = Calibrate(o);
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("report.json: cannot"));

  // A calibration file into a folder that does not exist, and one that is a folder.
  o.json_path.clear();
  for (const std::string& out : {dir_ + "/no/such/dir/cal.json", dir_}) {
    o.output_path = out;
    r = Calibrate(o);
    EXPECT_EQ(r.code, kExitBadInput) << out;
    EXPECT_THAT(r.err, HasSubstr("sph_calibrate: error: " + out)) << r.err;
  }
}

// A measurement with effects the file does not declare: two sphere positions, a Theta encoder
// error twice and three times per turn, and a probe drift of 0.6 um over the run.
SimulationSpec UndeclaredEffects() {
  SimulationSpec spec;
  spec.seed = 7;
  spec.centers_mm = {Eigen::Vector3d(2.0, 0.0, 0.0), Eigen::Vector3d(0.0, -3.0, 0.5)};
  EffectTerm enc{Effect::kThetaEncoder, {{2, 0, false}, {3, 0, true}}};
  EffectTerm drift{Effect::kProbeDrift, {{1, 0, false}}};
  spec.effects.model.terms = {enc, drift};
  spec.effects.values = {{6 * kRadPerArcsec, -4 * kRadPerArcsec}, {0.6 * kMmPerUm}};
  return spec;
}

TEST_F(CalibrateCmd, TracesTheResidualToTheUndeclaredEffects) {
  CalibrateOptions o;
  o.points_path = Simulated("points.txt", UndeclaredEffects());
  SimulationSpec other = UndeclaredEffects();
  other.centers_mm = {Eigen::Vector3d(1.5, 1.5, -1.0)};
  other.seed = 8;
  o.workflow.validate_path = Simulated("validate.txt", other);
  o.json_path = dir_ + "/report.json";
  o.plot_dir = dir_ + "/plots";
  o.output_path = dir_ + "/cal.json";
  const RunOutput r = Calibrate(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.err, HasSubstr("leaves out probe_drift"));
  EXPECT_THAT(r.out, HasSubstr("tracing the residual (to the effects"));
  EXPECT_THAT(r.out, HasSubstr("theta_encoder.c2"));
  const nlohmann::json j = nlohmann::json::parse(sph::testing::ReadWholeFile(o.json_path));
  EXPECT_EQ(j["effects_added"], nlohmann::json({"probe_drift", "theta_encoder"})) << j.dump(2);
  const double before = j["before"]["rms_um"], after = j["after"]["rms_um"];
  EXPECT_GT(before, 2.5 * after);
  EXPECT_LT(after, 0.05);
  EXPECT_LT(j["after"]["cv_rms_um"].get<double>(), j["before"]["cv_rms_um"].get<double>());
  EXPECT_TRUE(j["unexplained"].empty()) << j["unexplained"].dump(2);
  EXPECT_TRUE(j["ambiguous"].is_array());
  // Every candidate of every round is listed with its scores.
  ASSERT_GE(j["candidates"].size(), 8u);
  for (const auto& c : j["candidates"]) {
    EXPECT_TRUE(c.contains("delta_bic") && c.contains("cv_rms_um") && c.contains("id")) << c.dump();
  }
  // The parameters found are the simulated ones, within 4 std.
  for (const auto& e : j["effects"]) {
    for (const auto& p : e["parameters"]) {
      const std::string name = p["name"];
      const double truth = name == "theta_encoder.c2"   ? 6.0
                           : name == "theta_encoder.s3" ? -4.0
                           : name == "probe_drift.t1"   ? 0.6
                                                        : 0.0;
      EXPECT_NE(truth, 0.0) << "unexpected component " << name;
      EXPECT_NEAR(p["value"].get<double>(), truth, 4 * p["std"].get<double>()) << name;
    }
  }
  EXPECT_GT(j["validation"]["before_ls_sphericity_um"].get<double>(), 0.0);
  EXPECT_THAT(j["validation"]["note"].get<std::string>(), Not(HasSubstr("independent")));
  // The calibration file carries the machine's effects (not the run's drift), and compensation
  // with it gives the validation sphere the sphericity the report states.
  const Calibration cal = LoadCalibration(o.output_path);
  ASSERT_EQ(cal.effects.terms.size(), 1u);
  EXPECT_EQ(cal.effects.terms[0].effect, Effect::kThetaEncoder);
  const std::vector<Eigen::Vector3d> pts = CompensateAll(cal, ReadPointsFile(o.workflow.validate_path).samples);
  const LeastSquaresSphere ls = FitSphereLeastSquares(pts);
  ASSERT_TRUE(ls.sphere.ok);
  EXPECT_NEAR(RadialPeakToValley(pts, ls.sphere.center) * 1e3, j["validation"]["after_ls_sphericity_um"].get<double>(),
              1e-9);
  // Before and after compared by the rms, with its uncertainty rms / sqrt(2 (n - 4)), and said plainly.
  const nlohmann::json& v = j["validation"];
  EXPECT_NEAR(v["after_rms_um"].get<double>(), ls.rms * 1e3, 1e-9);
  EXPECT_NEAR(v["after_rms_u_um"].get<double>(), ls.rms * 1e3 / std::sqrt(2.0 * (288 - 4)), 1e-9);
  EXPECT_NEAR(v["rms_difference_um"].get<double>(), v["before_rms_um"].get<double>() - v["after_rms_um"].get<double>(),
              1e-12);
  EXPECT_EQ(v["rms_difference_inside_noise"].get<bool>(),
            std::abs(v["rms_difference_um"].get<double>()) <= 2.0 * v["rms_difference_u_um"].get<double>());
  EXPECT_THAT(r.out, HasSubstr("rms about the least-squares sphere"));
  EXPECT_THAT(r.out,
              HasSubstr(v["rms_difference_inside_noise"].get<bool>() ? "is inside the noise" : "is beyond the noise"));
  // The file keeps the covariance of the seven errors and of the effect's two parameters, jointly.
  const CalibrationFile file = ReadCalibrationFile(o.output_path);
  EXPECT_EQ(CalibrationParameterNames(file).size(), 9u);
  ASSERT_EQ(file.parameter_covariance.rows(), 9);
  const double std_c2_arcsec = std::sqrt(file.parameter_covariance(7, 7)) / kRadPerArcsec;
  for (const auto& e : j["effects"]) {
    for (const auto& p : e["parameters"]) {
      if (p["name"] == "theta_encoder.c2") {
        EXPECT_NEAR(std_c2_arcsec, p["std"].get<double>(), 1e-6 * std_c2_arcsec);
      }
    }
  }
  EXPECT_EQ(file.covariance_inputs.size(), 3u);  // R0, temperature, probe scale: stated as 0 here
  EXPECT_GT(file.covariance_type_a_dof, 500.0);
  EXPECT_GT(sph::testing::ReadWholeFile(o.plot_dir + "/residual_map.png").size(), 1000u);
  EXPECT_GT(sph::testing::ReadWholeFile(o.plot_dir + "/residual_time.png").size(), 1000u);
}

TEST_F(CalibrateCmd, AValidationOnTheCalibrationsOwnPointsSaysItIsNoIndependentCheck) {
  CalibrateOptions o;
  o.points_path = WriteFile("points.txt", sph::testing::ReadWholeFile(SPH_SOURCE_DIR "/data/example/points.txt"));
  o.workflow.validate_path = dir_ + "/same.txt";  // the same file by another name
  ASSERT_EQ(::symlink("points.txt", o.workflow.validate_path.c_str()), 0);
  o.json_path = dir_ + "/report.json";
  const RunOutput r = Calibrate(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  const std::string note =
      "the validation file is the calibration's own points file: this shows how the model fits its own data, not "
      "an independent check";
  EXPECT_THAT(r.out, HasSubstr(note));
  const nlohmann::json j = nlohmann::json::parse(sph::testing::ReadWholeFile(o.json_path));
  EXPECT_THAT(j["validation"]["note"].get<std::string>(), HasSubstr(note));
}

TEST_F(CalibrateCmd, NoExtendFitsTheSevenErrorsOnly) {
  CalibrateOptions o;
  o.points_path = Simulated("points.txt", UndeclaredEffects());
  o.workflow.trace = false;
  o.json_path = dir_ + "/report.json";
  const RunOutput r = Calibrate(o);
  EXPECT_THAT(r.out, Not(HasSubstr("tracing the residual (to the effects")));
  const nlohmann::json j = nlohmann::json::parse(sph::testing::ReadWholeFile(o.json_path));
  EXPECT_FALSE(j.contains("effects_added"));
}

TEST_F(CalibrateCmd, FixedEffectsAreFittedWithoutSelection) {
  CalibrateOptions o;
  o.points_path = Simulated("points.txt", UndeclaredEffects());
  o.effects = {"probe_gain", "probe_drift"};
  o.json_path = dir_ + "/report.json";
  const RunOutput r = Calibrate(o);
  const nlohmann::json j = nlohmann::json::parse(sph::testing::ReadWholeFile(o.json_path));
  EXPECT_EQ(j["effects_added"], nlohmann::json({"probe_gain", "probe_drift"}));
  ASSERT_EQ(j["effects"].size(), 2u);
  EXPECT_EQ(j["effects"][1]["parameters"].size(), 2u);  // t1 and t2: nothing left out
}

// --hold-confounded reaches the trace: a twice-per-turn Theta encoder error in one placement, which
// the design cannot tell from a radial motion of the spindle, adds nothing and holds both back,
// in the JSON and the text.
TEST_F(CalibrateCmd, HoldConfoundedAddsNeitherOfTwoEffectsItCannotTellApart) {
  SimulationSpec spec;
  spec.effects.model.terms = {{Effect::kThetaEncoder, {{2, 0, false}}}};
  spec.effects.values = {{10 * kRadPerArcsec}};
  CalibrateOptions o;
  o.points_path = Simulated("points.txt", spec);
  o.workflow.trace_options.hold_confounded = true;
  o.json_path = dir_ + "/report.json";
  const RunOutput r = Calibrate(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  const nlohmann::json j = nlohmann::json::parse(sph::testing::ReadWholeFile(o.json_path));
  EXPECT_TRUE(j["effects_added"].empty()) << j["effects_added"];
  const std::vector<std::string> held = j["effects_held"];
  EXPECT_NE(std::find(held.begin(), held.end(), "theta_encoder"), held.end());
  EXPECT_NE(std::find(held.begin(), held.end(), "theta_radial_motion"), held.end());
  EXPECT_THAT(r.out, HasSubstr("held back, not added"));
  EXPECT_THAT(r.out, HasSubstr("two explanations, neither added: "));
  CLI::App contradictory;
  CalibrateOptions o2;
  SetupCalibrateApp(contradictory, o2);
  std::vector<std::string> args{"--no-trace", "--hold-confounded", "p.txt"};  // parse() takes them reversed
  EXPECT_THROW(contradictory.parse(args), CLI::ExcludesError);
}

// CLI::App::parse(vector) takes the arguments in reverse order; this takes them as typed.
void ParseArgs(CLI::App& app, std::vector<std::string> args) {
  std::reverse(args.begin(), args.end());
  app.parse(args);
}

TEST_F(CalibrateCmd, StatesTheGumBudgetAndPutsTheCombinedCovarianceInTheCalibrationFile) {
  // The certificate's u(R0) from the header, the probe scale from an option (which would
  // override a header field of the same name), coverage k = 2.
  SimulationSpec spec;
  PointsData data = Simulate(spec);
  data.header.metadata.emplace_back("sphere_radius_u_um", "0.1");
  const std::string points = dir_ + "/points.txt";
  WritePointsFile(points, data);
  CalibrateOptions o;
  o.points_path = points;
  o.workflow.trace = false;
  o.workflow.conditions.probe_scale_u = 1e-5;
  o.json_path = dir_ + "/report.json";
  o.output_path = dir_ + "/cal.json";
  const RunOutput r = Calibrate(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("uncertainty (GUM)"));
  EXPECT_THAT(r.out, HasSubstr("R0 (certificate): u = 0.1 um (the certificate's standard uncertainty)"));
  std::ifstream in(o.json_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  const nlohmann::json& d = j["parameters"]["d_prime"];
  const double std_mm = d["std"].get<double>(), u_mm = d["u"].get<double>();
  EXPECT_GT(u_mm, 0.1e-3);  // R0's 0.1 um, taken one for one, beside a Type A std of 0.007 um
  EXPECT_LT(std_mm, 0.01e-3);
  EXPECT_DOUBLE_EQ(d["U"].get<double>(), 2.0 * u_mm);
  ASSERT_EQ(d["budget"].size(), 4u);
  double sum2 = 0.0;
  for (const auto& item : d["budget"]) sum2 += std::pow(item["u_contribution"].get<double>(), 2);
  EXPECT_NEAR(std::sqrt(sum2), u_mm, 1e-12);
  EXPECT_EQ(d["budget"][0]["type"], "A");
  EXPECT_EQ(d["budget"][1]["input"], "R0 (certificate)");
  EXPECT_DOUBLE_EQ(d["budget"][1]["u_input"].get<double>(), 0.1);
  EXPECT_DOUBLE_EQ(d["budget"][3]["u_input"].get<double>(), 1e-5);
  // The calibration file's covariance is the combined one: d' variance u^2, not std^2.
  const CalibrationFile cal = ReadCalibrationFile(o.output_path);
  ASSERT_TRUE(cal.covariance.has_value());
  EXPECT_NEAR(std::sqrt((*cal.covariance)(6, 6)), u_mm, 1e-9);
}

// Yesterday's calibration and today's of the same machine with d' moved by 1 um: the comparison
// names d' as moved, counts the shared certificate as correlated, and the exit code stays the
// calibration's own; a calibration that is not usable is compared too and still exits 1.
TEST_F(CalibrateCmd, ComparesWithAnEarlierCalibrationAndKeepsItsOwnExitCode) {
  SimulationSpec spec;
  spec.seed = 1;
  CalibrateOptions o;
  o.points_path = Simulated("yesterday.txt", spec);
  o.workflow.trace = false;
  o.workflow.conditions.sphere_radius_u_um = 0.1;
  o.quiet = true;
  o.output_path = dir_ + "/yesterday.json";
  ASSERT_EQ(Calibrate(o).code, kExitOk);
  spec.seed = 2;
  spec.truth[kDPrime] += 1e-3;
  o.points_path = Simulated("today.txt", spec);
  o.output_path.clear();
  o.quiet = false;
  o.workflow.compare_path = dir_ + "/yesterday.json";
  o.json_path = dir_ + "/today_report.json";
  o.report_path = dir_ + "/today_report.html";
  const RunOutput r = Calibrate(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("comparison with " + o.workflow.compare_path));
  EXPECT_THAT(r.out, HasSubstr("counted fully correlated (the same source in both, cancelling where it acts alike): "
                               "R0 (certificate)"));
  EXPECT_THAT(r.out, HasSubstr("verdict: moved: d_prime by +"));
  std::ifstream in(o.json_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_EQ(j["comparison"].size(), 7u);
  const nlohmann::json& d = j["comparison"][6];
  EXPECT_EQ(d["parameter"], "d_prime");
  EXPECT_EQ(d["unit"], "um");
  EXPECT_NEAR(d["difference"].get<double>(), d["now"].get<double>() - d["previous"].get<double>(), 1e-12);
  EXPECT_NEAR(d["difference"].get<double>(), 1.0, 0.05);  // the 1 um moved, within the two fits' noise
  // The certificate's 0.1 um acts alike on both: U is the fits' scatter alone, well below 2 x 0.1 um.
  EXPECT_LT(d["U"].get<double>(), 0.1);
  EXPECT_NEAR(d["En"].get<double>(), d["difference"].get<double>() / d["U"].get<double>(), 1e-12);
  EXPECT_FALSE(j["comparison_summary"]["unchanged"].get<bool>());
  for (int p = 0; p < kDPrime; ++p) EXPECT_LE(std::abs(j["comparison"][p]["En"].get<double>()), 3.0) << p;
  std::ifstream html(o.report_path);
  const std::string page((std::istreambuf_iterator<char>(html)), std::istreambuf_iterator<char>());
  EXPECT_THAT(page, HasSubstr("Comparison with an earlier calibration"));
  EXPECT_THAT(page, HasSubstr("<td>d_prime</td>"));

  spec.centers_mm = {Eigen::Vector3d(0.01, 0, 0)};  // centred: c undetermined, not usable
  o.points_path = Simulated("centred.txt", spec);
  o.report_path.clear();
  const RunOutput centred = Calibrate(o);
  EXPECT_EQ(centred.code, kExitNotUsable);
  EXPECT_THAT(centred.out, HasSubstr("verdict: "));
}

// A sphere with a form of its own, turned on its mount, on a machine with only the seven errors:
// the trace adds the form and nothing else, and what is reported and stored is the joint fit (the
// seven errors fitted with the form), with the form in the calibration file.
TEST_F(CalibrateCmd, AFormAloneIsFittedWithTheMachineAndStored) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(-2, 0, 0)};
  spec.mount_rotations_deg[1] = Eigen::Vector3d(0, 0, 90);
  spec.mount_rotations_deg[2] = Eigen::Vector3d(90, 0, 0);
  spec.noise_r_um = 0.02;
  spec.seed = 5;
  spec.effects.form = {{2, 0, 0.06}, {3, 1, 0.05}, {4, 2, 0.04}};
  CalibrateOptions o;
  o.points_path = Simulated("points.txt", spec);
  o.json_path = dir_ + "/report.json";
  o.output_path = dir_ + "/cal.json";
  const RunOutput r = Calibrate(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  std::ifstream in(o.json_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_TRUE(j.contains("sphere_form")) << r.out;
  const CalibrationFile cal = ReadCalibrationFile(o.output_path);
  ASSERT_FALSE(cal.form_terms.empty()) << r.out;
  EXPECT_TRUE(cal.effects.terms.empty());
  // Schmidt harmonics: rms over the sphere sqrt(sum c^2 / (2l + 1)).
  const double rms_um = std::sqrt(0.06 * 0.06 / 5 + 0.05 * 0.05 / 7 + 0.04 * 0.04 / 9);
  EXPECT_NEAR(FormRms(cal.form_terms, cal.form_values_mm) * kUmPerMm, rms_um, 0.1 * rms_um);
  // The stored seven errors are the joint fit's: its rms is at the noise, not at the form's.
  EXPECT_LT(j["fit"]["rms_um"].get<double>(), 1.2 * 0.02) << r.out;
  // The eccentricity turns with the sphere here (each centre's direction is the body's x axis), so
  // the probe's reading varies as (u . x) on the body in every setup: the design's null space ties
  // the form's S(2,0) and S(2,2) to the probe polynomial (and more of it to the Phi axis' motions),
  // and the report says so.
  const std::string design = j["sphere_form"]["design"].get<std::string>();
  EXPECT_THAT(design, HasSubstr("cannot be told from the machine by this design"));
  EXPECT_THAT(design, HasSubstr("S(2,0)"));
  EXPECT_THAT(design, HasSubstr("S(2,2)"));
  EXPECT_FALSE(j["sphere_form"]["confounded"].empty());
  // Its budget refits the form too (the sensitivities have every parameter of the joint fit).
  EXPECT_THAT(r.err, Not(HasSubstr("no uncertainty budget")));
  EXPECT_TRUE(j["parameters"]["d_prime"].contains("u")) << r.out;
}

TEST_F(CalibrateCmd, CoverageProbabilityGivesKFromTheDegreesOfFreedom) {
  CalibrateOptions o;
  o.points_path = SPH_SOURCE_DIR "/data/example/points.txt";
  o.workflow.trace = false;
  o.workflow.coverage = 0.99;
  o.json_path = dir_ + "/report.json";
  ASSERT_EQ(Calibrate(o).code, kExitOk);
  std::ifstream in(o.json_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  const nlohmann::json& alpha = j["parameters"]["alpha"];
  EXPECT_NEAR(alpha["k"].get<double>(), 2.594, 0.002);  // t_0.995 for 278 degrees of freedom
  EXPECT_DOUBLE_EQ(j["coverage"]["probability"].get<double>(), 0.99);
}

TEST(CalibrateCli, ParsesOptions) {
  CLI::App app;
  CalibrateOptions o;
  SetupCalibrateApp(app, o);
  ParseArgs(app, {"p.txt", "--json", "r.json", "--sphere-radius-mm=12.5", "--max-std-um", "0.5"});
  EXPECT_EQ(o.points_path, "p.txt");
  EXPECT_DOUBLE_EQ(*o.workflow.sphere_radius_mm, 12.5);
  EXPECT_DOUBLE_EQ(o.workflow.fit.max_std_um, 0.5);
  EXPECT_EQ(o.json_path, "r.json");
  CLI::App bad;
  CalibrateOptions o2;
  SetupCalibrateApp(bad, o2);
  EXPECT_THROW(ParseArgs(bad, {"p.txt", "--sphere-radius-mm", "-1"}), CLI::ValidationError);
  CLI::App effects;
  CalibrateOptions o3;
  SetupCalibrateApp(effects, o3);
  ParseArgs(effects, {"p.txt", "--effects", "probe_gain,theta_encoder"});
  EXPECT_EQ(o3.effects, (std::vector<std::string>{"probe_gain", "theta_encoder"}));
  CLI::App unknown;
  CalibrateOptions o4;
  SetupCalibrateApp(unknown, o4);
  EXPECT_THROW(ParseArgs(unknown, {"p.txt", "--effects", "probe_temperature"}), CLI::ValidationError);
  CLI::App contradictory;
  CalibrateOptions o5;
  SetupCalibrateApp(contradictory, o5);
  EXPECT_THROW(ParseArgs(contradictory, {"p.txt", "--no-trace", "--effects", "probe_gain"}), CLI::ExcludesError);
}

}  // namespace
}  // namespace sph::apps
