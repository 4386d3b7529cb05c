#include "simulate_cmd.hpp"

#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app_common.hpp"
#include "sph/core/points_file.hpp"
#include "test_util.hpp"

namespace sph::apps {
namespace {

using ::testing::HasSubstr;

TEST(SimulateCmd, DefaultsAreThePapersStudy) {
  const std::string dir = sph::testing::MakeTempDir("simcmd");
  SimulateOptions o;
  o.output_path = dir + "/p.txt";
  o.truth_path = dir + "/truth.json";
  std::ostringstream err;
  ASSERT_EQ(RunSimulate(o, err), kExitOk) << err.str();
  const PointsData d = ReadPointsFile(o.output_path);
  EXPECT_EQ(d.samples.size(), 288u);
  EXPECT_DOUBLE_EQ(*d.header.sphere_radius_mm, 20.0);
  EXPECT_DOUBLE_EQ(*d.header.probe_offset_mm, 25.0);
  EXPECT_TRUE(d.has_time);
  std::ifstream in(o.truth_path);
  const nlohmann::json t = nlohmann::json::parse(in);
  EXPECT_DOUBLE_EQ(t["geometry"]["d_prime"]["value"].get<double>(), -0.062);
  EXPECT_DOUBLE_EQ(t["centers_mm"][0][0].get<double>(), 2.0);
}

TEST(SimulateCmd, SeveralCentresAndAnExplicitPattern) {
  const std::string dir = sph::testing::MakeTempDir("simcmd2");
  std::ofstream(dir + "/angles.txt") << "# theta phi\n0 30\n90 60\n180 90\n270 120\n45 150\n";
  SimulateOptions o;
  o.output_path = dir + "/p.txt";
  o.machine.angles_path = dir + "/angles.txt";
  o.centers_mm = {"1,0,0", "0,0,-1.5"};
  std::ostringstream err;
  ASSERT_EQ(RunSimulate(o, err), kExitOk) << err.str();
  const PointsData d = ReadPointsFile(o.output_path);
  EXPECT_EQ(d.samples.size(), 10u);
  EXPECT_EQ(d.SetupIds(), (std::vector<int>{0, 1}));
}

TEST(SimulateCmd, BadOptionsExitTwo) {
  SimulateOptions o;
  o.output_path = "-";
  o.centers_mm = {"1,0"};
  std::ostringstream err;
  EXPECT_EQ(RunSimulate(o, err), kExitBadInput);
  EXPECT_THAT(err.str(), HasSubstr("--center-mm '1,0': expected x,y,z in mm"));
  o.centers_mm = {"0,40,0"};
  std::ostringstream err2;
  EXPECT_EQ(RunSimulate(o, err2), kExitBadInput);
  EXPECT_THAT(err2.str(), HasSubstr("misses the sphere"));
}

}  // namespace
}  // namespace sph::apps

namespace sph::apps {
namespace {

TEST(SimulateCmd, EffectsGoIntoTheReadingsAndTheTruthButNotTheFile) {
  const std::string dir = sph::testing::MakeTempDir("simcmd_effects");
  SimulateOptions o;
  o.output_path = dir + "/p.txt";
  o.truth_path = dir + "/truth.json";
  o.effects_arcsec = {"theta_encoder.c2=6", "theta_encoder.s3=-4"};
  o.effects_um = {"probe_drift.t1=0.6"};
  o.form_um = {"3,2,0.1"};
  std::ostringstream err;
  ASSERT_EQ(RunSimulate(o, err), kExitOk) << err.str();
  const std::string text = sph::testing::ReadWholeFile(o.output_path);
  EXPECT_THAT(text, ::testing::Not(HasSubstr("encoder")));
  EXPECT_THAT(text, ::testing::Not(HasSubstr("drift")));
  std::ifstream in(o.truth_path);
  const nlohmann::json t = nlohmann::json::parse(in);
  ASSERT_EQ(t["effects"].size(), 2u);
  EXPECT_EQ(t["effects"][0]["id"], "theta_encoder");
  EXPECT_DOUBLE_EQ(t["effects"][0]["parameters"]["theta_encoder.s3"]["value"].get<double>(), -4.0);
  EXPECT_EQ(t["effects"][0]["parameters"]["theta_encoder.s3"]["unit"], "arcsec");
  EXPECT_DOUBLE_EQ(t["form_um"][0]["amplitude_um"].get<double>(), 0.1);
}

TEST(SimulateCmd, UnwritableOutputsExitTwoAndLeaveNothing) {
  const std::string dir = sph::testing::MakeTempDir("simcmd_out");
  for (const std::string& path : {dir + "/no/such/dir/p.txt", dir}) {
    SimulateOptions o;
    o.output_path = path;
    std::ostringstream err;
    EXPECT_EQ(RunSimulate(o, err), kExitBadInput) << path;
    EXPECT_THAT(err.str(), HasSubstr("sph_simulate: error: " + path));
  }
  SimulateOptions o;
  o.output_path = dir + "/p.txt";
  o.truth_path = dir + "/no/such/dir/truth.json";
  std::ostringstream err;
  EXPECT_EQ(RunSimulate(o, err), kExitBadInput);
  EXPECT_THAT(err.str(), HasSubstr("truth.json: cannot"));
  EXPECT_TRUE(sph::testing::ReadWholeFile(o.output_path).empty()) << "the points file is not written either";
}

TEST(SimulateCmd, BadEffectsAreRefusedWithTheirOption) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases{
      {{"theta_encoder"}, "--effect-arcsec theta_encoder: expected id.param=value"},
      {{"encoder.c2=1"}, "unknown effect 'encoder'"},
      {{"theta_encoder.c0=1"}, "theta_encoder has no parameter 'c0'"},
      {{"theta_encoder.c2=x"}, "'x' is not a number"},
      {{"probe_drift.t1=1"}, "probe_drift is a length; give it with --effect-um"},
      {{"theta_encoder.c2=1", "theta_encoder.c2=2"}, "theta_encoder.c2 is given twice"},
  };
  for (const auto& [args, message] : cases) {
    const std::string dir = sph::testing::MakeTempDir("simcmd_bad");
    SimulateOptions o;
    o.output_path = dir + "/p.txt";
    o.effects_arcsec = args;
    std::ostringstream err;
    EXPECT_EQ(RunSimulate(o, err), kExitBadInput);
    EXPECT_THAT(err.str(), HasSubstr(message));
    EXPECT_TRUE(sph::testing::ReadWholeFile(o.output_path).empty()) << "no file is left behind";
  }
}

}  // namespace
}  // namespace sph::apps
