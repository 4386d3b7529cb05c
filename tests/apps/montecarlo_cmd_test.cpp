#include "montecarlo_cmd.hpp"

#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_util.hpp"

namespace sph::apps {
namespace {

using ::testing::HasSubstr;

struct RunOutput {
  int code;
  std::string out, err;
};

RunOutput RunApp(const MonteCarloAppOptions& o) {
  std::ostringstream out, err;
  const int code = RunMonteCarloApp(o, out, err);
  return {code, out.str(), err.str()};
}

TEST(MonteCarloCmd, TablesJsonAndCsv) {
  const std::string dir = sph::testing::MakeTempDir("mccmd");
  MonteCarloAppOptions o;
  o.trials = 30;
  o.eccentricities_mm = {1.0, 2.0};
  o.json_path = dir + "/mc.json";
  o.csv_path = dir + "/mc.csv";
  const RunOutput r = RunApp(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("Table 2: mean of the calibrations (30 trials per eccentricity"));
  EXPECT_THAT(r.out, HasSubstr("std/CRLB"));
  EXPECT_THAT(r.out, HasSubstr("Table 3"));
  EXPECT_THAT(r.out, HasSubstr("60 calibrations in"));
  std::ifstream in(o.json_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_EQ(j["eccentricities"].size(), 2u);
  const auto& c = j["eccentricities"][1]["parameters"]["c"];
  EXPECT_EQ(c["unit"], "mm");
  for (const char* k : {"true", "mean", "std", "se", "z", "crlb", "std_over_crlb", "bias_second_order"}) {
    EXPECT_TRUE(c[k].is_number()) << k;
  }
  EXPECT_EQ(j["table3"]["rows"].size(), 10u);
  std::ifstream csv(o.csv_path);
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header, "eccentricity_mm,parameter,unit,true,mean,std,se,z,crlb,std_over_crlb,converged,trials,determined");
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 14);
}

TEST(MonteCarloCmd, FigureFourAsPng) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) GTEST_SKIP() << "gnuplot is not installed";
  const std::string dir = sph::testing::MakeTempDir("mcplot") + "/figures";
  MonteCarloAppOptions o;
  o.trials = 20;
  o.table3 = false;
  o.plot_dir = dir;
  const RunOutput r = RunApp(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  for (const char* name : {"fig4_b_c_std.png", "fig4_beta_epsilon_std.png", "fig4_spread.png"}) {
    std::ifstream png(dir + "/" + name, std::ios::binary);
    char magic[8] = {};
    png.read(magic, 8);
    EXPECT_EQ(std::string(magic + 1, 3), "PNG") << name;
  }
}

TEST(MonteCarloCmd, PlanPredictsAndFindsTheEccentricity) {
  MonteCarloAppOptions o;
  o.plan = true;
  o.target_std_um = 2.0;
  const RunOutput r = RunApp(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("Predicted standard deviations"));
  EXPECT_THAT(r.out, HasSubstr("this pattern: 1.9"));  // c needs e = 1.9... mm for 2 um (std ~ 1/e^2)
  EXPECT_THAT(r.out, HasSubstr("96 x 48"));
}

// A parameter that the design does not determine (the sphere at the axes' common point, or
// placed along the Theta axis) is reported so, in the text, the JSON and the plan, as
// sph_calibrate judges it: no bound of 1e15 urad, no bias of 1e38, no std/CRLB of 0 against an
// infinite bound.
TEST(MonteCarloCmd, SaysUndeterminedWhereTheDesignDeterminesNothing) {
  const std::string dir = sph::testing::MakeTempDir("mcundetermined");
  MonteCarloAppOptions o;
  o.trials = 10;
  o.table3 = false;
  o.eccentricities_mm = {0.0};
  o.json_path = dir + "/mc.json";
  RunOutput r = RunApp(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("undetermined         -         -         -  urad"));
  EXPECT_THAT(r.out, HasSubstr("undetermined: alpha (CRLB "));
  EXPECT_THAT(r.out, ::testing::Not(HasSubstr("e+15")));
  nlohmann::json j = nlohmann::json::parse(std::ifstream(o.json_path));
  const auto& row = j["eccentricities"][0];
  EXPECT_EQ(row["undetermined"].size(), 7u);
  EXPECT_EQ(row["parameters"]["alpha"]["determined"], false);
  EXPECT_TRUE(row["parameters"]["alpha"]["bias_second_order"].is_null());
  EXPECT_TRUE(row["parameters"]["alpha"]["std_over_crlb"].is_null());

  o.eccentricities_mm = {2.0};
  o.direction = "0,0,1";  // along the Theta axis: the design has a null space
  r = RunApp(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, ::testing::Not(HasSubstr("0.000       nan")));
  j = nlohmann::json::parse(std::ifstream(o.json_path));
  const auto& along = j["eccentricities"][0]["parameters"]["alpha"];
  EXPECT_EQ(along["determined"], false);
  EXPECT_TRUE(along["crlb"].is_null());  // infinite
  EXPECT_TRUE(along["std_over_crlb"].is_null());

  o.plan = true;
  o.direction = "1,0,0";
  o.eccentricities_mm = {0.0, 2.0};
  o.json_path.clear();
  r = RunApp(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("\n0        undetermined undetermined"));
  EXPECT_THAT(r.out, HasSubstr("\n2              2.9455       0.0096      94.9160"));
  EXPECT_THAT(r.out, HasSubstr("e = 0 mm: undetermined: alpha (std "));
}

