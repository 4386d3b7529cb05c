#include "simulate_cmd.hpp"

#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app_common.hpp"
#include "sph/io/points_file.hpp"
#include "sph/simulation/simulate.hpp"
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
  o.form.harmonics_um = {"3,2,0.1"};
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
  EXPECT_DOUBLE_EQ(t["form"]["harmonics"]["terms"][0]["amplitude_um"].get<double>(), 0.1);
}

TEST(SimulateCmd, MountRotationsFormsAndScanOrders) {
  const std::string dir = sph::testing::MakeTempDir("simcmd_sep");
  SimulateOptions o;
  o.output_path = dir + "/p.txt";
  o.truth_path = dir + "/truth.json";
  o.centers_mm = {"2,0,0", "0,2,0", "2,0,0"};
  o.mount_rotations_deg = {"1:0,0,90", "2:90,0,0"};
  o.mount_unknown = {"2"};
  o.form.harmonics_um = {"3,2,0.1"};
  o.form.flats_um = {"0.5,0,0,-2"};
  o.form.bumps_um = {"-0.2,3,1,1,0"};
  o.scan_orders = {"serpentine", "1:shuffled"};
  o.machine.noise_r_um = 0.0;
  std::ostringstream err;
  ASSERT_EQ(RunSimulate(o, err), kExitOk) << err.str();
  const PointsData d = ReadPointsFile(o.output_path);
  ASSERT_EQ(d.header.mount_rotations.size(), 2u);
  EXPECT_EQ(d.header.mount_rotations.at(1), MountRotation::Known(Eigen::Vector3d(0, 0, 90)));
  EXPECT_FALSE(d.header.mount_rotations.at(2).known());
  EXPECT_EQ(d.samples[24].theta_deg, 345.0);  // setup 0 in serpentine: ring 1 backwards
  std::ifstream in(o.truth_path);
  const nlohmann::json t = nlohmann::json::parse(in);
  ASSERT_EQ(t["setups"].size(), 3u);
  EXPECT_EQ(t["setups"][1]["scan_order"], "shuffled");
  EXPECT_EQ(t["setups"][2]["scan_order"], "serpentine");
  EXPECT_EQ(t["setups"][1]["header"], "rotation");
  EXPECT_EQ(t["setups"][2]["header"], "unknown");
  EXPECT_EQ(t["setups"][0]["header"], "none");
  EXPECT_DOUBLE_EQ(t["setups"][2]["mount_rotation_deg"][0].get<double>(), 90.0);
  EXPECT_DOUBLE_EQ(t["form"]["flats"][0]["normal_body"][2].get<double>(), -1.0);
  EXPECT_DOUBLE_EQ(t["form"]["bumps"][0]["height_um"].get<double>(), -0.2);
  EXPECT_NEAR(t["form"]["harmonics"]["rms_um"].get<double>(), 0.1 / std::sqrt(7.0), 1e-15);
  EXPECT_GT(t["form"]["pv_um"].get<double>(), 0.5);  // the flat's 0.5 um and more
  // The same readings as the library's simulation of the same spec.
  SimulationSpec spec;
  spec.noise_r_um = 0.0;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(2, 0, 0)};
  spec.mount_rotations_deg = {{1, Eigen::Vector3d(0, 0, 90)}, {2, Eigen::Vector3d(90, 0, 0)}};
  spec.effects.form = {{3, 2, 0.1}};
  spec.effects.flats = {{0.5, Eigen::Vector3d(0, 0, -2)}};
  spec.effects.bumps = {{-0.2, 3.0, Eigen::Vector3d(1, 1, 0)}};
  spec.scan_order = ScanOrder::kSerpentine;
  spec.scan_orders = {{1, ScanOrder::kShuffled}};
  const PointsData lib = Simulate(spec);
  ASSERT_EQ(lib.samples.size(), d.samples.size());
  for (std::size_t i = 0; i < d.samples.size(); ++i) {
    EXPECT_NEAR(d.samples[i].r_mm, lib.samples[i].r_mm, 5e-11) << i;
    EXPECT_NEAR(d.samples[i].theta_deg, lib.samples[i].theta_deg, 5e-11) << i;
  }
}

