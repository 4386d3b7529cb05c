// The acquisition's session (what the live loop and the replay both drive, and what a host with
// a CAN driver of its own drives) on a bus of simulated devices in memory: the devices are
// started, identified and restarted after a reboot, their identity reaches the points file, a
// wrong configuration refuses the start, and the replay of the run's frame log gives the same
// points file.
#include "sph/can/acquisition_session.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cctype>
#include <cstring>
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

// The rows and comments of a points file: each comment that names its time ("# EMCY t_s T: ...")
// lies between the rows before and after it.
void ExpectCommentsAtTheirPlace(const std::string& path) {
  std::ifstream in(path);
  double last_row = 0.0;
  std::vector<std::pair<double, std::string>> waiting;  // comments not yet followed by a row
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) continue;
    if (line[0] != '#') {
      std::istringstream row(line);
      double theta = 0, phi = 0, r = 0, t = 0;
      row >> theta >> phi >> r >> t;
      for (const auto& [when, text] : waiting) EXPECT_LE(when, t + 1e-6) << text << " before the row of " << line;
      waiting.clear();
      last_row = t;
      continue;
    }
    const auto at = line.find(" t_s ");
    if (at == std::string::npos || at > 40 || !std::isdigit(static_cast<unsigned char>(line[at + 5]))) continue;
    const double when = std::stod(line.substr(at + 5));
    EXPECT_GE(when, last_row - 1e-6) << line << " after the row of t_s " << last_row;
    waiting.emplace_back(when, line);
  }
}

// Nodes that leave operational mid-run without a reboot: one by itself (pre-operational), one by
// its error behaviour (EMCY 0x8100, error register set, pre-operational; NMT Start holds only after
// the error reset 1 s later), one by another master's NMT command. Each is started again; the
// points file says what happened where, its rows are what the devices sent, and an EMCY that sets
// a node's error register flags the rows that follow. The replay of the frame log gives the same
// file.
TEST(AcquisitionSession, NodesThatLeaveOperationalAreStartedAgainAndTheFileSaysWhatHappened) {
  const std::string dir = sph::testing::MakeTempDir("acq_left");
  AcquisitionOptions o = Options(dir);
  DeviceSimConfig sc = Devices(AcquisitionPipelineConfig(o));
  sc.spec.pattern = GridPattern(8, 2);  // 16 stops of 0.7 s
  sc.heartbeat_period_s = 0.2;
  sc.faults.reboots = {{3, 3.0, false, NodeFaultKind::kPreOperational}, {2, 5.0, false, NodeFaultKind::kError, 1.0}};
  sc.faults.emergencies = {{kTheta, 8.0, 0x4210}};  // temperature: register set, no reset
  LiveRun live(o, sc);
  live.session->Begin(kT0);
  live.bus.RunUntil(kT0 + 9000 * kMs);
  live.bus.Send(EncodeNmt(NmtCommand::kEnterPreOperational, 1));  // another master
  live.bus.RunUntil(kT0 + 11000 * kMs);
  live.session->Finish();
  ASSERT_EQ(live.session->state(), AcquisitionSession::State::kAcquiring) << live.err.str();
  const CanopenMaster::Counts& m = live.session->master().counts();
  EXPECT_EQ(m.left_operational, 3U) << live.err.str();
  EXPECT_EQ(m.restarts, 3U);
  EXPECT_GE(m.start_retries, 1U);  // the node in error: Start did not hold before its reset
  for (int node = 1; node <= 3; ++node) EXPECT_EQ(live.sim.NodeState(node), 0x05) << node;
  const std::string text = sph::testing::ReadWholeFile(o.output_path);
  for (const char* expected :
       {"# node state t_s 1700000003.0", ": node 3 (probe): pre-operational (was operational)\n",
        ": probe (node 3) left operational (pre-operational): no probe values until it sends again\n",
        ": probe (node 3) sends again, ", " s after it left operational (",
        ": phi node 2: EMCY 0x8100 (monitoring), error register 0x11",
        ": node 2 (phi) signals an error (error register 0x11)",
        ": node 2 (phi): error reset (EMCY 0x0000) after 1.000 s; 0 rows written in the error state\n",
        ": node 1 (theta): pre-operational (was operational)\n",
        "# the error state of node 1 (theta), since t_s 1700000008.0"}) {
    EXPECT_NE(text.find(expected), std::string::npos) << expected << "\n" << live.err.str();
  }
  const PointsData d = ReadPointsFile(o.output_path);
  EXPECT_GT(d.samples.size(), 800U);
  ExpectCommentsAtTheirPlace(o.output_path);
  std::map<std::int64_t, const SimCycleRecord*> by_time;
  for (const SimCycleRecord& r : live.sim.records()) by_time[r.sync_ns] = &r;
  for (const Sample& s : d.samples) {
    const auto t = static_cast<std::int64_t>(std::llround(s.t_s * 1e9));
    auto it = by_time.lower_bound(t - 2000);
    ASSERT_NE(it, by_time.end());
    ASSERT_LT(std::llabs(it->first - t), 2000) << s.t_s;
    EXPECT_NEAR(s.theta_deg, it->second->value[kTheta], 1e-10);
    EXPECT_NEAR(s.phi_deg, it->second->value[kPhi], 1e-10);
    EXPECT_NEAR(s.r_mm, it->second->value[kProbe], 1e-10);
  }
  AcquisitionOptions r = Options(dir);
  r.iface.clear();
  r.replay_path = o.can_log_path;
  r.can_log_path.clear();
  r.output_path = dir + "/replay.txt";
  std::ostringstream err;
  Replay(r, err);
  EXPECT_EQ(Content(o.output_path), Content(r.output_path)) << err.str();
}

