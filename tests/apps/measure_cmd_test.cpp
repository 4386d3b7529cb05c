#include "measure_cmd.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>

#include <sys/stat.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "app_common.hpp"
#include "calibrate_cmd.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/points_file.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/io/xyz_file.hpp"
#include "sph/model/units.hpp"
#include "test_util.hpp"

namespace sph::apps {
namespace {

using nlohmann::json;
using ::testing::HasSubstr;
using ::testing::Not;

constexpr const char* kNistDir = SPH_TEST_DATA_DIR "/nist-ats-l2-sphere/";
// Agreement with NIST's reference fits through the app (data units); see nist_sphere_test.cpp.
constexpr double kNistTolerance = 1e-8;

struct RunOutput {
  int code;
  std::string out;
  std::string err;
};

RunOutput Measure(const MeasureOptions& o) {
  std::ostringstream out, err;
  const int code = RunMeasure(o, out, err);
  return {code, out.str(), err.str()};
}

json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return json::parse(in);
}

bool Exists(const std::string& path) { return std::ifstream(path).good(); }

class MeasureCmd : public ::testing::Test {
 protected:
  // One calibration of the example data for the whole suite: the paper's study at 2 mm.
  static void SetUpTestSuite() {
    suite_dir_ = sph::testing::MakeTempDir("measure_suite");
    CalibrateOptions c;
    c.points_path = SPH_SOURCE_DIR "/data/example/points.txt";
    c.output_path = suite_dir_ + "/cal.json";
    c.quiet = true;
    std::ostringstream out, err;
    ASSERT_EQ(RunCalibrate(c, out, err), kExitOk) << err.str();
  }

  void SetUp() override {
    dir_ = sph::testing::MakeTempDir(::testing::UnitTest::GetInstance()->current_test_info()->name());
  }

  static std::string Calibration() { return suite_dir_ + "/cal.json"; }

  std::string WriteFile(const std::string& name, const std::string& text) {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }

  // Readings of the paper's machine measuring a sphere at `centers` (one setup each).
  std::string Simulated(const std::string& name, std::vector<Eigen::Vector3d> centers, double noise_r_um = 0.05) {
    SimulationSpec spec;
    spec.centers_mm = std::move(centers);
    spec.noise_r_um = noise_r_um;
    const std::string path = dir_ + "/" + name;
    WritePointsFile(path, Simulate(spec));
    return path;
  }

  static std::string suite_dir_;
  std::string dir_;
};

std::string MeasureCmd::suite_dir_;

TEST_F(MeasureCmd, XyzOfAllThirtyNistSetsGivesTheReferenceCentreAndDiameter) {
  double worst = 0.0;
  for (int k = 1; k <= 30; ++k) {
    const std::string name = "sph" + std::to_string(k);
    MeasureOptions o;
    o.points_path = kNistDir + name + ".ds";
    o.workflow.xyz = true;
    o.json_path = dir_ + "/" + name + ".json";
    o.quiet = true;
    const RunOutput r = Measure(o);
    ASSERT_EQ(r.code, kExitOk) << name << ": " << r.err;
    const json j = ReadJson(o.json_path);
    std::ifstream fit(kNistDir + name + ".fit");
    double ref[4];
    for (double& v : ref) fit >> v;
    ASSERT_TRUE(fit) << name;
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(j["center_mm"][i].get<double>(), ref[i], kNistTolerance) << name << " centre " << i;
      worst = std::max(worst, std::abs(j["center_mm"][i].get<double>() - ref[i]));
    }
    EXPECT_NEAR(j["diameter_mm"].get<double>(), ref[3], kNistTolerance) << name;
    EXPECT_NEAR(2.0 * j["radius_mm"].get<double>(), ref[3], kNistTolerance) << name;
    worst = std::max(worst, std::abs(j["diameter_mm"].get<double>() - ref[3]));
    EXPECT_LE(j["sphericity_mz_um"].get<double>(), j["sphericity_ls_um"].get<double>()) << name;
    EXPECT_TRUE(j["fit"]["ls_converged"].get<bool>()) << name;
    EXPECT_TRUE(j["fit"]["mz_converged"].get<bool>()) << name;
    EXPECT_TRUE(j["uncertainty"].is_null());
  }
  std::printf("sph_measure --xyz on the NIST sets: worst deviation %.3g\n", worst);
}