TEST(SimulateCmd, TheSeparationExampleIsWhatItsCommandMakes) {
  // data/example/separation/points.txt, made again with the options data/README.md gives for it.
  const std::string dir = sph::testing::MakeTempDir("simcmd_example");
  SimulateOptions o;
  o.output_path = dir + "/points.txt";
  o.centers_mm = {"2,0,0", "0,2,0", "-2,0,0", "2,0,0"};
  o.mount_rotations_deg = {"1:0,0,90", "2:0,0,180", "3:90,0,0"};
  o.scan_orders = {"1:serpentine", "2:columns", "3:shuffled"};
  o.form.harmonics_um = {"2,0,0.062",  "2,2,-0.049", "3,1,0.049",  "3,-3,0.037", "4,0,-0.043",
                         "4,2,0.031",  "5,-2,0.037", "5,4,-0.025", "6,1,0.031",  "6,-5,0.025",
                         "7,3,-0.025", "8,0,0.025",  "8,-6,0.019"};
  o.effects_arcsec = {"theta_encoder.c3=5"};
  o.effects_um = {"probe_drift.t1=0.4"};
  o.seed = 11;
  std::ostringstream err;
  ASSERT_EQ(RunSimulate(o, err), kExitOk) << err.str();
  const PointsData made = ReadPointsFile(o.output_path);
  const PointsData example = ReadPointsFile(SPH_SOURCE_DIR "/data/example/separation/points.txt");
  EXPECT_EQ(made.header.mount_rotations, example.header.mount_rotations);
  EXPECT_EQ(example.header.mount_rotations.at(3), MountRotation::Known(Eigen::Vector3d(90, 0, 0)));
  ASSERT_EQ(made.samples.size(), example.samples.size());
  for (std::size_t i = 0; i < made.samples.size(); ++i) {
    EXPECT_EQ(made.samples[i].theta_deg, example.samples[i].theta_deg) << i;
    EXPECT_EQ(made.samples[i].setup, example.samples[i].setup) << i;
    EXPECT_NEAR(made.samples[i].r_mm, example.samples[i].r_mm, 2e-10) << i;  // the last of 10 decimals
  }
}

TEST(SimulateCmd, BadSphereOptionsNameTheOption) {
  const std::vector<std::pair<std::function<void(SimulateOptions&)>, std::string>> cases{
      {[](SimulateOptions& o) { o.mount_rotations_deg = {"0,0,90"}; },
       "--mount-rotation-deg '0,0,90': expected SETUP:rx,ry,rz"},
      {[](SimulateOptions& o) { o.mount_rotations_deg = {"0:0,0"}; }, "--mount-rotation-deg '0:0,0': expected SETUP:"},
      {[](SimulateOptions& o) { o.mount_rotations_deg = {"1:0,0,90"}; },
       "--mount-rotation-deg '1:0,0,90': setup 1 does not exist (the setups are 0 to 0, one per --center-mm)"},
      {[](SimulateOptions& o) {
         o.mount_rotations_deg = {"0:0,0,90", "0:0,0,45"};
       },
       "--mount-rotation-deg '0:0,0,45': setup 0 is given twice"},
      {[](SimulateOptions& o) {
         o.mount_unknown = {"0", "0"};
       },
       "--mount-unknown '0': the setup is given twice"},
      {[](SimulateOptions& o) { o.form.flats_um = {"30000,1,0,0"}; },
       "--form-flat-um '30000,1,0,0': depth_um: must be > 0 and <= 1000 um, got 30000"},
      {[](SimulateOptions& o) {
         o.machine.sphere_radius_mm = 0.5;
         o.machine.probe_offset_mm = 5.0;
         o.form.flats_um = {"600,1,0,0"};
       },
       "--form-flat-um '600,1,0,0': the depth must be smaller than the sphere's radius"},
      {[](SimulateOptions& o) {
         o.scan_orders = {"rings", "columns"};
       },
       "--scan-order 'columns': an order for every setup is given twice"},
      {[](SimulateOptions& o) {
         o.scan_orders = {"0:rings", "0:columns"};
       },
       "--scan-order '0:columns': the setup is given twice"},
  };
  for (const auto& [set, message] : cases) {
    const std::string dir = sph::testing::MakeTempDir("simcmd_bad_sphere");
    SimulateOptions o;
    o.output_path = dir + "/p.txt";
    set(o);
    std::ostringstream err;
    EXPECT_EQ(RunSimulate(o, err), kExitBadInput);
    EXPECT_THAT(err.str(), HasSubstr(message));
    EXPECT_TRUE(sph::testing::ReadWholeFile(o.output_path).empty()) << "no file is left behind";
  }
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