// A node that does not come back within --node-return-timeout-s ends the run: the file is
// finished cleanly and says why; the replay of the frame log ends alike (status kNodeLost).
TEST(AcquisitionSession, ANodeThatDoesNotComeBackEndsTheRunCleanly) {
  const std::string dir = sph::testing::MakeTempDir("acq_lost");
  AcquisitionOptions o = Options(dir);
  o.node_return_timeout_s = 2.0;
  o.devices.sync_counter_max = 0;  // its 1019h back at 0 fits: it passes the checks, and stays pre-operational
  DeviceSimConfig sc = Devices(AcquisitionPipelineConfig(o));
  sc.heartbeat_period_s = 0.2;
  sc.faults.reboots = {{2, 2.0, true}};  // back without its settings: cannot be started
  LiveRun live(o, sc);
  live.Run(kT0 + 8000 * kMs);
  ASSERT_EQ(live.session->state(), AcquisitionSession::State::kNodeLost) << live.err.str();
  EXPECT_THAT(live.session->error(), HasSubstr("node 2 (phi) was not restarted after its reboot: no heartbeat saying "
                                               "operational within 2.0 s (Start remote node sent "));
  const auto lines = Content(o.output_path);
  ASSERT_FALSE(lines.empty());
  const auto end = std::find_if(lines.begin(), lines.end(), [](const std::string& l) {
    return l.find(": the acquisition ends") != std::string::npos;
  });
  ASSERT_NE(end, lines.end());
  for (auto it = end + 1; it != lines.end(); ++it) EXPECT_EQ((*it)[0], '#') << *it;  // no row after it
  AcquisitionOptions r = Options(dir);
  r.iface.clear();
  r.replay_path = o.can_log_path;
  r.can_log_path.clear();
  r.output_path = dir + "/replay.txt";
  r.node_return_timeout_s = 2.0;
  r.devices.sync_counter_max = 0;
  std::ostringstream err;
  EXPECT_EQ(Replay(r, err), AcquisitionStatus::kNodeLost) << err.str();
  EXPECT_EQ(Content(o.output_path), Content(r.output_path)) << err.str();
}