TEST_F(MeasureCmd, MeasuresWithACalibrationInTextAndJson) {
  MeasureOptions o;
  o.points_path = Simulated("measure.txt", {Eigen::Vector3d(1.0, 1.0, 0.5)});
  o.workflow.calibration_path = Calibration();
  o.json_path = dir_ + "/m.json";
  const RunOutput r = Measure(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  for (const char* s : {"least-squares sphere", "center_mm", "radius_mm", "sphericity_ls_um", "minimum-zone sphere",
                        "sphericity_mz_um", "mz_center_mm", "cap_half_angle_deg", "radius_dilution",
                        "uncertainty from the calibration's covariance (sampling: 200 draws, seed 1)",
                        "calibration_form_p95_um", "radius_deviation_um", "warnings: none"}) {
    EXPECT_THAT(r.out, HasSubstr(s));
  }
  const json j = ReadJson(o.json_path);
  ASSERT_EQ(j["center_mm"].size(), 3u);
  EXPECT_NEAR(j["center_mm"][0].get<double>(), 1.0, 1e-3);
  EXPECT_NEAR(j["center_mm"][1].get<double>(), 1.0, 1e-3);
  EXPECT_NEAR(j["center_mm"][2].get<double>(), 0.5, 1e-3);
  EXPECT_NEAR(j["radius_mm"].get<double>(), 20.0, 1e-4);
  // Probe noise of 0.05 um and a good calibration: a few tenths of a micrometre, where the
  // uncompensated machine shows about 3 um (the paper's Table 3).
  EXPECT_GT(j["sphericity_ls_um"].get<double>(), 0.1);
  EXPECT_LT(j["sphericity_ls_um"].get<double>(), 0.6);
  EXPECT_LE(j["sphericity_mz_um"].get<double>(), j["sphericity_ls_um"].get<double>());
  EXPECT_EQ(j["mz_center_mm"].size(), 3u);
  EXPECT_EQ(j["input"]["n_points"], 288);
  EXPECT_EQ(j["input"]["calibration_file"], Calibration());
  EXPECT_FALSE(j["coverage"]["ill_posed"].get<bool>());
  ASSERT_TRUE(j["uncertainty"].is_object());
  EXPECT_EQ(j["uncertainty"]["method"], "sampling");
  EXPECT_EQ(j["uncertainty"]["samples"], 200);
  for (const char* k : {"radius_std_um", "sphericity_ls_std_um", "sphericity_mz_std_um", "calibration_form_p95_um"}) {
    EXPECT_GT(j["uncertainty"][k].get<double>(), 0.0) << k;
  }
  EXPECT_TRUE(j["warnings"].empty());
}

// Each result's budget: the measurement's own Type A, the calibration's Type A part and each
// Type B input the calibration file holds, combined as the GUM does; the sphericities checked by
// JCGM 101's adaptive Monte Carlo method.
TEST_F(MeasureCmd, StatesAGumBudgetOfEachResult) {
  MeasureOptions o;
  o.points_path = Simulated("budget.txt", {Eigen::Vector3d(1.0, 1.0, 0.5)});
  o.workflow.calibration_path = Calibration();
  o.json_path = dir_ + "/b.json";
  const RunOutput r = Measure(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("uncertainty (GUM)"));
  EXPECT_THAT(r.out, HasSubstr("calibration: fit (scatter of its points)"));
  EXPECT_THAT(r.out, HasSubstr("Monte Carlo check (JCGM 101, adaptive)"));
  const json j = ReadJson(o.json_path);
  const json& radius = j["budget"]["radius"];
  EXPECT_NEAR(radius["std"].get<double>(), j["coverage"]["radius_fit_std_um"].get<double>(), 1e-12);
  double sum2 = 0.0;
  std::vector<std::string> names;
  for (const json& in : radius["budget"]) {
    sum2 += std::pow(in["u_contribution"].get<double>(), 2);
    names.push_back(in["input"]);
    EXPECT_NEAR(in["u_contribution"].get<double>(),
                std::abs(in["sensitivity"].get<double>()) * in["u_input"].get<double>(), 1e-12);
  }
  EXPECT_EQ(names,
            (std::vector<std::string>{"measurement (scatter of the points)", "calibration: fit (scatter of its points)",
                                      "calibration: R0 (certificate)", "calibration: sphere temperature",
                                      "calibration: probe scale"}));
  EXPECT_NEAR(radius["u"].get<double>(), std::sqrt(sum2), 1e-12);
  EXPECT_EQ(radius["k"].get<double>(), 2.0);
  EXPECT_NEAR(radius["U"].get<double>(), 2.0 * radius["u"].get<double>(), 1e-12);
  // The linear budget's calibration part and the sampled one agree for the radius (200 draws: 5 %).
  EXPECT_NEAR(radius["budget"][1]["u_contribution"].get<double>() / j["uncertainty"]["radius_std_um"].get<double>(),
              1.0, 0.2);
  for (const char* k : {"sphericity_ls", "sphericity_mz"}) {
    const json& b = j["budget"][k];
    EXPECT_GT(b["u"].get<double>(), 0.0) << k;
    // The sphericities' own Type A: the noise floor's std of the statistic.
    EXPECT_NEAR(b["std"].get<double>(), j["noise_floor"][std::string(k) + "_um"]["std_um"].get<double>(), 1e-12) << k;
    const json& mc = b["monte_carlo"];
    ASSERT_TRUE(mc.contains("trials")) << mc.dump();
    EXPECT_GE(mc["trials"].get<long>(), 2000) << k;
    EXPECT_LE(mc["low_um"].get<double>(), mc["high_um"].get<double>());
    EXPECT_GT(mc["tolerance_um"].get<double>(), 0.0);
  }
  // A coverage probability: k from the effective degrees of freedom.
  o.workflow.coverage = 0.95;
  o.workflow.mc_max_trials = 0;
  ASSERT_EQ(Measure(o).code, kExitOk);
  const json p = ReadJson(o.json_path);
  EXPECT_NEAR(p["budget"]["radius"]["k"].get<double>(), 1.96, 0.02);
  EXPECT_EQ(p["budget"]["sphericity_ls"]["monte_carlo"]["note"], "not run (--mc-max-trials 0)");
}

TEST_F(MeasureCmd, CompensatedPointsRoundTripThroughXyz) {
  MeasureOptions o;
  o.points_path = Simulated("measure.txt", {Eigen::Vector3d(-1.0, 0.5, 0.0)});
  o.workflow.calibration_path = Calibration();
  o.json_path = dir_ + "/a.json";
  o.output_path = dir_ + "/points.xyz";
  o.quiet = true;
  o.workflow.mc_max_trials = 0;  // the budget's Monte Carlo check is not what this test is about
  ASSERT_EQ(Measure(o).code, kExitOk);
  std::ifstream in(o.output_path);
  std::string first, second;
  std::getline(in, first);
  std::getline(in, second);
  EXPECT_THAT(first, HasSubstr("# sph_measure"));
  EXPECT_EQ(second, "# columns: x_mm y_mm z_mm");
  MeasureOptions x;
  x.points_path = o.output_path;
  x.workflow.xyz = true;
  x.json_path = dir_ + "/b.json";
  x.quiet = true;
  ASSERT_EQ(Measure(x).code, kExitOk);
  const json a = ReadJson(o.json_path), b = ReadJson(x.json_path);
  // The file carries 1e-10 mm.
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(a["center_mm"][i].get<double>(), b["center_mm"][i].get<double>(), 1e-9);
  EXPECT_NEAR(a["radius_mm"].get<double>(), b["radius_mm"].get<double>(), 1e-9);
  EXPECT_NEAR(a["sphericity_ls_um"].get<double>(), b["sphericity_ls_um"].get<double>(), 1e-6);
  EXPECT_NEAR(a["sphericity_mz_um"].get<double>(), b["sphericity_mz_um"].get<double>(), 1e-6);
}

TEST_F(MeasureCmd, SaysWhenACapLeavesTheResultIllPosed) {
  std::ostringstream cap;
  for (int i = 0; i < 300; ++i) {  // a 25 deg cap of a 10 mm sphere, evenly covered
    const double z = 1.0 - (1.0 - std::cos(25.0 * kRadPerDeg)) * (i + 0.5) / 300.0, s = std::sqrt(1.0 - z * z);
    cap << 10.0 * s * std::cos(2.4 * i) << " " << 10.0 * s * std::sin(2.4 * i) << " " << 10.0 * z << "\n";
  }
  MeasureOptions o;
  o.points_path = WriteFile("cap.xyz", cap.str());
  o.workflow.xyz = true;
  o.json_path = dir_ + "/cap.json";
  const RunOutput r = Measure(o);
  EXPECT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("ill-posed for the coverage"));
  const json j = ReadJson(o.json_path);
  EXPECT_TRUE(j["coverage"]["ill_posed"].get<bool>());
  EXPECT_GT(j["coverage"]["radius_dilution"].get<double>(), 30.0);
  EXPECT_NEAR(j["coverage"]["cap_half_angle_deg"].get<double>(), 25.0, 0.5);
  ASSERT_EQ(j["warnings"].size(), 1u);
  // With the report on stdout as JSON the warnings go to stderr.
  o.json_path = "-";
  const RunOutput as_json = Measure(o);
  EXPECT_EQ(as_json.code, kExitOk);
  EXPECT_TRUE(json::parse(as_json.out)["coverage"]["ill_posed"].get<bool>());
  EXPECT_THAT(as_json.err, HasSubstr("sph_measure: warning: ill-posed for the coverage"));
}

