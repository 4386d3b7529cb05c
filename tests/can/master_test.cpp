// The CANopen master: against hand-written frames (what a device answers, byte by byte), and
// against the simulated devices on a bus in memory (boot, identification, checks, start,
// configuration, a reboot mid-run).
#include "sph/can/master.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <map>

#include "sim_bus.hpp"
#include "sph/can/device_sim.hpp"
#include "sph/can/sdo.hpp"
#include "sph/core/error.hpp"

namespace sph::can {
namespace {

using ::testing::Contains;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::Pair;

constexpr std::int64_t kMs = 1000000;
constexpr std::int64_t kT0 = 1700000000LL * 1000000000LL;

// A master on a bus of simulated devices.
struct Rig {
  explicit Rig(DeviceSimConfig sc, MasterConfig mc = {}) : sim(Prepare(sc)), bus(&sim, kT0) {
    if (mc.nodes.empty()) mc.nodes = MasterNodesFor(sc.devices);
    master = std::make_unique<CanopenMaster>(
        mc, CanopenMaster::Callbacks{[this](const CanFrame& f) { bus.Send(f); },
                                     [this](LogLevel, const std::string& l) { logs.push_back(l); },
                                     [this](const std::string& n) { notes.push_back(n); }});
    bus.set_host({[this](const CanFrame& f) { master->OnFrame(f); }, [this](std::int64_t t) { master->OnTime(t); },
                  [this] { return master->NextDeadline(); }});
  }
  static DeviceSimConfig Prepare(DeviceSimConfig sc) {
    sc.spec.pattern = GridPattern(4, 2);
    sc.start_time_s = static_cast<double>(kT0) * 1e-9;
    sc.sync_period_s = 0.01;
    return sc;
  }
  // Frames on the bus as can-utils writes them ("601#4018100100000000").
  std::vector<std::string> Frames() const {
    std::vector<std::string> out;
    for (const CanFrame& f : bus.log()) out.push_back(ToString(f));
    return out;
  }
  std::size_t IndexOf(const std::string& frame) const {
    const auto f = Frames();
    return static_cast<std::size_t>(std::find(f.begin(), f.end(), frame) - f.begin());
  }

