// The acquisition's session (what the live loop and the replay both drive, and what a host with
// a CAN driver of its own drives) on a bus of simulated devices in memory: the devices are
// started, identified and restarted after a reboot, their identity reaches the points file, a
// wrong configuration refuses the start, and the replay of the run's frame log gives the same
// points file.
#include "sph/can/acquisition_session.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <map>
#include <sstream>

#include "sim_bus.hpp"
#include "sph/can/acquisition.hpp"
#include "sph/can/candump_log.hpp"
#include "sph/can/device_sim.hpp"
#include "sph/io/points_file.hpp"
#include "test_util.hpp"

namespace sph::can {
namespace {

using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::Pair;

constexpr std::int64_t kMs = 1000000;
constexpr std::int64_t kT0 = 1700000000LL * 1000000000LL;

DeviceSimConfig Devices(const PipelineConfig& devices) {
  DeviceSimConfig sc;
  sc.devices = devices;
  sc.spec.pattern = GridPattern(6, 2);
  sc.stop_s = 0.5;
  sc.move_s = 0.2;
  sc.sync_period_s = 0.01;
  sc.start_time_s = static_cast<double>(kT0) * 1e-9;
  sc.start_operational = false;
  return sc;
}

AcquisitionOptions Options(const std::string& dir) {
  AcquisitionOptions o;
  o.iface = "vcan0";
  o.output_path = dir + "/live.txt";
  o.can_log_path = dir + "/frames.log";
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  o.devices.sync_period_ms = 10.0;
  o.devices.sync_counter_max = 240;
  o.heartbeat_timeout_s = 2.5;
  o.fsync_interval_s = -1;
  return o;
}

// What the daemon prints of a log line ("sph_acquired: error: ...").
AcquisitionSession::Log LogTo(std::ostream& err) {
  return [&err](LogLevel level, const std::string& text) {
    err << "sph_acquired: " << ToString(level) << ": " << text << "\n";
  };
}

// A replay through the library, logging into `err`.
AcquisitionStatus Replay(const AcquisitionOptions& o, std::ostream& err) {
  RunControl control;
  return ReplayAcquisition(o, control, {LogTo(err), nullptr}).status;
}

// A live run in memory: the session on the bus, SYNC produced once the devices run.
struct LiveRun {
  LiveRun(const AcquisitionOptions& o, DeviceSimConfig sc)
      : options(o),
        pipeline(AcquisitionPipelineConfig(o)),
        master(AcquisitionMasterConfig(o, pipeline)),
        sim(sc),
        bus(&sim, kT0) {
    sim.set_recording(true);
    session =
        std::make_unique<AcquisitionSession>(options, pipeline, master, LogTo(err), "CAN interface vcan0", "vcan0");
    session->set_send([this](const CanFrame& f) { bus.Send(f); });
    bus_host = {[this](const CanFrame& f) {
                  session->OnFrame(f);
                  StartSync();
                },
                [this](std::int64_t t) {
                  session->OnTime(t);
                  StartSync();
                },
                [this] { return session->NextDeadline(); }};
    bus.set_host(bus_host);
  }
  void StartSync() {
    if (!syncing && session->acquiring()) {
      syncing = true;
      bus.ProduceSync(bus.now() + 10 * kMs, 10 * kMs, pipeline.sync_counter_max);
    }
  }
  // The daemon begins at `begin_ns` (the bus runs from kT0 on).
  void Run(std::int64_t until, std::int64_t begin_ns = kT0) {
    if (begin_ns > kT0) {
      // Not yet there: the bus runs without the daemon.
      auto host = bus_host;
      bus.set_host({});
      bus.RunUntil(begin_ns);
      bus.set_host(host);
    }
    session->Begin(begin_ns);
    bus.RunUntil(until);
    session->Finish();
  }

  AcquisitionOptions options;
  PipelineConfig pipeline;
  MasterConfig master;
  std::ostringstream err;
  DeviceSimulator sim;
  testing::SimBus bus;
  std::unique_ptr<AcquisitionSession> session;
  testing::SimBus::Host bus_host;
  bool syncing = false;
};

// The frames on the bus, as candump writes them.
void WriteBusLog(const testing::SimBus& bus, const std::string& path) {
  std::ofstream out(path);
  for (const CanFrame& f : bus.log()) out << FormatCandumpLine(f, "vcan0") << "\n";
}

// The lines of a points file but its header's source and start time.
std::vector<std::string> Content(const std::string& path) {
  std::vector<std::string> lines;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("# source: ", 0) == 0 || line.rfind("# started: ", 0) == 0) continue;
    lines.push_back(line);
  }
  return lines;
}