// The orientations that separate the form from a radial motion of the Phi axis: with the sphere
// at the axes' common point the zonal terms are functions of phi, as that motion is; a tilt on the
// mount separates them (sph/select/orientation_plan.hpp), and the JSON says the same as the table.
TEST(MonteCarloCmd, PlansTheOrientationsThatSeparateTheForm) {
  const std::string dir = sph::testing::MakeTempDir("mcplan");
  MonteCarloAppOptions o;
  o.plan_orientations = true;
  o.eccentricities_mm = {0.0};
  o.effects = {"phi_radial_motion"};
  o.form_degree_max = 4;
  o.json_path = dir + "/plan.json";
  const RunOutput r = RunApp(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("separate its form (degrees 2..4) from the seven errors, the centres and "
                               "phi_radial_motion"));
  EXPECT_THAT(r.out, HasSubstr("S(2,0) S(3,0) S(4,0)"));
  EXPECT_THAT(r.out, HasSubstr("separable with 2 orientation(s); in the points file: mount_rotation_deg@0: 0 0 0, "
                               "mount_rotation_deg@1: "));
  std::ifstream in(o.json_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_EQ(j["plans"].size(), 1u);
  const nlohmann::json& plan = j["plans"][0];
  EXPECT_EQ(plan["separable"], true);
  ASSERT_EQ(plan["steps"].size(), 2u);
  EXPECT_EQ(plan["steps"][0]["confounded"], nlohmann::json({"S(2,0)", "S(3,0)", "S(4,0)"}));
  EXPECT_TRUE(plan["steps"][1]["confounded"].empty());
  EXPECT_LT(plan["steps"][1]["max_variance_inflation"].get<double>(), 1e4);

  o.candidate_rotations = {"0,0,90", "0,0,180"};
  o.json_path.clear();
  const RunOutput turns = RunApp(o);
  ASSERT_EQ(turns.code, kExitOk) << turns.err;
  EXPECT_THAT(turns.out, HasSubstr("not separable with these candidates: no further one helps; still confounded: "
                                   "S(2,0) S(3,0) S(4,0)"));
}

// The plan then judges the effects among themselves: a tilt of the Theta spindle and its axial
// motion move a sphere at one eccentricity alike, and the report names the placement that tells
// them apart, as text and JSON.
TEST(MonteCarloCmd, PlansThePlacementThatTellsTwoEffectsApart) {
  const std::string dir = sph::testing::MakeTempDir("mcplanfx");
  MonteCarloAppOptions o;
  o.plan_orientations = true;
  o.eccentricities_mm = {2.0};
  o.effects = {"theta_axial_motion", "theta_tilt_motion", "probe_drift"};
  o.form_degree_max = 4;
  o.json_path = dir + "/plan.json";
  const RunOutput r = RunApp(o);
  ASSERT_EQ(r.code, kExitOk) << r.err;
  EXPECT_THAT(r.out, HasSubstr("effects these orientations do not tell apart"));
  EXPECT_THAT(r.out, HasSubstr("theta_axial_motion and theta_tilt_motion: "));
  EXPECT_THAT(r.out, HasSubstr("; a second placement at three times the eccentricity (6 mm): "));
  std::ifstream in(o.json_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  const nlohmann::json& pairs = j["plans"][0]["confounded_effects"];
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0]["a"], "theta_axial_motion");
  EXPECT_EQ(pairs[0]["b"], "theta_tilt_motion");
  // Not told apart at all: infinite (null) or, by rounding, merely huge.
  EXPECT_TRUE(pairs[0]["factor"].is_null() || pairs[0]["factor"].get<double>() > 1e6) << pairs[0]["factor"];
  EXPECT_LE(pairs[0]["factor_with"].get<double>(), 100.0);
  EXPECT_THAT(pairs[0]["placement"].get<std::string>(), HasSubstr("three times the eccentricity"));
  EXPECT_EQ(pairs[0]["placement_center_mm"], nlohmann::json({6.0, 0.0, 0.0}));  // the paper's centre is (2, 0, 0)
  EXPECT_TRUE(pairs[0]["placement_sphere_radius_mm"].is_null());
  EXPECT_TRUE(pairs[0]["placement_mount_rotations_deg"].empty());
  EXPECT_TRUE(j["plans"][0]["undetermined_effects"].empty());
}

TEST(MonteCarloCmd, BadOptionsExitTwo) {
  MonteCarloAppOptions o;
  o.direction = "0,0,0";
  RunOutput r = RunApp(o);
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("--direction must not be zero"));
  o = MonteCarloAppOptions();
  o.eccentricities_mm = {30.0};
  r = RunApp(o);
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("is not in [0, R0)"));
  o = MonteCarloAppOptions();
  o.target_std_um = 1.0;
  r = RunApp(o);
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("--target-std-um goes with --plan"));
  // Outputs that cannot be written: one message, exit 2, nothing left behind.
  const std::string dir = sph::testing::MakeTempDir("mccmd_bad");
  o = MonteCarloAppOptions();
  o.trials = 5;
  o.eccentricities_mm = {2.0};
  o.json_path = dir + "/no/such/dir/mc.json";
  o.csv_path = dir + "/mc.csv";
  r = RunApp(o);
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("mc.json: cannot"));
  o.json_path.clear();
  o.csv_path = dir;  // a folder
  r = RunApp(o);
  EXPECT_EQ(r.code, kExitBadInput);
  EXPECT_THAT(r.err, HasSubstr("sph_montecarlo: error: " + dir));
}

}  // namespace
}  // namespace sph::apps