// A cap whose minimum zone has two local minima (tests/sphere/sphere_form_test.cpp): the search
// from several starts reports the narrower zone and what each start reached, in text and JSON; over
// the whole sphere one search is certified and no starts are listed.
TEST_F(MeasureCmd, ReportsTheMinimumZonesCertificateAndStarts) {
  MeasureOptions o;
  o.points_path = SPH_TEST_DATA_DIR "/minimum-zone/two_minima_cap.xyz";
  o.workflow.xyz = true;
  o.json_path = dir_ + "/cap.json";
  const RunOutput r = Measure(o);
  EXPECT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("mz_starts          7 searches reach widths from"));
  EXPECT_THAT(r.out, HasSubstr("the minimum zone has several local minima for this coverage"));
  const json j = ReadJson(o.json_path);
  const json& starts = j["mz_check"]["starts"];
  ASSERT_TRUE(starts.is_object());
  EXPECT_FALSE(starts["agree"].get<bool>());
  ASSERT_EQ(starts["runs"].size(), 7u);
  double lo = 1e300, hi = 0.0;
  for (const json& run : starts["runs"]) {
    lo = std::min(lo, run["width_um"].get<double>());
    hi = std::max(hi, run["width_um"].get<double>());
  }
  EXPECT_EQ(lo, j["sphericity_mz_um"].get<double>());
  EXPECT_GT(hi - lo, 0.1);  // um
  EXPECT_NEAR(starts["width_spread_um"].get<double>(), hi - lo, 1e-9);
  EXPECT_GT(starts["center_spread_um"].get<double>(), 1000.0);

  o.points_path = Simulated("full.txt", {Eigen::Vector3d(2, 0, 0)});
  o.workflow.xyz = false;
  o.workflow.calibration_path = Calibration();
  o.workflow.uncertainty_samples = 0;
  o.workflow.noise_floor_draws = 0;
  o.json_path = dir_ + "/full.json";
  const RunOutput full = Measure(o);
  ASSERT_EQ(full.code, kExitOk) << full.err;
  EXPECT_THAT(full.out, HasSubstr("mz_certified_um"));
  EXPECT_THAT(full.out, Not(HasSubstr("mz_starts")));
  const json jf = ReadJson(o.json_path);
  EXPECT_TRUE(jf["mz_check"]["starts"].is_null());
  // sqrt(2 R 1 nm) = 6.3 um on a 20 mm sphere; the near region is about twice the width (2 f / w
  // with w >= 2 sqrt(lambda_min), near 1 for the paper's grid).
  EXPECT_NEAR(jf["mz_check"]["certified_radius_um"].get<double>(), 6.3, 0.1);
  EXPECT_LT(jf["mz_check"]["near_radius_um"].get<double>(), 2.5 * jf["sphericity_mz_um"].get<double>());
  EXPECT_LT(jf["mz_check"]["max_decrease_near_um"].get<double>(), 1e-5);
}

