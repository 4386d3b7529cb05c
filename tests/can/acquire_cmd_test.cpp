// sph_acquired and sph_cansim through their run functions, and the installed programs for the
// signal tests: replay of simulated logs, every fault, restarts, output errors, the end-to-end
// calibration.
#include "acquire_cmd.hpp"

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <CLI/CLI.hpp>

#include "app_common.hpp"
#include "cansim_cmd.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/core/error.hpp"
#include "sph/io/points_file.hpp"
#include "sph/simulation/simulate.hpp"
#include "test_util.hpp"

namespace sph::apps {
namespace {

// A simulated log of the default machine; `extra` adjusts the options.
std::string MakeLog(const std::string& dir, const std::string& name, void (*extra)(CansimOptions&) = nullptr) {
  CansimOptions o;
  o.bus.output_path = dir + "/" + name;
  o.bus.devices.sync_period_ms = 10.0;
  o.bus.sim.stop_s = 1.0;
  o.bus.sim.move_s = 0.5;
  if (extra != nullptr) extra(o);
  std::ostringstream err;
  EXPECT_EQ(RunCansim(o, err), kExitOk) << err.str();
  return o.bus.output_path;
}

AcquireOptions ReplayOptions(const std::string& log, const std::string& out) {
  AcquireOptions o;
  o.acq.replay_path = log;
  o.acq.output_path = out;
  o.acq.sphere_radius_mm = 20.0;
  o.acq.probe_offset_mm = 25.0;
  o.acq.devices.sync_period_ms = 10.0;
  o.acq.heartbeat_timeout_s = 2.5;
  return o;
}

TEST(Acquire, StreamReplayWritesEverySyncCycle) {
  const std::string dir = sph::testing::MakeTempDir("acq_stream");
  const std::string log = MakeLog(dir, "sim.log", [](CansimOptions& o) {
    o.machine.theta_steps = 4;
    o.machine.phi_steps = 2;
  });
  std::ostringstream err;
  EXPECT_EQ(RunAcquire(ReplayOptions(log, dir + "/p.txt"), err), kExitOk) << err.str();
  const PointsData d = ReadPointsFile(dir + "/p.txt");
  EXPECT_EQ(d.samples.size(), 1150U);  // 8 stops of 1 s + 7 moves of 0.5 s at 10 ms
  EXPECT_NE(err.str().find("samples 1150"), std::string::npos) << err.str();
}

TEST(Acquire, EveryFaultIsCountedReportedAndTheFileStaysReadable) {
  const std::string dir = sph::testing::MakeTempDir("acq_faults");
  const std::string log = MakeLog(dir, "sim.log", [](CansimOptions& o) {
    o.machine.theta_steps = 6;
    o.machine.phi_steps = 3;
    o.bus.sim.faults.drop_probability = 0.01;
    o.bus.sim.faults.short_probability = 0.005;
    o.bus.sim.faults.sync_drop_probability = 0.005;
    o.bus.sim.faults.probe_out_of_range_probability = 0.005;
    o.bus.sim.faults.jitter_us = 2000;
    o.bus.sim.faults.error_frame_period_s = 5.0;
    o.bus.sim.faults.bus_off_at_s = {7.0};
    o.silences = {"probe:10:14"};
    o.emergencies = {"theta:3:8130"};
    o.bus.devices.sync_counter_max = 240;
  });
  { std::ofstream(log, std::ios::app) << "garbage line\n(1700000100.000000) can0 183#0102\n(1.0) can0 181##1\n"; }
  AcquireOptions o = ReplayOptions(log, dir + "/p.txt");
  o.acq.devices.sync_counter_max = 240;
  o.acq.mode = can::Mode::kPoints;
  o.acq.can_log_path = dir + "/frames.log";
  std::ostringstream err;
  EXPECT_EQ(RunAcquire(o, err), kExitSamplesLost) << err.str();
  const std::string e = err.str();
  for (const char* expected : {"error frame: controller-problem{rx-error-warning}", "error frame: bus-off",
                               "node 3 (probe): heartbeat lost", "theta node 1: EMCY 0x8130", "malformed probe PDO",
                               "probe reports out of range", "SYNC cycle missing (never received)", "malformed input: ",
                               "sim.log:", ": CAN FD frames ('##') are not supported", "samples were lost"}) {
    EXPECT_NE(e.find(expected), std::string::npos) << "missing '" << expected << "' in:\n" << e;
  }
  const PointsData d = ReadPointsFile(dir + "/p.txt");
  // Stops are 1 s at t = 1.5 i; the probe's silence from 10 to 14 s swallows the stops at 10.5 and
  // 12 s whole; every other stop still gives its point.
  EXPECT_EQ(d.samples.size(), 16U);
  const std::string file = sph::testing::ReadWholeFile(dir + "/p.txt");
  EXPECT_NE(file.find("incomplete SYNC cycle"), std::string::npos);
  EXPECT_NE(file.find("probe no frame"), std::string::npos);
  // The frame log holds every valid frame of the input, in can-utils' format.
  std::size_t valid = 0;
  {
    std::ifstream in(log);
    for (std::string line; std::getline(in, line);) valid += line.find("##") == std::string::npos && line[0] == '(';
  }
  std::size_t logged = 0;
  {
    std::ifstream in(dir + "/frames.log");
    for (std::string line; std::getline(in, line);) ++logged;
  }
  EXPECT_EQ(logged, valid);
}

TEST(Acquire, ARestartAppendsToTheSameFile) {
  const std::string dir = sph::testing::MakeTempDir("acq_restart");
  const std::string log = MakeLog(dir, "sim.log", [](CansimOptions& o) {
    o.machine.theta_steps = 3;
    o.machine.phi_steps = 1;
  });
  AcquireOptions o = ReplayOptions(log, dir + "/p.txt");
  o.acq.mode = can::Mode::kPoints;
  std::ostringstream err;
  ASSERT_EQ(RunAcquire(o, err), kExitOk) << err.str();
  const std::string first = sph::testing::ReadWholeFile(dir + "/p.txt");
  ASSERT_EQ(RunAcquire(o, err), kExitOk) << err.str();
  const std::string both = sph::testing::ReadWholeFile(dir + "/p.txt");
  EXPECT_EQ(both.rfind(first, 0), 0U);
  EXPECT_EQ(ReadPointsFile(dir + "/p.txt").samples.size(), 6U);
  EXPECT_NE(both.find("# resumed by sph_acquired"), std::string::npos);
}

TEST(Acquire, OutputErrorsExitWith3) {
  const std::string dir = sph::testing::MakeTempDir("acq_full");
  const std::string log = MakeLog(dir, "sim.log", [](CansimOptions& o) {
    o.machine.theta_steps = 2;
    o.machine.phi_steps = 1;
  });
  std::ostringstream err;
  EXPECT_EQ(RunAcquire(ReplayOptions(log, "/dev/full"), err), kExitOutputError);
  EXPECT_NE(err.str().find("/dev/full: cannot write: No space left on device"), std::string::npos) << err.str();
  std::ostringstream err2;
  EXPECT_EQ(RunAcquire(ReplayOptions(log, dir + "/no/such/dir/p.txt"), err2), kExitOutputError);
}

TEST(Acquire, BadInputExitsWith2AndAMissingInterfaceWith4) {
  std::ostringstream err;
  AcquireOptions o;
  o.acq.output_path = sph::testing::MakeTempDir("acq_bad") + "/p.txt";
  EXPECT_EQ(RunAcquire(o, err), kExitBadInput);  // neither --iface nor --replay
  o.acq.replay_path = "/nonexistent.log";
  EXPECT_EQ(RunAcquire(o, err), kExitBadInput);
  EXPECT_NE(err.str().find("/nonexistent.log: cannot open for reading"), std::string::npos) << err.str();
  o.acq.replay_path.clear();
  o.acq.iface = "nosuchcan9";
  std::ostringstream err4;
  EXPECT_EQ(RunAcquire(o, err4), kExitInterfaceError);
  EXPECT_NE(err4.str().find("nosuchcan9: "), std::string::npos) << err4.str();
  o.acq.devices.phi.cob_id = o.acq.devices.theta.cob_id;
  std::ostringstream err2;
  EXPECT_EQ(RunAcquire(o, err2), kExitBadInput);
  EXPECT_NE(err2.str().find("theta and phi use the same CAN id 0x181"), std::string::npos) << err2.str();
}

TEST(Acquire, TheExampleConfigParsesAndSetsEveryDevice) {
  CLI::App app;
  AcquireOptions o;
  SetupAcquireApp(app, o);
  const std::string config = std::string(SPH_SOURCE_DIR) + "/data/sph_acquired.conf";
  // CLI11 takes the arguments reversed.
  ASSERT_NO_THROW(app.parse(std::vector<std::string>{"x.txt", "--output", config, "--config"}));
  EXPECT_EQ(o.acq.iface, "can0");
  EXPECT_EQ(o.acq.mode, can::Mode::kPoints);
  EXPECT_EQ(o.acq.devices.theta.cob_id, 0x181U);
  EXPECT_EQ(o.acq.devices.phi.counts_per_rev, 1U << 24);
  EXPECT_EQ(o.acq.devices.probe_scale_nm_per_count, 1.0);
  EXPECT_EQ(o.acq.devices.sync_counter_max, 0);
  EXPECT_DOUBLE_EQ(o.acq.fsync_interval_s, 1.0);
  EXPECT_FALSE(o.acq.no_nmt);
  EXPECT_FALSE(o.acq.no_sdo);
  EXPECT_DOUBLE_EQ(o.acq.sdo_timeout_ms, 500.0);
  EXPECT_EQ(o.acq.devices.theta.sync_counter_byte, -1);
  EXPECT_NO_THROW(can::CheckAcquisitionOptions(o.acq));
}

TEST(Acquire, HexIdsOnTheCommandLine) {
  CLI::App app;
  AcquireOptions o;
  SetupAcquireApp(app, o);
  ASSERT_NO_THROW(
      app.parse(std::vector<std::string>{"0x1A5", "--probe-cob-id", "o.txt", "-o", "0x8A", "--theta-cob-id"}));
  EXPECT_EQ(o.acq.devices.theta.cob_id, 0x8AU);
  EXPECT_EQ(o.acq.devices.probe_cob_id, 0x1A5U);
}

// Calibrate a points file as sph_calibrate does; the seven errors and their std (internal units).
struct Fit {
  ScmsGeometry value{};
  std::array<double, kNumScmsParams> sd{};
  bool usable = false;
};
Fit CalibrateFile(const PointsData& points) {
  CalibrationOptions co;
  co.sphere_radius_mm = 20.0;
  co.probe_offset_mm = 25.0;
  const CalibrationResult r = Calibrate(points, co);
  Fit f;
  f.value = r.geometry;
  for (int i = 0; i < kNumScmsParams; ++i) f.sd[static_cast<std::size_t>(i)] = r.analysis.std(i);
  f.usable = r.Usable();
  return f;
}

TEST(EndToEnd, SimulatorLogDaemonPointsFileCalibratesLikeSphSimulate) {
  const std::string dir = sph::testing::MakeTempDir("acq_e2e");
  const std::string log = MakeLog(dir, "sim.log");  // the paper's 24 x 12 grid, 1 s stops at 100 Hz
  AcquireOptions o = ReplayOptions(log, dir + "/p.txt");
  o.acq.mode = can::Mode::kPoints;
  std::ostringstream err;
  ASSERT_EQ(RunAcquire(o, err), kExitOk) << err.str();
  const PointsData daemon = ReadPointsFile(dir + "/p.txt");
  ASSERT_EQ(daemon.samples.size(), 288U);
  const Fit from_daemon = CalibrateFile(daemon);
  const Fit from_simulate = CalibrateFile(Simulate(SimulationSpec{}));  // what sph_simulate writes by default
  ASSERT_TRUE(from_daemon.usable);
  ASSERT_TRUE(from_simulate.usable);
  const ScmsGeometry truth = SimulationSpec::PaperTruth();
  for (int i = 0; i < kNumScmsParams; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double combined = std::hypot(from_daemon.sd[k], from_simulate.sd[k]);
    // Coverage factor 3 on the reported standard uncertainties.
    EXPECT_LE(std::abs(from_daemon.value[k] - from_simulate.value[k]), 3.0 * combined) << "parameter " << i;
    EXPECT_LE(std::abs(from_daemon.value[k] - truth[k]), 3.0 * from_daemon.sd[k]) << "parameter " << i;
  }
}

// A sphere with a form, turned on its mount: the simulator ray-traces the turned form, and the
// daemon writes the turn into the points file's header for the calibrator.
TEST(EndToEnd, ASphereTurnedOnItsMountWithAFormReachesThePointsFile) {
  const std::string dir = sph::testing::MakeTempDir("acq_form");
  const std::string log = MakeLog(dir, "sim.log", [](CansimOptions& c) {
    c.mount_rotation_deg = "0,90,0";
    c.form.harmonics_um = {"3,2,0.2"};
    c.form.bumps_um = {"0.1,10,1,0,0"};
  });
  AcquireOptions o = ReplayOptions(log, dir + "/p.txt");
  o.acq.mode = can::Mode::kPoints;
  o.acq.mount_rotation = MountRotation::Known({0.0, 90.0, 0.0});
  std::ostringstream err;
  ASSERT_EQ(RunAcquire(o, err), kExitOk) << err.str();
  const PointsData daemon = ReadPointsFile(dir + "/p.txt");
  ASSERT_EQ(daemon.samples.size(), 288U);
  ASSERT_EQ(daemon.header.mount_rotations.count(0), 1U);
  ASSERT_TRUE(daemon.header.mount_rotations.at(0).known());
  EXPECT_EQ(*daemon.header.mount_rotations.at(0).rotation_deg, Eigen::Vector3d(0.0, 90.0, 0.0));

  // The exact readings of the same sphere, turned and not, by the ray tracer.
  SimulationSpec spec;
  spec.effects.form = {{3, 2, 0.2}};
  spec.effects.bumps = {{0.1, 10.0, Eigen::Vector3d(1.0, 0.0, 0.0)}};
  const PointsData unturned = SimulateExact(spec);
  spec.mount_rotations_deg[0] = Eigen::Vector3d(0.0, 90.0, 0.0);
  const PointsData turned = SimulateExact(spec);
  auto key = [](const Sample& s) {
    return std::make_pair(std::lround(s.theta_deg * 1e3), std::lround(s.phi_deg * 1e3));
  };
  std::map<std::pair<long, long>, std::pair<double, double>> exact;
  for (std::size_t i = 0; i < turned.samples.size(); ++i) {
    exact[key(turned.samples[i])] = {turned.samples[i].r_mm, unturned.samples[i].r_mm};
  }
  double worst_um = 0.0, turn_shows_um = 0.0;
  for (const Sample& s : daemon.samples) {
    const auto it = exact.find(key(s));
    ASSERT_NE(it, exact.end()) << s.theta_deg << " " << s.phi_deg;
    worst_um = std::max(worst_um, std::abs(s.r_mm - it->second.first) * kUmPerMm);
    turn_shows_um = std::max(turn_shows_um, std::abs(it->second.first - it->second.second) * kUmPerMm);
  }
  // Each point averages about 100 readings of 0.05 um noise: 0.005 um; the turn moves the form by
  // up to tenths of a micrometre.
  EXPECT_LT(worst_um, 0.03);
  EXPECT_GT(turn_shows_um, 0.1);
}

// One sphere in two orientations, acquired by two runs into one file: the second run's rotation is
// written before its setup's first row, and a run that contradicts it is refused.
TEST(Acquire, ARunAppendingANewOrientationWritesItsMountRotation) {
  const std::string dir = sph::testing::MakeTempDir("acq_turns");
  const std::string log = MakeLog(dir, "sim.log");
  AcquireOptions o = ReplayOptions(log, dir + "/p.txt");
  o.acq.mode = can::Mode::kPoints;
  o.acq.mount_rotation = MountRotation::Known({0.0, 0.0, 0.0});
  std::ostringstream err;
  ASSERT_EQ(RunAcquire(o, err), kExitOk) << err.str();
  o.acq.setup = 1;
  o.acq.mount_rotation = MountRotation::Known({0.0, 90.0, 0.0});
  ASSERT_EQ(RunAcquire(o, err), kExitOk) << err.str();
  const PointsData both = ReadPointsFile(dir + "/p.txt");
  ASSERT_EQ(both.samples.size(), 576U);
  ASSERT_EQ(both.header.mount_rotations.size(), 2U);
  EXPECT_EQ(*both.header.mount_rotations.at(0).rotation_deg, Eigen::Vector3d::Zero());
  EXPECT_EQ(*both.header.mount_rotations.at(1).rotation_deg, Eigen::Vector3d(0.0, 90.0, 0.0));
  o.acq.mount_rotation = MountRotation::Known({0.0, 0.0, 90.0});
  std::ostringstream refused;
  EXPECT_EQ(RunAcquire(o, refused), kExitOutputError);
  EXPECT_NE(refused.str().find("has mount_rotation_deg@1 0 90 0 but this run writes 0 0 90"), std::string::npos)
      << refused.str();
  EXPECT_EQ(ReadPointsFile(dir + "/p.txt").samples.size(), 576U);
  // A third run on another sphere: its radius, for its setup, before its first row.
  o.acq.setup = 2;
  o.acq.mount_rotation.reset();
  o.acq.other_sphere_radius_mm = 10.0;
  ASSERT_EQ(RunAcquire(o, err), kExitOk) << err.str();
  const PointsData three = ReadPointsFile(dir + "/p.txt");
  EXPECT_EQ(three.samples.size(), 864U);
  EXPECT_EQ(three.header.sphere_radii_mm, (std::map<int, double>{{2, 10.0}}));
}

// --mount-rotation-deg and --probe-pdo-object are parsed into the library's types; a text that is
// neither is refused naming it (the bad-input matrix runs the program on them).
TEST(Acquire, TheMountRotationAndThePdoObjectAreParsedIntoTheLibrarysTypes) {
  const auto parse = [](std::vector<std::string> args) {
    CLI::App app;
    auto o = std::make_unique<AcquireOptions>();
    SetupAcquireApp(app, *o);
    args.insert(args.end(), {"-o", "p.txt"});
    std::reverse(args.begin(), args.end());  // CLI11 takes the arguments reversed
    app.parse(args);
    return o;
  };
  const auto turned = parse({"--mount-rotation-deg", "0,90,0", "--probe-pdo-object", "0x2000:01"});
  ASSERT_TRUE(turned->acq.mount_rotation.has_value());
  EXPECT_EQ(*turned->acq.mount_rotation, MountRotation::Known({0.0, 90.0, 0.0}));
  EXPECT_EQ(turned->acq.probe_pdo_object, (can::ObjectAddress{0x2000, 1}));
  EXPECT_EQ(*parse({"--mount-rotation-deg", "unknown"})->acq.mount_rotation, MountRotation::Unknown());
  EXPECT_FALSE(parse({})->acq.mount_rotation.has_value());
  try {
    parse({"--mount-rotation-deg", "0,90"});
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(
        e.what(),
        "--mount-rotation-deg '0,90': expected rx,ry,rz (a rotation vector in deg, axis times angle) or unknown");
  }
}

// The installed program under signals.
pid_t Spawn(const std::vector<std::string>& args, const std::string& stderr_path) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::freopen(stderr_path.c_str(), "w", stderr);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

TEST(AcquireProcess, SigtermFlushesClosesAndSigusr1PrintsTheSummary) {
  const std::string dir = sph::testing::MakeTempDir("acq_sigterm");
  const std::string log = MakeLog(dir, "sim.log", [](CansimOptions& o) {
    o.machine.theta_steps = 24;
    o.machine.phi_steps = 2;
  });
  const pid_t pid = Spawn({SPH_ACQUIRED_PATH, "--replay", log, "-o", dir + "/p.txt", "--replay-speed", "1",
                           "--sync-period-ms", "10", "--fsync-interval-s", "0.2"},
                          dir + "/stderr.txt");
  ASSERT_GT(pid, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  kill(pid, SIGUSR1);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), kExitOk);
  const std::string e = sph::testing::ReadWholeFile(dir + "/stderr.txt");
  EXPECT_NE(e.find("stop requested"), std::string::npos) << e;
  const auto first = e.find("summary: frames");
  ASSERT_NE(first, std::string::npos) << e;
  EXPECT_NE(e.find("summary: frames", first + 1), std::string::npos) << "SIGUSR1 and the end each print one:\n" << e;
  const PointsData d = ReadPointsFile(dir + "/p.txt");
  EXPECT_GT(d.samples.size(), 100U);  // about 180 in 1.8 s at 100 Hz
  EXPECT_LT(d.samples.size(), 400U);  // stopped long before the log's 36 s end
}

TEST(AcquireProcess, Kill9LosesNoWrittenRecordAndTheFileStaysReadable) {
  const std::string dir = sph::testing::MakeTempDir("acq_kill9");
  const std::string log = MakeLog(dir, "sim.log", [](CansimOptions& o) {
    o.machine.theta_steps = 24;
    o.machine.phi_steps = 2;
  });
  for (int run = 0; run < 2; ++run) {  // the second run continues the killed file
    const pid_t pid = Spawn({SPH_ACQUIRED_PATH, "--replay", log, "-o", dir + "/p.txt", "--replay-speed", "1",
                             "--sync-period-ms", "10", "--fsync-interval-s", "0.5"},
                            dir + "/stderr.txt");
    ASSERT_GT(pid, 0);
    std::this_thread::sleep_for(std::chrono::milliseconds(1200));
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFSIGNALED(status));
    const PointsData d = ReadPointsFile(dir + "/p.txt");  // throws if a line is broken
    EXPECT_GT(d.samples.size(), 50U * static_cast<std::size_t>(run + 1));
    const std::string text = sph::testing::ReadWholeFile(dir + "/p.txt");
    EXPECT_EQ(text.back(), '\n');
  }
}