// With --no-sdo a node that is not there is started without a word: it is named in the file and
// in the summary.
TEST(AcquisitionSession, WithoutSdoANodeNeverHeardFromIsNamed) {
  const std::string dir = sph::testing::MakeTempDir("acq_silent");
  AcquisitionOptions o = Options(dir);
  o.no_sdo = true;
  DeviceSimConfig sc = Devices(AcquisitionPipelineConfig(o));
  sc.faults.silences = {{kProbe, 0.0, 100.0}};
  LiveRun live(o, sc);
  live.Run(kT0 + 4000 * kMs, kT0 + 500 * kMs);  // the boot-ups before the daemon began
  ASSERT_EQ(live.session->state(), AcquisitionSession::State::kAcquiring) << live.err.str();
  const AcquisitionResult result = live.session->Result();
  EXPECT_THAT(result.never_heard, ::testing::ElementsAre("node 3 (probe)"));
  EXPECT_THAT(SummaryLines(result)[0], HasSubstr("\nnever heard from: node 3 (probe)"));
  const std::string text = sph::testing::ReadWholeFile(o.output_path);
  EXPECT_NE(text.find("# node 3 (probe) has not been heard from since the start (no heartbeat, EMCY, SDO answer or "
                      "PDO): started without a word from it\n"),
            std::string::npos)
      << text.substr(0, 3000);
  EXPECT_NE(text.find("# node 3 (probe) was never heard from during the run (no frame of it at all)\n"),
            std::string::npos);
}

// A probe whose TPDO maps a REAL32 value (its reading in mm): the master checks the mapping and
// reads the value over SDO (4 bytes), each row's r_mm is the single in the probe's frame at its
// SYNC (decoded here by hand); a data type whose size the object does not have refuses the start.
TEST(AcquisitionSession, AReal32ProbeIsAcquiredByItsDataType) {
  const std::string dir = sph::testing::MakeTempDir("acq_real32");
  AcquisitionOptions o = Options(dir);
  o.devices.probe_data_type = "real32";
  o.devices.probe_scale_um_per_count = 1000.0;
  o.probe_pdo_object = ObjectAddress{0x2000, 0};
  LiveRun live(o, Devices(AcquisitionPipelineConfig(o)));
  live.Run(kT0 + 3000 * kMs);
  ASSERT_EQ(live.session->state(), AcquisitionSession::State::kAcquiring) << live.err.str();
  EXPECT_THAT(live.bus.log(), Contains(::testing::Truly([](const CanFrame& f) {
                return ToString(f).rfind("583#43002000", 0) == 0;
              })));                    // 0x2000:00 uploaded: 4 bytes (expedited, size indicated)
  std::map<std::int64_t, float> sent;  // the probe's single after each SYNC
  std::int64_t last_sync = 0;
  for (const CanFrame& f : live.bus.log()) {
    if (f.id == 0x80) last_sync = f.t_ns;
    if (f.id != 0x183 || f.len < 4) continue;
    float mm = 0.0F;
    std::memcpy(&mm, f.data.data(), sizeof mm);
    sent[last_sync] = mm;
  }
  const PointsData d = ReadPointsFile(o.output_path);
  ASSERT_GT(d.samples.size(), 150U);
  for (const Sample& s : d.samples) {
    const auto t = static_cast<std::int64_t>(std::llround(s.t_s * 1e9));
    const auto it = sent.lower_bound(t - 2000);
    ASSERT_NE(it, sent.end());
    EXPECT_NEAR(s.r_mm, static_cast<double>(it->second), 0.5e-10) << s.t_s;  // the single, to the 10 decimals written
  }
  AcquisitionOptions wrong = Options(sph::testing::MakeTempDir("acq_real32_wrong"));
  wrong.devices.probe_data_type = "integer16";
  wrong.probe_pdo_object = ObjectAddress{0x2000, 0};
  DeviceSimConfig sc = Devices(AcquisitionPipelineConfig(o));  // the device as before: REAL32
  LiveRun refused(wrong, sc);
  refused.Run(kT0 + 3000 * kMs);
  EXPECT_EQ(refused.session->state(), AcquisitionSession::State::kStartRefused);
  EXPECT_THAT(refused.err.str(), HasSubstr("node 3 (probe): object 0x2000:00 (the mapped value) holds 4 bytes, "
                                           "--probe-data-type integer16 has 2"));
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