TEST_F(MeasureCmd, ACalibrationWithoutCovarianceStillCompensates) {
  CalibrationFile cal = ReadCalibrationFile(Calibration());
  cal.covariance.reset();
  const std::string path = dir_ + "/nocov.json";
  WriteCalibrationFile(path, cal);
  MeasureOptions o;
  o.points_path = Simulated("measure.txt", {Eigen::Vector3d(2.0, 0.0, 0.0)});
  o.workflow.calibration_path = path;
  o.json_path = dir_ + "/m.json";
  const RunOutput r = Measure(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("uncertainty from the calibration: none (" + path + " holds no covariance)"));
  const json j = ReadJson(o.json_path);
  EXPECT_TRUE(j["uncertainty"].is_null());
  EXPECT_THAT(j["uncertainty_note"].get<std::string>(), HasSubstr("holds no covariance"));
}

TEST_F(MeasureCmd, ChoosesASetupOfSeveral) {
  MeasureOptions o;
  o.points_path = Simulated("two.txt", {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 3, 0)});
  o.workflow.calibration_path = Calibration();
  o.workflow.mc_max_trials = 0;  // the budget's Monte Carlo check is not what this test is about
  o.json_path = dir_ + "/m.json";
  RunOutput r = Measure(o);
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("two.txt: the file holds several setups (0 1), each a placement of a sphere: choose "
                               "one with --setup"));
  o.workflow.setup = 1;
  r = Measure(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  const json j = ReadJson(o.json_path);
  EXPECT_EQ(j["input"]["setup"], 1);
  EXPECT_EQ(j["input"]["n_points"], 288);
  EXPECT_NEAR(j["center_mm"][1].get<double>(), 3.0, 1e-3);
  o.workflow.setup = 7;
  EXPECT_THAT(Measure(o).err, HasSubstr("two.txt: there is no setup 7"));
}

// A setup that measured another sphere is measured against that sphere's stated radius.
TEST_F(MeasureCmd, TheRadiusDeviationIsFromTheSetupsOwnSphere) {
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(1, 0, 0)};
  spec.sphere_radii_mm = {{1, 10.0}};
  const std::string points = dir_ + "/two.txt";
  WritePointsFile(points, Simulate(spec));
  CalibrationFile cal;
  cal.geometry = SimulationSpec::PaperTruth();
  cal.probe_offset_mm = 25.0;
  WriteCalibrationFile(dir_ + "/exact.json", cal);
  MeasureOptions o;
  o.points_path = points;
  o.workflow.calibration_path = dir_ + "/exact.json";
  o.workflow.setup = 1;
  o.workflow.mc_max_trials = 0;
  o.json_path = dir_ + "/m.json";
  const RunOutput r = Measure(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("(from the file's sphere_radius_mm@1 10)"));
  const json j = ReadJson(o.json_path);
  EXPECT_EQ(j["header_sphere_radius_mm"].get<double>(), 10.0);
  EXPECT_EQ(j["header_sphere_radius_key"], "sphere_radius_mm@1");
  EXPECT_NEAR(j["radius_deviation_um"].get<double>(), 0.0, 1e-6);  // exact readings, the exact calibration
  o.workflow.setup = 0;
  ASSERT_EQ(Measure(o).code, kExitOk);
  EXPECT_EQ(ReadJson(o.json_path)["header_sphere_radius_key"], "sphere_radius_mm");
  EXPECT_NEAR(ReadJson(o.json_path)["radius_deviation_um"].get<double>(), 0.0, 1e-6);
}