// The program on broken input: one error line, exit 2 (bad input) or 3 (output error), and no
// points file or frame log made.
struct ProcessResult {
  int code = -1;
  std::string err;
};

ProcessResult RunAcquired(const std::vector<std::string>& args, const std::string& dir) {
  std::vector<std::string> argv{SPH_ACQUIRED_PATH};
  argv.insert(argv.end(), args.begin(), args.end());
  const pid_t pid = Spawn(argv, dir + "/stderr.txt");
  int status = 0;
  waitpid(pid, &status, 0);
  ProcessResult r;
  if (WIFEXITED(status)) r.code = WEXITSTATUS(status);
  r.err = sph::testing::ReadWholeFile(dir + "/stderr.txt");
  return r;
}

bool Exists(const std::string& path) { return ::access(path.c_str(), F_OK) == 0; }

std::string WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

TEST(AcquireProcess, BrokenReplayLogsAreBadInputAndMakeNoFile) {
  const std::string dir = sph::testing::MakeTempDir("acq_broken_log");
  const std::string out = dir + "/p.txt", frames = dir + "/frames.log";
  const struct {
    std::string log;
    std::string message;
  } cases[] = {
      {dir + "/missing.log", dir + "/missing.log: cannot open for reading: No such file or directory"},
      {WriteBytes(dir + "/empty.log", ""), dir + "/empty.log: empty: no CAN frame to replay"},
      {WriteBytes(dir + "/blank.log", "\n\n  \n"), dir + "/blank.log: no CAN frame to replay, only blank lines"},
      {WriteBytes(dir + "/binary.log", std::string("\x7f"
                                                   "ELF\x02\x01\x01\0\0\n\xff\xfe(\0)\n",
                                                   16)),
       dir + "/binary.log: no CAN frame in its 2 lines: not a candump log (first: " + dir +
           "/binary.log:1: expected '(seconds.microseconds)' at the start)"},
      {WriteBytes(dir + "/points.log", "# sph-points 1\n# columns: theta_deg phi_deg r_mm\n0 7.5 4.9\n"),
       dir + "/points.log: no CAN frame in its 3 lines: not a candump log (first: " + dir +
           "/points.log:1: expected '(seconds.microseconds)' at the start)"},
      {WriteBytes(dir + "/nan.log", "(nan) can0 080#\n(1.0) can0 181#zz\n"),
       dir + "/nan.log: no CAN frame in its 2 lines: not a candump log (first: " + dir +
           "/nan.log:1: expected '(seconds.microseconds)' at the start)"},
  };
  for (const auto& c : cases) {
    const ProcessResult r = RunAcquired({"--replay", c.log, "-o", out, "--can-log", frames}, dir);
    EXPECT_EQ(r.code, kExitBadInput) << c.log << "\n" << r.err;
    EXPECT_EQ(r.err, "sph_acquired: error: " + c.message + "\n");
    EXPECT_FALSE(Exists(out)) << c.log;
    EXPECT_FALSE(Exists(frames)) << c.log;
  }
}

