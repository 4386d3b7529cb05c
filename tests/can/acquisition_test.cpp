// The acquisition and the simulated bus as a host program calls them: sph::can alone, no command
// line. A log simulated by the library is replayed by the library into a points file; the options
// a host sets are checked by the library with the daemon's words; RunControl stops a run and asks
// for its summary; the fault texts of the simulator parse into its types.
#include "sph/can/acquisition.hpp"

#include <unistd.h>

#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/can/bus_simulation.hpp"
#include "sph/core/error.hpp"
#include "sph/io/points_file.hpp"
#include "test_util.hpp"

namespace sph::can {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

bool Exists(const std::string& path) { return ::access(path.c_str(), F_OK) == 0; }

// A log of 4 x 2 stops of 1 s at a SYNC every 10 ms, written by the library's simulated bus.
std::string SimulatedLog(const std::string& dir) {
  BusSimulationOptions b;
  b.output_path = dir + "/sim.log";
  b.devices.sync_period_ms = 10.0;
  b.sim.spec.pattern = GridPattern(4, 2);
  RunControl control;
  std::vector<std::string> lines;
  const BusSimulationResult r =
      SimulateBusLog(b, control, {[&](LogLevel, const std::string& text) { lines.push_back(text); }});
  EXPECT_EQ(r.status, BusSimulationStatus::kOk) << r.error;
  EXPECT_EQ(r.cycles, 1150U);  // 8 stops of 1 s and 7 moves of 0.5 s at 10 ms
  EXPECT_EQ(r.injected.pdos[kProbe], 1150U);
  EXPECT_THAT(lines, ::testing::ElementsAre("1150 SYNC cycles, 11.5 s", StartsWith("cycles 1150, SYNC dropped 0")));
  return b.output_path;
}

AcquisitionOptions ReplayOf(const std::string& log, const std::string& points) {
  AcquisitionOptions o;
  o.replay_path = log;
  o.output_path = points;
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  o.devices.sync_period_ms = 10.0;
  o.mode = Mode::kPoints;
  return o;
}

// What a run told: its log lines and each summary.
struct Told {
  std::vector<std::string> lines;
  std::vector<AcquisitionResult> summaries;
  AcquisitionHooks Hooks() {
    return {[this](LogLevel level, const std::string& text) { lines.push_back(ToString(level) + (": " + text)); },
            [this](const AcquisitionResult& r) { summaries.push_back(r); }};
  }
};

TEST(AcquisitionLibrary, AHostReplaysALogIntoAPointsFileWithoutTheCommandLine) {
  const std::string dir = sph::testing::MakeTempDir("host_replay");
  AcquisitionOptions o = ReplayOf(SimulatedLog(dir), dir + "/p.txt");
  o.can_log_path = dir + "/frames.log";
  o.generator = "host-software 2.1";
  RunControl control;
  Told told;
  const AcquisitionResult r = ReplayAcquisition(o, control, told.Hooks());
  ASSERT_EQ(r.status, AcquisitionStatus::kOk) << r.error;
  EXPECT_TRUE(r.acquired);
  EXPECT_TRUE(r.outputs_opened);
  EXPECT_EQ(r.counts.cycles, 1150U);
  EXPECT_EQ(r.counts.points, 8U);
  EXPECT_EQ(r.rows_written, 8U);
  EXPECT_EQ(r.frames_logged, r.counts.frames);
  EXPECT_EQ(r.losses, 0U);
  EXPECT_TRUE(r.warnings.empty());
  const PointsData d = ReadPointsFile(o.output_path);
  EXPECT_EQ(d.samples.size(), 8U);
  EXPECT_THAT(d.header.metadata, ::testing::Contains(::testing::Pair("generator", "host-software 2.1")));
  EXPECT_THAT(d.header.metadata, ::testing::Contains(::testing::Pair("mode", "points")));
  // The summary is told once, at the end, and rendered by the library.
  ASSERT_EQ(told.summaries.size(), 1U);
  const std::vector<std::string> summary = SummaryLines(told.summaries[0]);
  ASSERT_EQ(summary.size(), 2U);
  EXPECT_THAT(summary[0],
              StartsWith("frames " + std::to_string(r.counts.frames) + ", SYNC 1150, cycles 1150, samples "));
  EXPECT_EQ(summary[1], o.output_path + ": 8 rows written, frame log " + std::to_string(r.frames_logged) + " frames");
  EXPECT_THAT(told.lines,
              ::testing::Contains(HasSubstr("info: replay of " + o.replay_path + ": acquiring (points mode)")));
  // Run again: the file is continued, and says by whom.
  const AcquisitionResult again = ReplayAcquisition(o, control, {});
  EXPECT_EQ(again.status, AcquisitionStatus::kOk) << again.error;
  EXPECT_EQ(ReadPointsFile(o.output_path).samples.size(), 16U);
  EXPECT_THAT(sph::testing::ReadWholeFile(o.output_path), HasSubstr("# resumed by host-software 2.1 at "));
}

// Values the command line refuses as it parses them, set by a host: the library refuses them with
// the same option names, before anything is made.
TEST(AcquisitionLibrary, TheValuesAHostSetsAreCheckedBeforeAnythingIsMade) {
  const std::string dir = sph::testing::MakeTempDir("host_checks");
  const std::string log = SimulatedLog(dir);
  const struct {
    std::function<void(AcquisitionOptions&)> edit;
    std::string error;
  } cases[] = {
      {[](AcquisitionOptions& o) { o.iface = "can0"; }, "give either --iface (live) or --replay (a candump log)"},
      {[](AcquisitionOptions& o) { o.heartbeat_timeout_s = -2.0; },
       "--heartbeat-timeout-s: must be -1 (three of the nodes' heartbeat times) or >= 0 and <= 86400 s, got -2"},
      {[](AcquisitionOptions& o) {
         o.replay_path.clear();
         o.iface = "can0";
         o.bitrate_kbit_s = 250;
         o.devices.sync_period_ms = 1;
       },
       "--sync-period-ms 1: 340 bits a SYNC cycle (SYNC and 3 TPDOs) and heartbeats: 136.8 % of a 250 kbit/s bus at "
       "a 1 ms SYNC period: the bus cannot carry it; a SYNC period of at least 1.37 ms can be carried, 2.74 ms or "
       "more keeps the load at half the bus or less"},
      {[](AcquisitionOptions& o) { o.bitrate_kbit_s = 2000; },
       "--bitrate-kbit-s: must be 0 (the interface's) or >= 10 and <= 1000 kbit/s, got 2000"},
      {[](AcquisitionOptions& o) { o.standstill.min_samples = 0; }, "--min-samples: must be >= 1 and <= 1e+08, got 0"},
      {[](AcquisitionOptions& o) { o.standstill.tolerance_deg = 0.0; },
       "--standstill-tol-deg: must be > 0 and <= 360 deg, got 0"},
      {[](AcquisitionOptions& o) { o.fsync_interval_s = -2.0; },
       "--fsync-interval-s: must be -1 (only at the end) or >= 0 and <= 86400 s, got -2"},
      {[](AcquisitionOptions& o) { o.sphere_radius_mm = 0.0; },
       "--sphere-radius-mm: must be > 0 and <= 1000 mm, got 0"},
      {[](AcquisitionOptions& o) {
         o.mount_rotation = MountRotation::Known({0.0, NAN, 0.0});
       },
       "--mount-rotation-deg: the rotation vector must be finite"},
      {[](AcquisitionOptions& o) { o.sdo_timeout_ms = 0.0; }, "--sdo-timeout-ms: must be >= 1 and <= 60000 ms, got 0"},
      {[](AcquisitionOptions& o) { o.node_heartbeat_ms = 70000; },
       "--node-heartbeat-ms: must be >= 0 and <= 65535, got 70000"},
      {[](AcquisitionOptions& o) {
         o.no_nmt = true;
         o.configure_pdo = true;
       },
       "--no-nmt: --configure-pdo needs NMT"},
      {[](AcquisitionOptions& o) { o.devices.theta.node = 128; }, "--theta-node: must be >= 0 and <= 127, got 128"},
      {[](AcquisitionOptions& o) { o.devices.phi.direction = 0; }, "--phi-direction: must be 1 or -1, got 0"},
      {[](AcquisitionOptions& o) { o.devices.probe_status_error_mask = 0; },
       "--probe-status-error-mask: must be >= 1 and <= 255, got 0"},
      {[](AcquisitionOptions& o) { o.devices.sync_period_ms = 0.01; },
       "--sync-period-ms: must be 0 (unknown) or >= 0.1 and <= 60000 ms, got 0.01"},
      {[](AcquisitionOptions& o) { o.devices.sync_counter_max = 241; },
       "--sync-counter-max: must be >= 0 and <= 240, got 241"},
      {[](AcquisitionOptions& o) { o.output_path = o.replay_path; },
       "--output " + log + " is also the input --replay " + log + ": an output never replaces an input"},
  };
  for (const auto& c : cases) {
    AcquisitionOptions o = ReplayOf(log, dir + "/p.txt");
    c.edit(o);
    RunControl control;
    Told told;
    const AcquisitionResult r = ReplayAcquisition(o, control, told.Hooks());
    EXPECT_EQ(r.status, AcquisitionStatus::kBadInput) << c.error;
    EXPECT_THAT(r.error, StartsWith(c.error));
    EXPECT_THAT(told.lines, ::testing::ElementsAre("error: " + r.error));
    EXPECT_FALSE(r.ran);
    EXPECT_FALSE(Exists(dir + "/p.txt")) << c.error;
  }
  // The live call wants an interface, the replay a log.
  RunControl control;
  const AcquisitionResult live = LiveAcquisition(ReplayOf(log, dir + "/p.txt"), control, {});
  EXPECT_EQ(live.status, AcquisitionStatus::kBadInput);
  EXPECT_EQ(live.error, "--replay " + log + ": this is a live acquisition (--iface)");
}

// A stop asked before the replay began ends it before the devices ran: nothing is made; a summary
// asked for is told at once, and again at the end.
TEST(AcquisitionLibrary, RunControlStopsARunAndAsksForItsSummary) {
  const std::string dir = sph::testing::MakeTempDir("host_control");
  const AcquisitionOptions o = ReplayOf(SimulatedLog(dir), dir + "/p.txt");
  RunControl stop;
  stop.stop = 15;
  Told stopped;
  const AcquisitionResult r = ReplayAcquisition(o, stop, stopped.Hooks());
  EXPECT_EQ(r.status, AcquisitionStatus::kOk);
  EXPECT_TRUE(r.ran);
  EXPECT_FALSE(r.acquired);
  EXPECT_THAT(r.warnings, ::testing::ElementsAre("stopped before the devices were started: no points file was made"));
  EXPECT_THAT(stopped.lines, ::testing::Contains("info: stop requested: ending the replay"));
  ASSERT_EQ(stopped.summaries.size(), 1U);
  EXPECT_EQ(SummaryLines(stopped.summaries[0]),
            std::vector<std::string>{"no acquisition: the devices were not started"});
  EXPECT_FALSE(Exists(o.output_path));

  RunControl summary;
  summary.summary = 1;
  Told told;
  EXPECT_EQ(ReplayAcquisition(o, summary, told.Hooks()).status, AcquisitionStatus::kOk);
  ASSERT_EQ(told.summaries.size(), 2U);
  EXPECT_FALSE(told.summaries[0].acquired);  // asked for before the first frame
  EXPECT_EQ(told.summaries[1].rows_written, 8U);
  EXPECT_EQ(summary.summary.load(), 0);
}

TEST(BusSimulationLibrary, TheFaultTextsParseIntoTheSimulatorsTypes) {
  const Silence s = ParseSilence("probe:10:14.5");
  EXPECT_EQ(s.device, kProbe);
  EXPECT_EQ(s.from_s, 10.0);
  EXPECT_EQ(s.to_s, 14.5);
  const EmcyEvent e = ParseEmcy("theta:3:0x8130");
  EXPECT_EQ(e.device, kTheta);
  EXPECT_EQ(e.at_s, 3.0);
  EXPECT_EQ(e.code, 0x8130);
  EXPECT_EQ(ParseEmcy("phi:1:5000").code, 0x5000);
  DeviceOptions devices;
  devices.phi.node = 7;
  const RebootEvent f = ParseFault("settings-lost:phi@2.5", devices);
  EXPECT_EQ(f.node_id, 7);
  EXPECT_EQ(f.at_s, 2.5);
  EXPECT_TRUE(f.settings_lost);
  EXPECT_EQ(ParseFault("reboot:12@1", devices).node_id, 12);
  const struct {
    std::function<void()> parse;
    std::string error;
  } refused[] = {
      {[] { ParseEmcy("theta:1:+8130"); }, "--emcy 'theta:1:+8130': code must be 16-bit hex"},
      {[] { ParseEmcy("theta:1:10000"); }, "--emcy 'theta:1:10000': code must be 16-bit hex"},
      {[] { ParseSilence("probe:nan:3"); }, "--silence 'probe:nan:3': from_s: 'nan' is not a finite number"},
      {[] { ParseSilence("laser:1:2"); }, "--silence: device 'laser' is not theta, phi or probe"},
      {[&] { ParseFault("reboot: 1@1", devices); }, "--fault 'reboot: 1@1': node must be 1..127"},
      {[] { ParseObjectAddress("2000:", "--probe-pdo-object '2000:'"); },
       "--probe-pdo-object '2000:': expected INDEX:SUB in hex, e.g. 0x2000:00"},
      {[] { ParseObjectAddress("0:00", "x"); }, "x: expected INDEX:SUB in hex, e.g. 0x2000:00"},
  };
  for (const auto& c : refused) {
    try {
      c.parse();
      ADD_FAILURE() << "no error: " << c.error;
    } catch (const Error& err) {
      EXPECT_EQ(err.what(), c.error);
    }
  }
  EXPECT_EQ(ParseObjectAddress("1A00:1", "x"), (ObjectAddress{0x1A00, 1}));
}

TEST(BusSimulationLibrary, TheValuesAHostSetsAreCheckedAndAStoppedLogIsRemoved) {
  const std::string dir = sph::testing::MakeTempDir("host_bus");
  const struct {
    std::function<void(BusSimulationOptions&)> edit;
    std::string error;
  } cases[] = {
      {[](BusSimulationOptions& b) { b.iface = "vcan0"; }, "give either --output (a candump log) or --iface (live)"},
      {[](BusSimulationOptions& b) { b.external_sync = true; }, "--sync-source external needs --iface"},
      {[](BusSimulationOptions& b) { b.sim.move_s = -1.0; }, "--move-s: must be >= 0 and <= 3600 s, got -1"},
      {[](BusSimulationOptions& b) { b.sim.heartbeat_period_s = 1e-6; },
       "--heartbeat-period-s: must be 0 (none) or >= 0.001 and <= 65.535 s, got 1e-06"},
      {[](BusSimulationOptions& b) { b.sim.faults.drop_probability = 2.0; },
       "--drop-probability: must be >= 0 and <= 1, got 2"},
      {[](BusSimulationOptions& b) {
         b.sim.faults.silences = {{kProbe, 14.0, 10.0}};
       },
       "--silence probe:14:10: the window must end after it begins (from_s < to_s)"},
      {[](BusSimulationOptions& b) { b.sim.sync_counter_overflow = 1; },
       "--nodes-sync-counter-max: 1 is not allowed (-1, 0 or 2..240)"},
      {[](BusSimulationOptions& b) { b.devices.sync_period_ms = 0.0; },
       "--sync-period-ms: must be >= 0.1 and <= 60000 ms, got 0"},
      {[](BusSimulationOptions& b) {
         b.sim.faults.reboots = {{9, 1.0}};
       },
       "device simulator: reboot of node 9, which no device is"},
  };
  for (const auto& c : cases) {
    BusSimulationOptions b;
    b.output_path = dir + "/x.log";
    c.edit(b);
    RunControl control;
    const BusSimulationResult r = SimulateBusLog(b, control, {});
    EXPECT_EQ(r.status, BusSimulationStatus::kBadInput) << c.error;
    EXPECT_EQ(r.error, c.error);
    EXPECT_FALSE(Exists(b.output_path));
  }
  // A stop cuts the log short: it is removed, the record is not written.
  BusSimulationOptions b;
  b.output_path = dir + "/x.log";
  b.record_path = dir + "/x.rec";
  RunControl control;
  control.stop = 2;
  std::vector<std::string> lines;
  const BusSimulationResult r =
      SimulateBusLog(b, control, {[&](LogLevel, const std::string& text) { lines.push_back(text); }});
  EXPECT_EQ(r.status, BusSimulationStatus::kStopped);
  EXPECT_EQ(r.stopped_by, 2);
  EXPECT_THAT(lines, ::testing::Contains("stopped by signal 2: no log written"));
  EXPECT_FALSE(Exists(b.output_path));
  EXPECT_FALSE(Exists(b.record_path));
}

}  // namespace
}  // namespace sph::can