TEST_F(MeasureCmd, BadInputExitsTwoNamingTheFile) {
  const std::string readings = Simulated("r.txt", {Eigen::Vector3d(2, 0, 0)});
  auto expect_bad = [&](MeasureOptions o, const std::string& message) {
    const RunOutput r = Measure(o);
    EXPECT_EQ(r.code, kExitBadInput) << message;
    EXPECT_THAT(r.err, HasSubstr("sph_measure: error: " + message));
    EXPECT_EQ(r.out, "");
  };
  MeasureOptions o;
  o.points_path = readings;
  expect_bad(o, readings +
                    ": readings (theta, phi, r) need a calibration to become points: pass --calibration FILE, "
                    "or --xyz when the file holds x y z coordinates");
  o.workflow.xyz = true;
  o.workflow.calibration_path = Calibration();
  expect_bad(o, "--calibration compensates readings (theta, phi, r); " + readings + " is read as x y z coordinates");
  o.workflow.calibration_path.clear();
  {  // readings taken for coordinates: the first row is refused, by file and line
    std::ifstream in(readings);
    std::string line;
    int line_no = 0, fields = 0;
    while (std::getline(in, line)) {
      ++line_no;
      if (line[0] == '#') continue;
      std::istringstream ls(line);
      for (std::string t; ls >> t;) ++fields;
      break;
    }
    ASSERT_NE(fields, 3);
    expect_bad(o, readings + ":" + std::to_string(line_no) + ": expected 3 numbers (x y z), found " +
                      std::to_string(fields) + " fields");
  }
  o.points_path = WriteFile("bad.xyz", "1 2 3\n4 5 6\n7 x 9\n");
  expect_bad(o, o.points_path + ":3: y: 'x' is not a number");
  o.points_path = WriteFile("three.xyz", "1 0 0\n0 1 0\n0 0 1\n");
  expect_bad(o, o.points_path + ": 3 points are too few to determine a sphere (at least 4)");
  o.points_path = dir_ + "/missing.xyz";
  expect_bad(o, o.points_path + ": cannot open for reading");

  MeasureOptions c;
  c.points_path = readings;
  c.workflow.calibration_path = WriteFile("v2.json", R"({"format": "sph-calibration", "format_version": 2})");
  expect_bad(c, c.workflow.calibration_path + ": calibration format version 2 is not supported");
  c.workflow.calibration_path = Calibration();
  c.workflow.uncertainty_samples = 1;
  expect_bad(c, "--uncertainty-samples: 1 draw gives no spread");
  c.workflow.uncertainty_samples = 200;
  PointsData other = ReadPointsFile(readings);
  other.header.probe_offset_mm = 30.0;
  c.points_path = dir_ + "/d30.txt";
  WritePointsFile(c.points_path, other);
  expect_bad(c, c.points_path + ": probe_offset_mm 30 differs from the calibration's 25 (" + Calibration() +
                    "): the calibration belongs to another probe set-up");
}

// Broken input files and unusable output paths: exit 2, one error line naming the file and the
// problem, nothing on stdout, and no output file (whole or partial) left behind.
TEST_F(MeasureCmd, BrokenFilesGiveOneMessageAndExitTwo) {
  auto expect_one_error = [&](const MeasureOptions& o, const std::string& message) {
    const RunOutput r = Measure(o);
    EXPECT_EQ(r.code, kExitBadInput) << message;
    EXPECT_EQ(r.out, "") << message;
    EXPECT_THAT(r.err, HasSubstr("sph_measure: error: " + message));
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  };
  MeasureOptions o;
  o.workflow.calibration_path = Calibration();
  o.points_path = WriteFile("empty.txt", "");
  expect_one_error(o, o.points_path + ": no samples (the file has 0 lines, none of them a sample)");
  o.points_path = WriteFile("header.txt", "# sph-points 1\n# sphere_radius_mm: 20\n# probe_offset_mm: 25\n");
  expect_one_error(o, o.points_path + ": no samples (the file has 3 lines, none of them a sample)");
  o.points_path = WriteFile("binary.txt", std::string("\x7f"
                                                      "ELF\x02\x01\x01\0\0\0\0\0\0\0\0\0\x03\0>\0",
                                                      20));
  expect_one_error(o, o.points_path + ":1: binary data (NUL byte): this is not a points file");
  o.points_path = WriteFile("garbage.txt", "\xde\xad\xbe\xef 7.5 4.9\n");
  // Bytes that are not printable ASCII are shown as \xHH, so the message stays readable.
  expect_one_error(o, o.points_path + ":1: column theta_deg: '\\xDE\\xAD\\xBE\\xEF' is not a number");
  o.points_path = WriteFile("nan.txt", "# sph-points 1\n0 7.5 4.9\n15 7.5 nan\n");
  expect_one_error(o, o.points_path + ":3: column r_mm: 'nan' is not a finite number");
  o.points_path = WriteFile("inf.txt", "0 -inf 4.9\n");
  expect_one_error(o, o.points_path + ":1: column phi_deg: '-inf' is not a finite number");
  o.points_path = dir_ + "/missing.txt";
  expect_one_error(o, o.points_path + ": cannot open for reading");
  o.points_path = Simulated("r.txt", {Eigen::Vector3d(2, 0, 0)});
  o.workflow.calibration_path = dir_ + "/missing.json";
  expect_one_error(o, o.workflow.calibration_path + ": cannot open for reading");
  o.workflow.calibration_path = WriteFile("garbage.json", std::string("\0\x01\x02{[", 5));
  expect_one_error(o, o.workflow.calibration_path + ":1: binary data (NUL byte): this is not a calibration file");
  o.workflow.calibration_path = WriteFile("garbage2.json", "{[\x01");
  expect_one_error(o, o.workflow.calibration_path + ": not valid JSON");
  o.workflow.calibration_path = WriteFile("empty.json", "");
  expect_one_error(o, o.workflow.calibration_path + ": not valid JSON");

  MeasureOptions x;
  x.workflow.xyz = true;
  x.points_path = WriteFile("empty.xyz", "");
  expect_one_error(x, x.points_path + ": no points (expected lines 'x y z')");
  x.points_path = WriteFile("comments.xyz", "# x y z\n# nothing else\n");
  expect_one_error(x, x.points_path + ": no points (expected lines 'x y z')");
  x.points_path = WriteFile("binary.xyz", std::string("1 2 3\n\0\0\0\xff\n", 10));
  expect_one_error(x, x.points_path + ":2: binary data (NUL byte): this is not a text file of points");
  x.points_path = WriteFile("nan.xyz", "1 0 0\n0 1 0\n0 0 nan\n0 0 -1\n");
  expect_one_error(x, x.points_path + ":3: z: 'nan' is not a finite number");
  x.points_path = WriteFile("inf.xyz", "inf 0 0\n");
  expect_one_error(x, x.points_path + ":1: x: 'inf' is not a finite number");
}