TEST(AcquisitionSession, RebootedNodesAreRestartedAndTheReplayOfTheLogGivesTheSamePointsFile) {
  const std::string dir = sph::testing::MakeTempDir("acq_session");
  AcquisitionOptions o = Options(dir);
  o.nmt_stop_at_exit = true;
  DeviceSimConfig sc = Devices(AcquisitionPipelineConfig(o));
  sc.faults.reboots = {{1, 3.0}, {3, 5.0}};
  sc.faults.drop_probability = 0.01;
  LiveRun live(o, sc);
  live.Run(kT0 + 11000 * kMs);
  ASSERT_EQ(live.session->state(), AcquisitionSession::State::kAcquiring) << live.err.str();
  EXPECT_EQ(live.session->master().counts().restarts, 2U) << live.err.str();
  const PointsData d = ReadPointsFile(o.output_path);
  EXPECT_GT(d.samples.size(), 500U);
  // The identity of each device is in the header.
  EXPECT_THAT(d.header.metadata,
              Contains(Pair("device_theta_encoder", HasSubstr("node 1; name \"sph_cansim theta encoder\"; vendor_id "
                                                              "0x00535048; product_code 0x00004060"))));
  EXPECT_THAT(d.header.metadata, Contains(Pair("device_probe", HasSubstr("serial 0x00010003"))));
  // Each reboot is a gap, opened and closed.
  const std::string text = sph::testing::ReadWholeFile(o.output_path);
  EXPECT_NE(text.find("# gap start t_s 1700000003.0"), std::string::npos) << text.substr(0, 2000);
  EXPECT_NE(text.find(": theta (node 1) rebooted (boot-up message): no theta values until it sends again"),
            std::string::npos);
  EXPECT_NE(text.find(": probe (node 3) sends again"), std::string::npos);
  // Every sample is what the devices sent for its SYNC.
  std::map<std::int64_t, const SimCycleRecord*> by_time;
  for (const SimCycleRecord& r : live.sim.records()) by_time[r.sync_ns] = &r;
  for (const Sample& s : d.samples) {
    const auto t = static_cast<std::int64_t>(std::llround(s.t_s * 1e9));
    auto it = by_time.lower_bound(t - 2000);  // t_s has 6 decimals
    ASSERT_NE(it, by_time.end());
    ASSERT_LT(std::llabs(it->first - t), 2000) << s.t_s;
    EXPECT_NEAR(s.theta_deg, it->second->value[kTheta], 1e-10);
    EXPECT_NEAR(s.phi_deg, it->second->value[kPhi], 1e-10);
    EXPECT_NEAR(s.r_mm, it->second->value[kProbe], 1e-10);
  }
  // The replay of the frame log: the same file.
  AcquisitionOptions r = Options(dir);
  r.iface.clear();
  r.replay_path = o.can_log_path;
  r.can_log_path.clear();
  r.output_path = dir + "/replay.txt";
  std::ostringstream err;
  const AcquisitionStatus status = Replay(r, err);
  EXPECT_EQ(status, live.session->Losses() > 0 ? AcquisitionStatus::kSamplesLost : AcquisitionStatus::kOk) << err.str();
  const auto a = Content(o.output_path), b = Content(r.output_path);
  ASSERT_EQ(a.size(), b.size()) << err.str();
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i], b[i]) << "line " << i;
}