TEST(AcquireProcess, BadNumbersAndAMissingConfigAreBadInput) {
  const std::string dir = sph::testing::MakeTempDir("acq_bad_numbers");
  const std::string log = WriteBytes(dir + "/one.log", "(1.000000) can0 080#\n");
  const std::string out = dir + "/p.txt";
  const std::string nan_conf = WriteBytes(dir + "/nan.conf", "sphere-radius-mm = nan\n");
  const struct {
    std::vector<std::string> args;
    std::string message;
  } cases[] = {
      {{"--sphere-radius-mm", "nan"}, "--sphere-radius-mm: must be > 0 and <= 1000 mm, got nan"},
      {{"--probe-offset-mm", "-25"}, "--probe-offset-mm: must be > 0 and <= 10000 mm, got -25"},
      {{"--fsync-interval-s", "nan"},
       "--fsync-interval-s: must be -1 (only at the end) or >= 0 and <= 86400 s, got nan"},
      {{"--fsync-interval-s", "-2"}, "--fsync-interval-s: must be -1 (only at the end) or >= 0 and <= 86400 s, got -2"},
      {{"--config", dir + "/missing.conf"},
       dir + "/missing.conf: cannot open the configuration file (--config) for reading: No such file or directory"},
      {{"--config", nan_conf}, nan_conf + ":1: --sphere-radius-mm: must be > 0 and <= 1000 mm, got nan"},
  };
  for (const auto& c : cases) {
    std::vector<std::string> args{"--replay", log, "-o", out};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const ProcessResult r = RunAcquired(args, dir);
    EXPECT_EQ(r.code, kExitBadInput) << c.message << "\n" << r.err;
    EXPECT_EQ(r.err.substr(0, r.err.find('\n') + 1), "sph_acquired: error: " + c.message + "\n");
    EXPECT_FALSE(Exists(out)) << c.message;
  }
}