TEST_F(MeasureCmd, AnUnwritableOutputLeavesNoFileBehind) {
  const std::string busy = dir_ + "/busy";  // a directory where the file should go
  ASSERT_EQ(std::system(("mkdir -p '" + busy + "/inside'").c_str()), 0);
  auto entries = [&] {
    std::vector<std::string> names;
    const std::string list = dir_ + "/ls.txt";
    EXPECT_EQ(std::system(("ls -A '" + dir_ + "' > '" + list + "'").c_str()), 0);
    std::ifstream in(list);
    for (std::string n; std::getline(in, n);) {
      if (n != "ls.txt") names.push_back(n);
    }
    return names;
  };
  MeasureOptions o;
  o.workflow.xyz = true;
  o.points_path = WriteFile("p.xyz", "1 0 0\n0 1 0\n0 0 1\n-1 0 0\n0 -1 0\n0 0 -1\n");
  const std::vector<std::string> before = entries();
  for (const std::string& target : {std::string("output"), std::string("json")}) {
    for (const std::string& path : {busy, dir_ + "/no/such/dir/out"}) {
      MeasureOptions bad = o;
      (target == "json" ? bad.json_path : bad.output_path) = path;
      const RunOutput r = Measure(bad);
      EXPECT_EQ(r.code, kExitBadInput) << target << " " << path;
      EXPECT_THAT(r.err, HasSubstr("sph_measure: error: " + path +
                                   (path == busy ? ": is a directory; give the name of a file" : ": cannot ")));
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
      EXPECT_EQ(entries(), before) << "left behind by --" << target << " " << path;
      EXPECT_TRUE(Exists(busy + "/inside"));
    }
  }
}

bool HaveGnuplot() { return std::system("command -v gnuplot > /dev/null 2>&1") == 0; }