  DeviceSimulator sim;
  testing::SimBus bus;
  std::unique_ptr<CanopenMaster> master;
  std::vector<std::string> logs, notes;
};

DeviceSimConfig Booting() {
  DeviceSimConfig sc;
  sc.start_operational = false;
  return sc;
}

TEST(Master, IdentifiesChecksAndStartsPreOperationalNodes) {
  Rig r(Booting());
  r.bus.ProduceSync(kT0 + 10 * kMs, 10 * kMs);  // a SYNC producer from the start
  r.master->Begin(kT0);
  r.bus.RunUntil(kT0 + 3000 * kMs);
  ASSERT_EQ(r.master->phase(), CanopenMaster::Phase::kRunning) << ::testing::PrintToString(r.master->errors());
  for (int node = 1; node <= 3; ++node) EXPECT_EQ(r.sim.NodeState(node), 0x05) << node;
  const auto frames = r.Frames();
  // The first request: an upload of 0x1018:01 from node 1; each node started by its own command.
  EXPECT_THAT(frames, Contains("601#4018100100000000"));
  EXPECT_THAT(frames, Contains("581#4318100148505300"));  // vendor-id 0x00535048
  EXPECT_THAT(frames, Contains("000#0101"));
  EXPECT_THAT(frames, Contains("000#0102"));
  EXPECT_THAT(frames, Contains("000#0103"));
  // The devices stay silent (no PDO) until their start, though SYNCs come from the beginning.
  const std::size_t start = std::min({r.IndexOf("000#0101"), r.IndexOf("000#0102"), r.IndexOf("000#0103")});
  for (std::size_t i = 0; i < start; ++i) {
    const std::uint32_t id = r.bus.log()[i].id;
    EXPECT_TRUE(id != 0x181 && id != 0x182 && id != 0x183) << frames[i] << " before the start";
  }
  std::size_t pdos_after = 0;
  for (std::size_t i = start; i < frames.size(); ++i) pdos_after += r.bus.log()[i].id == 0x181;
  EXPECT_GT(pdos_after, 100U);
  // Identity and resolution go into the header fields.
  const auto fields = r.master->HeaderFields();
  ASSERT_EQ(fields.size(), 3U);
  EXPECT_EQ(fields[0].first, "device_theta_encoder");
  EXPECT_EQ(fields[0].second,
            "node 1; name \"sph_cansim theta encoder\"; vendor_id 0x00535048; product_code 0x00004060; revision "
            "0x00010000; serial 0x00010001; measuring_units_per_revolution 16777216; total_measuring_range 16777216; "
            "tpdo 1 cob_id 0x181");
  EXPECT_THAT(fields[2].second, HasSubstr("name \"sph_cansim probe\""));
  EXPECT_EQ(r.master->counts().restarts, 0U);
}

TEST(Master, AWrongCountsPerRevolutionRefusesTheStartAndStartsNoNode) {
  DeviceSimConfig sc = Booting();
  MasterConfig mc;
  mc.nodes = MasterNodesFor(sc.devices);
  mc.nodes[0].devices[0].counts_per_rev = 8192;
  mc.nodes[0].devices[0].cpr_name = "--theta-counts-per-rev";
  Rig r(sc, mc);
  r.master->Begin(kT0);
  r.bus.RunUntil(kT0 + 3000 * kMs);
  ASSERT_EQ(r.master->phase(), CanopenMaster::Phase::kFailed);
  ASSERT_EQ(r.master->errors().size(), 1U);
  EXPECT_EQ(r.master->errors()[0],
            "node 1 (theta): object 0x6001:00 (measuring units per revolution): the device has 16777216, "
            "--theta-counts-per-rev 8192");
  for (int node = 1; node <= 3; ++node) EXPECT_EQ(r.sim.NodeState(node), 0x7F) << node;  // pre-operational
  for (const std::string& f : r.Frames()) EXPECT_NE(f.rfind("000#01", 0), 0U) << f;
}

TEST(Master, ATrustedConfigurationWarnsAndStarts) {
  DeviceSimConfig sc = Booting();
  MasterConfig mc;
  mc.trust_config = true;
  mc.nodes = MasterNodesFor(sc.devices);
  mc.nodes[1].devices[0].counts_per_rev = 4096;
  Rig r(sc, mc);
  r.master->Begin(kT0);
  r.bus.RunUntil(kT0 + 3000 * kMs);
  EXPECT_EQ(r.master->phase(), CanopenMaster::Phase::kRunning);
  EXPECT_THAT(r.logs, Contains(HasSubstr("node 2 (phi): object 0x6001:00 (measuring units per revolution): the device "
                                         "has 16777216, the configured counts per revolution 4096 (trusted")));
}

TEST(Master, AnEventDrivenPdoIsRefusedOrConfigured) {
  DeviceSimConfig sc = Booting();
  sc.transmission_type = 254;
  {
    Rig r(sc);
    r.master->Begin(kT0);
    r.bus.RunUntil(kT0 + 3000 * kMs);
    ASSERT_EQ(r.master->phase(), CanopenMaster::Phase::kFailed);
    EXPECT_EQ(r.master->errors().size(), 3U);
    EXPECT_THAT(r.master->errors()[0],
                HasSubstr("node 1 (theta): object 0x1800:02 (TPDO1 transmission type): the device has 254 "
                          "(event-driven, manufacturer-specific), the daemon needs 1 (synchronous, every SYNC)"));
  }
  MasterConfig mc;
  mc.configure_pdo = true;
  mc.nodes = MasterNodesFor(sc.devices);
  Rig r(sc, mc);
  r.master->Begin(kT0);
  r.bus.RunUntil(kT0 + 3000 * kMs);
  ASSERT_EQ(r.master->phase(), CanopenMaster::Phase::kRunning) << ::testing::PrintToString(r.master->errors());
  // CiA 301's sequence for TPDO1 of node 1: invalid, transmission type, mapping off, entry, on, valid.
  const std::vector<std::string> writes{"601#2300180181010080", "601#2F00180201000000", "601#2F001A0000000000",
                                        "601#23001A0120000460", "601#2F001A0001000000", "601#2300180181010000"};
  std::size_t last = 0;
  for (const std::string& w : writes) {
    const std::size_t i = r.IndexOf(w);
    ASSERT_LT(i, r.Frames().size()) << w;
    EXPECT_GT(i, last) << w;
    last = i;
    const std::string answer = "581#60" + w.substr(6, 6) + "00000000";  // the device confirms each write
    EXPECT_THAT(r.Frames(), Contains(answer)) << w;
  }
  EXPECT_THAT(r.Frames(), Contains("000#8001"));  // pre-operational before writing
}

TEST(Master, PdoWritesWhileOperationalAreRefusedByTheDevice) {
  DeviceSimConfig sc;  // operational from the start, as after another master
  Rig r(sc);
  r.bus.Send(EncodeDownloadRequest(1, {0x1800, 2}, {1}));
  r.bus.RunUntil(kT0 + 10 * kMs);
  EXPECT_THAT(r.Frames(), Contains("581#8000180222000008"));  // 0x08000022: the present device state
  MasterConfig mc;
  mc.configure_pdo = true;
  mc.nodes = MasterNodesFor(sc.devices);
  Rig q(sc, mc);  // the master brings them to pre-operational first
  q.master->Begin(kT0);
  q.bus.RunUntil(kT0 + 3000 * kMs);
  EXPECT_EQ(q.master->phase(), CanopenMaster::Phase::kRunning) << ::testing::PrintToString(q.master->errors());
}

TEST(Master, ANodeThatDoesNotAnswerFailsTheStartInTime) {
  DeviceSimConfig sc = Booting();
  MasterConfig mc;
  mc.nodes = MasterNodesFor(sc.devices);
  mc.nodes[2].node_id = 9;  // nobody is node 9
  mc.nodes[2].name = "probe";
  Rig r(sc, mc);
  r.master->Begin(kT0);
  r.bus.RunUntil(kT0 + 499 * kMs);
  EXPECT_EQ(r.master->phase(), CanopenMaster::Phase::kStarting);
  r.bus.RunUntil(kT0 + 600 * kMs);
  ASSERT_EQ(r.master->phase(), CanopenMaster::Phase::kFailed);
  EXPECT_THAT(r.master->errors(),
              Contains("node 9 (probe): reading 0x1018:01 (identity: vendor-id): no answer within 500 ms (sent abort "
                       "0x05040000 (SDO protocol timed out))"));
  EXPECT_THAT(r.Frames(), Contains("609#8018100100000405"));
}

TEST(Master, ResetCommunicationWaitsForTheBootUps) {
  DeviceSimConfig sc;
  MasterConfig mc;
  mc.reset_communication = true;
  mc.nmt_broadcast = true;
  mc.nodes = MasterNodesFor(sc.devices);
  Rig r(sc, mc);
  r.master->Begin(kT0);
  r.bus.RunUntil(kT0 + 3000 * kMs);
  ASSERT_EQ(r.master->phase(), CanopenMaster::Phase::kRunning);
  const auto f = r.Frames();
  ASSERT_FALSE(f.empty());
  EXPECT_EQ(f[0], "000#8200");
  EXPECT_LT(r.IndexOf("701#00"), r.IndexOf("601#4018100100000000"));
  EXPECT_EQ(std::count(f.begin(), f.end(), "000#0100"), 1);  // one broadcast start
  mc.nodes[0].node_id = 7;
  Rig q(sc, mc);
  q.master->Begin(kT0);
  q.bus.RunUntil(kT0 + 6000 * kMs);
  ASSERT_EQ(q.master->phase(), CanopenMaster::Phase::kFailed);
  EXPECT_THAT(q.master->errors(),
              Contains("node 7 (theta): no boot-up message within 5.0 s after Reset communication"));
}

TEST(Master, ANodeThatRebootsMidRunIsRestarted) {
  DeviceSimConfig sc = Booting();
  sc.faults.reboots = {{2, 2.0}};
  Rig r(sc);
  r.bus.ProduceSync(kT0 + 10 * kMs, 10 * kMs);
  r.master->Begin(kT0);
  r.bus.RunUntil(kT0 + 1900 * kMs);
  ASSERT_EQ(r.master->phase(), CanopenMaster::Phase::kRunning);
  const std::size_t before = r.Frames().size();
  r.bus.RunUntil(kT0 + 4000 * kMs);
  EXPECT_EQ(r.sim.NodeState(2), 0x05);
  EXPECT_EQ(r.master->counts().boot_ups, 1U);
  EXPECT_EQ(r.master->counts().restarts, 1U);
  const auto f = r.Frames();
  const auto boot = std::find(f.begin() + static_cast<std::ptrdiff_t>(before), f.end(), "702#00");
  ASSERT_NE(boot, f.end());
  const auto ident = std::find(boot, f.end(), "602#4018100100000000");  // identified again
  const auto start = std::find(ident, f.end(), "000#0102");
  EXPECT_NE(start, f.end());
  EXPECT_THAT(r.logs, Contains("node 2 (phi): boot-up message: the node rebooted; restarting it"));
  EXPECT_THAT(r.logs, Contains("node 2 (phi): restarted, operational again"));
}

// One encoder node whose answers are written out by hand, byte by byte: to each request of the
// master the device's answer (an abort "no such object" to any other request), and the
// heartbeats the test sends.
struct ScriptedNode {
  explicit ScriptedNode(MasterConfig mc)
      : master(std::move(mc), {[this](const CanFrame& f) { sent.push_back(ToString(f)); },
                               [this](LogLevel, const std::string& l) { logs.push_back(l); },
                               [this](const std::string& n) { notes.push_back(n); }}) {}
  static MasterConfig OneEncoder() {
    PipelineConfig pc;
    pc.phi.node_id = 0;
    pc.probe.node_id = 0;
    MasterConfig mc;
    mc.nodes = MasterNodesFor(pc);
    return mc;
  }
  // Answers the master's requests, each 1 ms after the one before, until it asks nothing more.
  void Answer() {
    while (answered < sent.size()) {
      const std::string request = sent[answered++];
      if (request.rfind("601#", 0) != 0) continue;  // NMT
      const auto it = answers.find(request.substr(4));
      std::string reply = it != answers.end() ? it->second : "80" + request.substr(6, 6) + "00000206";
      if (request.substr(4, 1) == "2" && reply.rfind("60", 0) == 0) {  // a write taken: read back as written
        const int bytes = 4 - ((std::stoi(request.substr(5, 1), nullptr, 16) >> 2) & 3);
        char command[3];
        std::snprintf(command, sizeof command, "%02X", 0x43 | ((4 - bytes) << 2));
        answers["40" + request.substr(6, 6) + "00000000"] = command + request.substr(6);
      }
      CanFrame f = MakeFrame(0x581, {}, t += kMs);
      f.len = 8;
      for (int i = 0; i < 8; ++i)
        f.data[static_cast<std::size_t>(i)] =
            static_cast<std::uint8_t>(std::stoi(reply.substr(static_cast<std::size_t>(2 * i), 2), nullptr, 16));
      master.OnFrame(f);
    }
  }
  void Heartbeat(std::uint8_t state) { master.OnFrame(MakeFrame(0x701, {state}, t += kMs)); }
  void Time(std::int64_t dt) { master.OnTime(t += dt); }