TEST(AcquireProcess, AnUnwritableOutputExitsThreeAndLeavesNoFile) {
  const std::string dir = sph::testing::MakeTempDir("acq_unwritable");
  const std::string log = MakeLog(dir, "sim.log", [](CansimOptions& o) {
    o.machine.theta_steps = 2;
    o.machine.phi_steps = 1;
  });
  const std::string out = dir + "/p.txt", frames = dir + "/frames.log";
  ASSERT_EQ(::mkdir((dir + "/a_dir").c_str(), 0755), 0);
  const struct {
    std::string points, frame_log, message;
  } cases[] = {
      {dir + "/no/such/dir/p.txt", "", dir + "/no/such/dir/p.txt: cannot open"},
      {dir + "/a_dir", "", dir + "/a_dir: cannot open"},
      {out, dir + "/no/such/dir/frames.log", dir + "/no/such/dir/frames.log: cannot open"},
      {out, dir + "/a_dir", dir + "/a_dir: cannot open"},
  };
  for (const auto& c : cases) {
    std::vector<std::string> args{"--replay", log, "-o", c.points, "--sync-period-ms", "10"};
    if (!c.frame_log.empty()) args.insert(args.end(), {"--can-log", c.frame_log});
    const ProcessResult r = RunAcquired(args, dir);
    EXPECT_EQ(r.code, kExitOutputError) << c.message << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("sph_acquired: error: " + c.message, 0), 0U) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(Exists(out)) << c.message;
    EXPECT_FALSE(Exists(frames)) << c.message;
  }
  // A file that was there is continued, never removed, when the other output fails.
  const ProcessResult first = RunAcquired({"--replay", log, "-o", out, "--sync-period-ms", "10"}, dir);
  ASSERT_EQ(first.code, kExitOk) << first.err;
  const std::string before = sph::testing::ReadWholeFile(out);
  const ProcessResult r = RunAcquired({"--replay", log, "-o", out, "--can-log", dir + "/a_dir"}, dir);
  EXPECT_EQ(r.code, kExitOutputError) << r.err;
  ASSERT_TRUE(Exists(out));
  EXPECT_EQ(sph::testing::ReadWholeFile(out).rfind(before, 0), 0U);
}