TEST_F(MeasureCmd, DrawsTheFormErrorMap) {
  if (!HaveGnuplot()) GTEST_SKIP() << "gnuplot is not installed (apt-get install gnuplot-nox)";
  MeasureOptions o;
  o.points_path = Simulated("measure.txt", {Eigen::Vector3d(2.0, 0.0, 0.0)});
  o.workflow.calibration_path = Calibration();
  o.workflow.uncertainty_samples = 0;
  o.workflow.mc_max_trials = 0;
  o.quiet = true;
  // A folder whose name holds a space and a quote, to test the quoting.
  ASSERT_EQ(::mkdir((dir_ + "/plots 'A'").c_str(), 0755), 0);
  o.plot_path = dir_ + "/plots 'A'/form map.png";
  o.plot_script_path = dir_ + "/form.gp";
  const RunOutput r = Measure(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  std::ifstream png(o.plot_path, std::ios::binary);
  std::string head(8, '\0');
  png.read(head.data(), 8);
  EXPECT_EQ(head, std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(sph::testing::ListFolder(dir_ + "/plots 'A'"),
            std::vector<std::string>{"form map.png"});  // no temporary file left
  std::ifstream script(o.plot_script_path);
  const std::string text((std::istreambuf_iterator<char>(script)), std::istreambuf_iterator<char>());
  EXPECT_THAT(text, HasSubstr("$residuals << EOD"));
  // Run alone, the script draws to the image's path (the quote doubled for gnuplot).
  EXPECT_THAT(text, HasSubstr("if (!exists(\"png\")) png = '" + dir_ + "/plots ''A''/form map.png'\nset output png\n"));
  const auto begin = text.find("$residuals << EOD\n"), end = text.find("\nEOD\n");
  ASSERT_NE(begin, std::string::npos);
  ASSERT_NE(end, std::string::npos);
  EXPECT_EQ(std::count(text.begin() + static_cast<long>(begin), text.begin() + static_cast<long>(end), '\n'), 288);
}

TEST_F(MeasureCmd, WithoutGnuplotSaysHowToGetIt) {
  MeasureOptions o;
  o.points_path = kNistDir + std::string("sph5.ds");
  o.workflow.xyz = true;
  o.quiet = true;
  o.plot_path = dir_ + "/map.png";
  o.gnuplot = dir_ + "/no-such-gnuplot";
  const RunOutput r = Measure(o);
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr(o.plot_path + ": cannot draw the form-error map: the program '" + o.gnuplot +
                               "' was not found; install gnuplot (Debian: apt-get install gnuplot-nox)"));
  EXPECT_FALSE(Exists(o.plot_path));
  EXPECT_FALSE(Exists(o.plot_path + ".tmp"));
  EXPECT_FALSE(Exists(o.plot_path + ".gp.tmp"));
}

// CLI::App::parse(vector) takes the arguments in reverse order; this takes them as typed.
void ParseArgs(CLI::App& app, std::vector<std::string> args) {
  std::reverse(args.begin(), args.end());
  app.parse(args);
}

TEST_F(MeasureCmd, ProgressOnRequestNamesEachStageAndEveryDrawByDefaultNone) {
  MeasureOptions o;
  o.points_path = Simulated("progress.txt", {Eigen::Vector3d(1.0, 1.0, 0.5)});
  o.workflow.calibration_path = Calibration();
  o.workflow.uncertainty_samples = 20;
  o.workflow.mc_max_trials = 0;                 // the budget's Monte Carlo check is not what this test is about
  const RunOutput quiet = Measure(o);  // stderr is no terminal here: nothing by default
  ASSERT_EQ(quiet.code, kExitOk) << quiet.err;
  EXPECT_THAT(quiet.err, Not(HasSubstr("sph_measure: reading")));
  o.progress = ProgressMode::kAlways;
  const RunOutput r = Measure(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.err, HasSubstr("sph_measure: reading " + o.points_path + "\n"));
  EXPECT_THAT(r.err, HasSubstr("sph_measure: fitting the spheres of 288 points\n"));
  EXPECT_THAT(r.err, HasSubstr("sph_measure: uncertainty: calibration draws 100% (20/20)\n"));
  EXPECT_EQ(r.out, quiet.out);  // the report is the same
}

TEST(MeasureCli, ParsesOptions) {
  CLI::App app;
  MeasureOptions o;
  SetupMeasureApp(app, o);
  ParseArgs(app, {"p.txt", "-c", "cal.json", "--setup", "2", "--json", "-", "-o", "pts.xyz", "--plot", "m.png",
                  "--uncertainty-samples", "50", "--seed", "9", "--max-dilution", "20"});
  EXPECT_EQ(o.points_path, "p.txt");
  EXPECT_EQ(o.workflow.calibration_path, "cal.json");
  ASSERT_TRUE(o.workflow.setup.has_value());
  EXPECT_EQ(*o.workflow.setup, 2);
  EXPECT_EQ(o.json_path, "-");
  EXPECT_EQ(o.output_path, "pts.xyz");
  EXPECT_EQ(o.plot_path, "m.png");
  EXPECT_EQ(o.workflow.uncertainty_samples, 50);
  EXPECT_EQ(o.workflow.seed, 9u);
  EXPECT_EQ(o.workflow.max_dilution, 20.0);
  EXPECT_FALSE(o.workflow.xyz);

  CLI::App app2;
  MeasureOptions x;
  SetupMeasureApp(app2, x);
  ParseArgs(app2, {"--xyz", "sph1.ds"});
  EXPECT_TRUE(x.workflow.xyz);
  EXPECT_EQ(x.points_path, "sph1.ds");
  CLI::App app3;
  MeasureOptions bad;
  SetupMeasureApp(app3, bad);
  EXPECT_THROW(ParseArgs(app3, {"p.txt", "--max-dilution", "-1"}), CLI::ValidationError);
  EXPECT_EQ(bad.progress, ProgressMode::kAuto);
  CLI::App app4;
  MeasureOptions p;
  SetupMeasureApp(app4, p);
  ParseArgs(app4, {"p.txt", "--no-progress"});
  EXPECT_EQ(p.progress, ProgressMode::kNever);
  CLI::App app5;
  MeasureOptions both;
  SetupMeasureApp(app5, both);
  EXPECT_THROW(ParseArgs(app5, {"p.txt", "--progress", "--no-progress"}), CLI::ExcludesError);
}

// The calibration sphere measured again, turned on its mount: with the calibration file's form
// of it taken off, what is left is the noise; without, the form is the sphericity.
TEST_F(MeasureCmd, SubtractsTheCalibrationSpheresForm) {
  SimulationSpec spec;
  spec.noise_r_um = 0.002;
  spec.effects.form = {{3, 1, 0.2}, {4, -2, -0.15}};
  spec.mount_rotations_deg[0] = Eigen::Vector3d(0, 0, 40);
  const std::string points = dir_ + "/sphere.txt";
  WritePointsFile(points, Simulate(spec));
  CalibrationFile cal;
  cal.geometry = SimulationSpec::PaperTruth();
  cal.probe_offset_mm = 25.0;
  cal.form_terms = {{3, 1}, {4, -2}};
  cal.form_values_mm = {0.2 * kMmPerUm, -0.15 * kMmPerUm};
  WriteCalibrationFile(dir_ + "/cal.json", cal);
  MeasureOptions o;
  o.points_path = points;
  o.workflow.calibration_path = dir_ + "/cal.json";
  o.json_path = dir_ + "/with.json";
  o.quiet = true;
  ASSERT_EQ(Measure(o).code, kExitOk);
  const double with_form_um = ReadJson(o.json_path)["sphericity_ls_um"].get<double>();
  o.workflow.subtract_sphere_form = true;
  o.json_path = dir_ + "/without.json";
  const RunOutput r = Measure(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  const json j = ReadJson(o.json_path);
  EXPECT_GT(with_form_um, 0.3);
  EXPECT_LT(j["sphericity_ls_um"].get<double>(), 0.02);  // the noise: 0.002 um, about 6 sigma peak to valley
  EXPECT_TRUE(j["sphere_form"]["subtracted"].get<bool>());
  // A calibration without a form cannot take one off.
  CalibrationFile plain = cal;
  plain.form_terms.clear();
  plain.form_values_mm.clear();
  WriteCalibrationFile(dir_ + "/plain.json", plain);
  o.workflow.calibration_path = dir_ + "/plain.json";
  const RunOutput none = Measure(o);
  EXPECT_EQ(none.code, kExitBadInput);
  EXPECT_THAT(none.err, HasSubstr("holds no form of the calibration sphere"));
}

}  // namespace
}  // namespace sph::apps