  // The device: identity, no name, 6001h and 6002h 2^24, TPDO1 on 0x181, synchronous, 0x6004:00.
  std::map<std::string, std::string> answers{
      {"4018100100000000", "4318100148505300"}, {"4018100200000000", "4318100260400000"},
      {"4018100400000000", "4318100401000100"}, {"4001600000000000", "4301600000000001"},
      {"4002600000000000", "4302600000000001"}, {"4000180100000000", "4300180181010000"},
      {"4000180200000000", "4F00180201000000"}, {"40001A0000000000", "4F001A0001000000"},
      {"40001A0100000000", "43001A0120000460"}, {"4017100000000000", "4B171000C8000000"}};
  CanopenMaster master;
  std::vector<std::string> sent, logs, notes;
  std::size_t answered = 0;
  std::int64_t t = kT0;
};

// The start and a reboot of one node, and a device with another serial number where the
// rebooted one was.
TEST(Master, ScriptedNodeAndADeviceThatCameBackAsAnother) {
  ScriptedNode d(ScriptedNode::OneEncoder());
  d.answers["4017100000000000"] = "4B171000F4010000";  // heartbeat 500 ms
  d.master.Begin(d.t);
  d.Answer();
  const std::vector<std::string> expected{"601#4018100100000000", "601#4018100200000000",
                                          "601#4018100300000000", "601#4018100400000000",
                                          "601#4008100000000000", "601#4017100000000000",
                                          "601#4019100000000000", "601#4001600000000000",
                                          "601#4002600000000000", "601#4000180100000000",
                                          "601#4000180200000000", "601#40001A0000000000",
                                          "601#40001A0100000000", "000#0101"};
  EXPECT_EQ(d.sent, expected);
  EXPECT_EQ(d.master.phase(), CanopenMaster::Phase::kStarting);  // until its heartbeat says operational
  d.Heartbeat(0x05);
  EXPECT_EQ(d.master.phase(), CanopenMaster::Phase::kRunning);
  EXPECT_THAT(d.logs, Contains("every node is operational (each heartbeat says so)"));
  EXPECT_EQ(d.master.HeaderFields()[0].second,
            "node 1; vendor_id 0x00535048; product_code 0x00004060; serial 0x00010001; "
            "measuring_units_per_revolution 16777216; total_measuring_range 16777216; tpdo 1 cob_id 0x181");
  d.Heartbeat(0x00);  // boot-up: rebooted
  EXPECT_EQ(d.master.counts().boot_ups, 1U);
  d.answers["4018100400000000"] = "4318100402000100";  // another serial
  d.Answer();
  EXPECT_EQ(d.master.counts().restart_failures, 1U);
  EXPECT_EQ(d.sent.back(), "601#40001A0100000000");  // not started again
  ASSERT_EQ(d.notes.size(), 1U);
  EXPECT_THAT(d.notes[0],
              HasSubstr("node 1 (theta) was not restarted after its reboot: it came back as another device"));
  EXPECT_THAT(d.notes[0], HasSubstr("serial 0x00010002 (at the start: 0x00535048, 0x00004060, 0x00010001)"));
}

// A node whose 1017h is 0 sends no heartbeat, so nothing would tell that it is operational: the
// master writes its heartbeat time into it (and reads it back) and calls it operational only when
// a heartbeat says so.
TEST(Master, ANodeWithoutHeartbeatIsGivenOneAndStartedOnlyWhenItSaysOperational) {
  ScriptedNode d(ScriptedNode::OneEncoder());
  d.answers["4017100000000000"] = "4B17100000000000";  // 0 ms
  d.answers["2B17100064000000"] = "6017100000000000";  // the write of 100 ms is taken
  d.master.Begin(d.t);
  d.Answer();
  ASSERT_GE(d.sent.size(), 8U);
  EXPECT_EQ(d.sent[5], "601#4017100000000000");
  EXPECT_EQ(d.sent[6], "601#2B17100064000000");
  EXPECT_EQ(d.sent[7], "601#4017100000000000");  // read back: 100 ms
  EXPECT_EQ(d.sent.back(), "000#0101");
  EXPECT_THAT(d.logs, Not(Contains(HasSubstr("operational"))));
  d.Heartbeat(0x7F);  // still pre-operational: not enough
  d.Time(700 * kMs);
  EXPECT_EQ(d.master.phase(), CanopenMaster::Phase::kStarting);
  d.Time(200 * kMs);  // 500 ms + 3 heartbeat periods after the Start
  ASSERT_EQ(d.master.phase(), CanopenMaster::Phase::kFailed);
  EXPECT_THAT(d.master.errors(), ElementsAre("node 1 (theta): no heartbeat saying operational within 0.8 s after "
                                             "Start remote node (last state: pre-operational)"));
  // The refused start leaves the bus as found: the node back to pre-operational, its 1017h 0 again.
  std::vector<std::string> undo;
  for (const CanFrame& f : d.master.UndoStart()) undo.push_back(ToString(f));
  EXPECT_THAT(undo, ElementsAre("000#8001", "601#2B17100000000000"));

  ScriptedNode ok(ScriptedNode::OneEncoder());
  ok.answers["4017100000000000"] = "4B17100000000000";
  ok.answers["2B17100064000000"] = "6017100000000000";
  ok.master.Begin(ok.t);
  ok.Answer();
  ok.Heartbeat(0x05);
  EXPECT_EQ(ok.master.phase(), CanopenMaster::Phase::kRunning);
  EXPECT_THAT(ok.logs, Contains("every node is operational (each heartbeat says so)"));
}

// A device that refuses the heartbeat time (1017h read-only) cannot confirm its state: the start
// is refused, or with a trusted configuration it is started and said to be unconfirmed.
TEST(Master, ANodeThatCannotSendHeartbeatsIsRefusedOrStartedUnconfirmed) {
  for (const bool trust : {false, true}) {
    MasterConfig mc = ScriptedNode::OneEncoder();
    mc.trust_config = trust;
    ScriptedNode d(mc);
    d.answers["4017100000000000"] = "4B17100000000000";
    d.answers["2B17100064000000"] = "8017100002000106";  // read only
    d.master.Begin(d.t);
    d.Answer();
    const std::string why =
        "its NMT state cannot be confirmed: object 0x1017:00 (producer heartbeat time) is 0, it sends no heartbeat "
        "(writing 0x1017:00 (producer heartbeat time): the device aborted: 0x06010002 (attempt to write a read only "
        "object))";
    if (!trust) {
      ASSERT_EQ(d.master.phase(), CanopenMaster::Phase::kFailed);
      EXPECT_THAT(d.master.errors(), ElementsAre("node 1 (theta): " + why));
      EXPECT_THAT(d.sent, Not(Contains("000#0101")));
      continue;
    }
    EXPECT_EQ(d.master.phase(), CanopenMaster::Phase::kRunning);
    EXPECT_THAT(d.logs, Contains("node 1 (theta): " + why + " (trusted: acquiring anyway)"));
    EXPECT_THAT(d.logs, Contains("every node is started; not confirmed operational (no heartbeat): node 1 (theta)"));
    EXPECT_EQ(d.master.counts().unconfirmed, 1U);
  }
}

// The SYNC carries a counter (overflow value 240) and the device's 1019h is 0: it would refuse
// every SYNC. The start is refused naming 1019h; --configure-pdo writes it.
TEST(Master, A1019hThatDoesNotFitTheSyncRefusesTheStartOrIsWritten) {
  MasterConfig mc = ScriptedNode::OneEncoder();
  mc.sync_counter_max = 240;
  mc.sync_counter_name = "--sync-counter-max";
  ScriptedNode d(mc);
  d.answers["4019100000000000"] = "4F19100000000000";
  d.master.Begin(d.t);
  d.Answer();
  ASSERT_EQ(d.master.phase(), CanopenMaster::Phase::kFailed);
  EXPECT_THAT(d.master.errors(),
              ElementsAre("node 1 (theta): object 0x1019:00 (synchronous counter overflow value): the device has 0, "
                          "--sync-counter-max 240 (a node that expects another SYNC refuses every SYNC: EMCY 0x8240, "
                          "pre-operational)"));
  mc.configure_pdo = true;
  ScriptedNode c(mc);
  c.answers["4019100000000000"] = "4F19100000000000";
  c.answers["2F191000F0000000"] = "6019100000000000";
  for (const char* w : {"2300180181010080", "2F00180201000000", "2F001A0000000000", "23001A0120000460",
                        "2F001A0001000000", "2300180181010000"}) {
    c.answers[w] = "60" + std::string(w).substr(2, 6) + "00000000";
  }
  c.master.Begin(c.t);
  c.Answer();
  const auto write = std::find(c.sent.begin(), c.sent.end(), "601#2F191000F0000000");
  ASSERT_NE(write, c.sent.end());
  EXPECT_EQ(*(write + 1), "601#4019100000000000");  // read back: 240
  c.Heartbeat(0x05);
  EXPECT_EQ(c.master.phase(), CanopenMaster::Phase::kRunning) << ::testing::PrintToString(c.master.errors());
}

// A node that reboots without its stored settings (1017h and 1019h back at 0, EMCY 0x5000) and
// stays pre-operational: the changed heartbeat time is flagged and the start's written back, the
// node is not called operational again while its heartbeat says pre-operational, Start is sent
// again each time the wait runs out, and after the return timeout the acquisition ends.
TEST(Master, ANodeBackWithoutItsSettingsIsFlaggedAndNotCalledOperational) {
  DeviceSimConfig sc = Booting();
  sc.heartbeat_period_s = 0.2;
  sc.faults.reboots = {{2, 2.0, true}};
  Rig r(sc);
  r.bus.ProduceSync(kT0 + 10 * kMs, 10 * kMs);
  r.master->Begin(kT0);
  r.bus.RunUntil(kT0 + 1900 * kMs);
  ASSERT_EQ(r.master->phase(), CanopenMaster::Phase::kRunning);
  r.bus.RunUntil(kT0 + 5000 * kMs);
  EXPECT_EQ(r.sim.NodeState(2), 0x7F);
  EXPECT_THAT(r.notes, Contains("node 2 (phi): object 0x1017:00 (producer heartbeat time) is 0 ms after its reboot, "
                                "200 ms at the start: it may have lost its stored settings"));
  EXPECT_THAT(r.Frames(), Contains("602#2B171000C8000000"));  // 200 ms written back
  EXPECT_THAT(r.logs, Not(Contains("node 2 (phi): restarted, operational again")));
  EXPECT_EQ(r.master->counts().restarts, 0U);
  EXPECT_EQ(r.master->counts().restart_failures, 0U);  // not yet: 10 s to come back
  EXPECT_EQ(r.master->phase(), CanopenMaster::Phase::kRunning);
  EXPECT_THAT(r.logs, Contains("node 2 (phi): not operational yet (last state: pre-operational): sending Start "
                               "remote node again"));
  r.bus.RunUntil(kT0 + 13000 * kMs);
  EXPECT_EQ(r.master->counts().restart_failures, 1U);
  ASSERT_EQ(r.master->phase(), CanopenMaster::Phase::kNodeLost);
  // Start at 2.05 s and every 1.1 s after (0.5 s + 3 heartbeat periods) until 12.05 s: 10 times.
  const auto frames = r.Frames();
  EXPECT_EQ(std::count(frames.begin(), frames.end(), "000#0102"), 11);  // and the start's
  EXPECT_THAT(r.notes, Contains("node 2 (phi) was not restarted after its reboot: no heartbeat saying operational "
                                "within 10.0 s (Start remote node sent 10 times; last state: pre-operational): "
                                "the acquisition ends"));
  EXPECT_THAT(r.master->errors(), ElementsAre(HasSubstr("node 2 (phi) was not restarted after its reboot")));
}

// A running node dropped to pre-operational without a reboot, by another master's NMT command and
// by its own error behaviour (CiA 301 1029h: EMCY, error register set, pre-operational, which
// NMT Start cannot end until the error clears): the master sends Start at once and again until
// the node's heartbeat says operational.
TEST(Master, ANodeThatLeavesOperationalIsStartedAgain) {
  DeviceSimConfig sc = Booting();
  sc.heartbeat_period_s = 0.1;
  sc.faults.reboots = {{2, 3.0, false, NodeFaultKind::kError, 1.0}};
  Rig r(sc);
  r.bus.ProduceSync(kT0 + 10 * kMs, 10 * kMs);
  r.master->Begin(kT0);
  r.bus.RunUntil(kT0 + 2000 * kMs);
  ASSERT_EQ(r.master->phase(), CanopenMaster::Phase::kRunning);
  r.bus.Send(EncodeNmt(NmtCommand::kEnterPreOperational, 3));  // another master's command
  r.bus.RunUntil(kT0 + 2500 * kMs);
  EXPECT_EQ(r.sim.NodeState(3), 0x05);
  const auto frames = r.Frames();
  const auto after = [&frames](std::size_t from, const std::string& frame) {
    return static_cast<std::size_t>(std::find(frames.begin() + static_cast<std::ptrdiff_t>(from), frames.end(), frame) -
                                    frames.begin());
  };
  // Its heartbeat at once says pre-operational; the master's Start follows; operational again.
  const std::size_t preop = r.IndexOf("000#8003");
  const std::size_t hb_preop = after(preop, "703#7F");
  const std::size_t start = after(hb_preop, "000#0103");
  const std::size_t hb_op = after(start, "703#05");
  ASSERT_LT(hb_op, frames.size());
  EXPECT_LT(r.bus.log()[start].t_ns - r.bus.log()[hb_preop].t_ns, kMs);  // at once
  EXPECT_THAT(r.logs, Contains("node 3 (probe): heartbeat says pre-operational: it left operational; sending Start "
                               "remote node"));
  EXPECT_THAT(r.logs, Contains("node 3 (probe): restarted, operational again"));
  // The error: EMCY 0x8100 with register 0x11, pre-operational; Start does not hold until the
  // error reset (EMCY 0x0000) 1 s later; the next Start after it does.
  r.bus.RunUntil(kT0 + 6000 * kMs);
  EXPECT_EQ(r.sim.NodeState(2), 0x05);
  const auto all = r.Frames();
  const std::size_t emcy = r.IndexOf("082#0081110000000000");
  const std::size_t reset = r.IndexOf("082#0000000000000000");
  ASSERT_LT(emcy, all.size());
  ASSERT_LT(reset, all.size());
  const auto starts = std::count(all.begin() + static_cast<std::ptrdiff_t>(emcy), all.end(), "000#0102");
  EXPECT_GE(starts, 2);  // one at once (refused: the error), one after the reset
  EXPECT_EQ(r.master->counts().left_operational, 2U);
  EXPECT_EQ(r.master->counts().restarts, 2U);
  EXPECT_GE(r.master->counts().start_retries, 1U);
  EXPECT_EQ(r.master->counts().restart_failures, 0U);
  EXPECT_EQ(r.master->phase(), CanopenMaster::Phase::kRunning);
}

TEST(Master, ConfigurationErrors) {
  MasterConfig mc;
  mc.nmt = false;
  mc.configure_pdo = true;
  EXPECT_THROW(mc.Validate(), Error);
  MasterConfig twice;
  twice.nodes = MasterNodesFor(PipelineConfig{});
  twice.nodes[1].node_id = 1;
  EXPECT_THROW(twice.Validate(), Error);
  // Two encoders on one node share it, each with its own TPDO.
  PipelineConfig shared;
  shared.phi.node_id = 1;
  shared.phi.field.can_id = 0x281;
  const auto nodes = MasterNodesFor(shared);
  ASSERT_EQ(nodes.size(), 2U);
  EXPECT_EQ(nodes[0].name, "theta+phi");
  EXPECT_EQ(nodes[0].devices[1].tpdo, 2);
}

}  // namespace
}  // namespace sph::can