TEST(AcquisitionSession, AWrongCountsPerRevolutionRefusesTheStartAndMakesNoFile) {
  const std::string dir = sph::testing::MakeTempDir("acq_refused");
  AcquisitionOptions o = Options(dir);
  DeviceSimConfig sc = Devices(AcquisitionPipelineConfig(o));
  o.devices.theta.counts_per_rev = 8192;  // the daemon's config; the device has 2^24
  LiveRun live(o, sc);
  live.Run(kT0 + 3000 * kMs);
  EXPECT_EQ(live.session->state(), AcquisitionSession::State::kStartRefused);
  EXPECT_THAT(live.err.str(), HasSubstr("sph_acquired: error: node 1 (theta): object 0x6001:00 (measuring units per "
                                        "revolution): the device has 16777216, --theta-counts-per-rev 8192\n"));
  EXPECT_EQ(::access(o.output_path.c_str(), F_OK), -1);
  EXPECT_EQ(::access(o.can_log_path.c_str(), F_OK), -1);
  // The same start, replayed from a recording of the bus: refused alike.
  const std::string log = dir + "/bus.log";
  WriteBusLog(live.bus, log);
  AcquisitionOptions r = o;
  r.iface.clear();
  r.replay_path = log;
  r.can_log_path.clear();
  std::ostringstream err;
  EXPECT_EQ(Replay(r, err), AcquisitionStatus::kStartRefused);
  EXPECT_THAT(err.str(), HasSubstr("object 0x6001:00 (measuring units per revolution): the device has 16777216, "
                                   "--theta-counts-per-rev 8192"));
  EXPECT_EQ(::access(o.output_path.c_str(), F_OK), -1);
}

// candump began 2 s before the daemon: its log holds boot-ups and heartbeats the daemon never
// saw. Replayed, they are left out and the points file is the daemon's.
TEST(AcquisitionSession, TheReplayOfABusLogBegunBeforeTheDaemonLeavesOutWhatItNeverSaw) {
  const std::string dir = sph::testing::MakeTempDir("acq_buslog");
  AcquisitionOptions o = Options(dir);
  LiveRun live(o, Devices(AcquisitionPipelineConfig(o)));
  live.Run(kT0 + 6000 * kMs, kT0 + 2000 * kMs);
  ASSERT_EQ(live.session->state(), AcquisitionSession::State::kAcquiring) << live.err.str();
  WriteBusLog(live.bus, dir + "/bus.log");
  AcquisitionOptions r = Options(dir);
  r.iface.clear();
  r.replay_path = dir + "/bus.log";
  r.can_log_path.clear();
  r.output_path = dir + "/replay.txt";
  std::ostringstream err;
  Replay(r, err);
  EXPECT_THAT(err.str(), HasSubstr("frames before the daemon's first request are left out"));
  EXPECT_EQ(Content(o.output_path), Content(r.output_path)) << err.str();
}

TEST(AcquisitionSession, OptionsForTheMaster) {
  AcquisitionOptions o;
  o.devices.theta.tpdo = 2;
  o.probe_pdo_object = ParseObjectAddress("0x2000:00", "--probe-pdo-object");
  const MasterConfig m = AcquisitionMasterConfig(o, AcquisitionPipelineConfig(o));
  ASSERT_EQ(m.nodes.size(), 3U);
  EXPECT_EQ(m.nodes[0].devices[0].tpdo, 2);
  EXPECT_EQ(m.nodes[0].devices[0].cpr_name, "--theta-counts-per-rev");
  ASSERT_TRUE(m.nodes[2].devices[0].mapped_object.has_value());
  EXPECT_EQ(*m.nodes[2].devices[0].mapped_object, (ObjectAddress{0x2000, 0}));
  EXPECT_EQ(m.sync_counter_max, 0);  // every node's 1019h is checked against the SYNC's
  EXPECT_EQ(m.heartbeat_ms, 100);
  o.devices.sync_counter_max = 240;
  o.node_heartbeat_ms = 250;
  const MasterConfig counted = AcquisitionMasterConfig(o, AcquisitionPipelineConfig(o));
  EXPECT_EQ(counted.sync_counter_max, 240);
  EXPECT_EQ(counted.sync_counter_name, "--sync-counter-max");
  EXPECT_EQ(counted.heartbeat_ms, 250);
  EXPECT_THROW(ParseObjectAddress("2000", "--probe-pdo-object"), Error);
  o.probe_pdo_object.reset();
  o.no_nmt = true;
  o.configure_pdo = true;
  EXPECT_THROW(AcquisitionMasterConfig(o, AcquisitionPipelineConfig(o)), Error);
  o.configure_pdo = false;
  o.nmt_stop_at_exit = true;
  try {
    AcquisitionMasterConfig(o, AcquisitionPipelineConfig(o));
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "--no-nmt: --nmt-stop-at-exit needs NMT");
  }
}

}  // namespace
}  // namespace sph::can