// sph_cansim's bad-input matrix: each case one message naming the option or file, exit 2 for bad
// options and 3 for a log that cannot be written (the exit codes of sph_acquired), and no log left
// behind.
TEST(CansimCmd, BadOptionsAndUnwritableLogsFailAndLeaveNothing) {
  const std::string dir = sph::testing::MakeTempDir("cansim_bad");
  struct Case {
    void (*edit)(CansimOptions&);
    int exit;
    std::string message;
  };
  const std::vector<Case> cases{
      {[](CansimOptions& o) { o.silences = {"probe:1"}; }, kExitBadInput,
       "--silence 'probe:1': expected device:from_s:to_s"},
      {[](CansimOptions& o) { o.emergencies = {"theta:1:xyz"}; }, kExitBadInput,
       "--emcy 'theta:1:xyz': code must be 16-bit hex"},
      {[](CansimOptions& o) { o.center_mm = "1,2"; }, kExitBadInput, "--center-mm"},
      {[](CansimOptions& o) { o.faults = {"reboot:1"}; }, kExitBadInput,
       "--fault 'reboot:1': expected reboot:NODE@T, settings-lost:NODE@T, preop:NODE@T or error:NODE@T (NODE a node id "
       "or theta, phi, probe; T in s)"},
      {[](CansimOptions& o) { o.faults = {"reboot:9@1"}; }, kExitBadInput,
       "device simulator: reboot of node 9, which no device is"},
      {[](CansimOptions& o) { o.faults = {"reboot:theta@-1"}; }, kExitBadInput,
       "--fault 'reboot:theta@-1': T: must be >= 0 and <= 1e+08 s, got -1"},
      {[](CansimOptions& o) { o.mount_rotation_deg = "0,x,0"; }, kExitBadInput,
       "--mount-rotation-deg '0,x,0': ry: 'x' is not a number"},
      {[](CansimOptions& o) { o.form.flats_um = {"1,0,0,0"}; }, kExitBadInput,
       "--form-flat-um '1,0,0,0': the direction nx,ny,nz has no length"},
      {[](CansimOptions& o) { o.bus.output_path += "/no/such/dir/sim.log"; }, kExitOutputError, "sim.log"},
  };
  for (const auto& [edit, exit, message] : cases) {
    CansimOptions o;
    o.bus.output_path = dir + "/sim.log";
    edit(o);
    std::ostringstream err;
    EXPECT_EQ(RunCansim(o, err), exit) << message;
    EXPECT_THAT(err.str(), ::testing::HasSubstr(message));
    EXPECT_TRUE(sph::testing::ReadWholeFile(dir + "/sim.log").empty()) << message;
  }
}

}  // namespace
}  // namespace sph::apps