namespace sph::apps {
namespace {

// A calibration of the paper's machine (its truth, no covariance) with one effect term.
std::string WriteCalibrationWith(const std::string& path, const EffectTerm& term, const std::vector<double>& values,
                                 const EffectReference& reference) {
  CalibrationFile file;
  file.geometry = SimulationSpec::PaperTruth();
  file.probe_offset_mm = 25.0;
  file.effects.terms = {term};
  file.effect_values = {values};
  file.effects.reference = reference;
  WriteCalibrationFile(path, file);
  return path;
}

// Readings outside those the calibration's probe gain was fitted over are counted in a warning.
TEST_F(MeasureCmd, WarnsWithTheirCountWhenItExtrapolatesTheProbePolynomial) {
  MeasureOptions o;
  o.points_path = Simulated("measure.txt", {Eigen::Vector3d(2.0, 0.0, 0.0)});
  EffectReference ref = WithProbeRange(EffectReference{}, 10.0);
  ref.r_fit_min_mm = 4.0;
  ref.r_fit_max_mm = 6.0;
  o.workflow.calibration_path = WriteCalibrationWith(dir_ + "/cal.json", DefaultTerm(Effect::kProbeGain), {1e-3}, ref);
  o.workflow.uncertainty_samples = 0;
  o.workflow.noise_floor_draws = 0;
  int outside = 0;
  const PointsData points = ReadPointsFile(o.points_path);
  for (const Sample& s : points.samples) outside += s.r_mm < 4.0 || s.r_mm > 6.0 ? 1 : 0;
  ASSERT_GT(outside, 0);
  const RunOutput r = Measure(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.err, HasSubstr(std::to_string(outside) + " of " + std::to_string(points.samples.size()) +
                               " readings lie outside the probe readings the calibration's probe terms were fitted "
                               "over (r_mm 4.000000 to 6.000000)"));
}

// A probe incidence error, simulated from the ray's angle, is compensated with the centre of the
// measured sphere: noise-free readings then lie on a sphere to rounding, as without the error.
TEST_F(MeasureCmd, CompensatesAProbeIncidenceErrorWithTheMeasuredSpheresCentre) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(1.5, -1.0, 0.5)};
  spec.noise_r_um = 0.0;
  const EffectTerm term = DefaultTerm(Effect::kProbeIncidence);
  spec.effects.model.terms = {term};
  spec.effects.values = {{30e-3}};
  MeasureOptions o;
  o.points_path = dir_ + "/measure.txt";
  WritePointsFile(o.points_path, Simulate(spec));
  o.json_path = dir_ + "/m.json";
  o.quiet = true;
  o.workflow.uncertainty_samples = 0;
  o.workflow.noise_floor_draws = 0;
  o.workflow.calibration_path = WriteCalibrationWith(dir_ + "/cal.json", term, {30e-3}, EffectReference{});
  ASSERT_EQ(Measure(o).code, kExitOk);
  const double with_um = ReadJson(o.json_path)["sphericity_ls_um"].get<double>();
  o.workflow.calibration_path = WriteCalibrationWith(dir_ + "/none.json", term, {0.0}, EffectReference{});
  ASSERT_EQ(Measure(o).code, kExitOk);
  const double without_um = ReadJson(o.json_path)["sphericity_ls_um"].get<double>();
  EXPECT_LT(with_um, 1e-4);
  EXPECT_GT(without_um, 0.05);  // i1 (e / R0)^2 = 30 um x 0.0088: 0.26 um at most
}

}  // namespace
}  // namespace sph::apps
