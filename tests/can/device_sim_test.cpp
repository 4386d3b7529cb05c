// The simulated devices behave like CANopen nodes: they boot pre-operational, answer SDO from
// their object dictionary (with aborts), start, stop and reset on NMT, refuse PDO settings while
// operational, and reboot on demand. Frames are checked byte by byte.
#include "sph/can/device_sim.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/can/sdo.hpp"
#include "sph/core/error.hpp"

namespace sph::can {
namespace {

using ::testing::Contains;
using ::testing::ElementsAre;
using ::testing::Not;

constexpr std::int64_t kMs = 1000000;
constexpr std::int64_t kT0 = 1700000000LL * 1000000000LL;

DeviceSimConfig Config() {
  DeviceSimConfig c;
  c.spec.pattern = GridPattern(4, 2);
  c.sync_period_s = 0.01;
  c.start_time_s = static_cast<double>(kT0) * 1e-9;
  c.start_operational = false;
  return c;
}

// Drives the devices: frames in at `t`, everything they send until `until` out, as text.
struct Drive {
  explicit Drive(const DeviceSimConfig& c) : sim(c) {}
  std::vector<std::string> At(std::int64_t t, std::vector<CanFrame> in, std::int64_t until) {
    std::vector<CanFrame> out;
    for (CanFrame& f : in) {
      f.t_ns = t;
      sim.AdvanceTo(t, out);
      sim.OnFrame(f, out);
    }
    sim.AdvanceTo(until, out);
    std::vector<std::string> text;
    for (const CanFrame& f : out) text.push_back(ToString(f));
    return text;
  }
  DeviceSimulator sim;
};

CanFrame Sync() { return EncodeSync(); }

TEST(DeviceSim, BootsPreOperationalAndSendsNoPdoUntilStarted) {
  Drive d(Config());
  // Power-on: silent for boot_s, then boot-up messages, pre-operational heartbeats.
  auto f = d.At(kT0, {}, kT0 + 49 * kMs);
  EXPECT_TRUE(f.empty());
  f = d.At(kT0 + 49 * kMs, {}, kT0 + 1100 * kMs);
  EXPECT_THAT(f, Contains("701#00"));
  EXPECT_THAT(f, Contains("703#00"));
  EXPECT_THAT(f, Contains("701#7F"));
  EXPECT_EQ(d.sim.NodeState(1), 0x7F);
  f = d.At(kT0 + 1100 * kMs, {Sync()}, kT0 + 1110 * kMs);
  EXPECT_TRUE(f.empty()) << ::testing::PrintToString(f);  // no PDO before NMT Start
  f = d.At(kT0 + 1110 * kMs, {EncodeNmt(NmtCommand::kStart, 1)}, kT0 + 1120 * kMs);
  EXPECT_EQ(d.sim.NodeState(1), 0x05);
  EXPECT_EQ(d.sim.NodeState(2), 0x7F);
  f = d.At(kT0 + 1120 * kMs, {Sync()}, kT0 + 1130 * kMs);
  ASSERT_EQ(f.size(), 1U);
  EXPECT_EQ(f[0].substr(0, 4), "181#");
  d.At(kT0 + 1130 * kMs, {EncodeNmt(NmtCommand::kStart, 0)}, kT0 + 1140 * kMs);  // all nodes
  f = d.At(kT0 + 1140 * kMs, {Sync()}, kT0 + 1150 * kMs);
  EXPECT_EQ(f.size(), 3U);
  f = d.At(kT0 + 1150 * kMs, {EncodeNmt(NmtCommand::kStop, 2)}, kT0 + 2100 * kMs);
  EXPECT_THAT(f, Contains("702#04"));  // stopped: heartbeat only
  f = d.At(kT0 + 2100 * kMs, {Sync()}, kT0 + 2110 * kMs);
  EXPECT_THAT(f, Not(Contains(::testing::StartsWith("182#"))));
  f = d.At(kT0 + 2110 * kMs, {EncodeUploadRequest(2, {0x1018, 1})}, kT0 + 2120 * kMs);
  EXPECT_THAT(f, Not(Contains(::testing::StartsWith("582#"))));  // no SDO when stopped
  f = d.At(kT0 + 2120 * kMs, {EncodeNmt(NmtCommand::kResetCommunication, 2)}, kT0 + 2200 * kMs);
  EXPECT_THAT(f, Contains("702#00"));  // boot-up again
  EXPECT_EQ(d.sim.NodeState(2), 0x7F);
}

TEST(DeviceSim, AnswersSdoFromItsDictionaryWithAborts) {
  Drive d(Config());
  d.At(kT0, {}, kT0 + 100 * kMs);
  auto f = d.At(kT0 + 100 * kMs, {EncodeUploadRequest(1, {0x1018, 1})}, kT0 + 101 * kMs);
  EXPECT_THAT(f, Contains("581#4318100148505300"));
  f = d.At(kT0 + 101 * kMs, {EncodeUploadRequest(1, {0x6001, 0})}, kT0 + 102 * kMs);
  EXPECT_THAT(f, Contains("581#4301600000000001"));  // 2^24 counts per revolution
  f = d.At(kT0 + 102 * kMs, {EncodeUploadRequest(3, {0x6001, 0})}, kT0 + 103 * kMs);
  EXPECT_THAT(f, Contains("583#8001600000000206"));  // the probe has no 6001h
  f = d.At(kT0 + 103 * kMs, {EncodeUploadRequest(1, {0x1018, 9})}, kT0 + 104 * kMs);
  EXPECT_THAT(f, Contains("581#8018100911000906"));  // no such sub-index
  f = d.At(kT0 + 104 * kMs, {EncodeDownloadRequest(1, {0x6001, 0}, {0, 0x20, 0, 0})}, kT0 + 105 * kMs);
  EXPECT_THAT(f, Contains("581#8001600002000106"));  // read only
  f = d.At(kT0 + 105 * kMs, {EncodeUploadRequest(1, {0x1A00, 1})}, kT0 + 106 * kMs);
  EXPECT_THAT(f, Contains("581#43001A0120000460"));  // 0x6004:00, 32 bits
}

TEST(DeviceSim, RefusesPdoSettingsWhileOperationalAndFollowsTheMappingAfterwards) {
  DeviceSimConfig c = Config();
  c.devices.sync_counter_max = 10;
  Drive d(c);
  d.At(kT0, {}, kT0 + 100 * kMs);
  d.At(kT0 + 100 * kMs, {EncodeNmt(NmtCommand::kStart, 1)}, kT0 + 101 * kMs);
  auto f = d.At(kT0 + 101 * kMs, {EncodeDownloadRequest(1, {0x1800, 2}, {5})}, kT0 + 102 * kMs);
  EXPECT_THAT(f, Contains("581#8000180222000008"));  // present device state
  d.At(kT0 + 102 * kMs, {EncodeNmt(NmtCommand::kEnterPreOperational, 1)}, kT0 + 103 * kMs);
  f = d.At(kT0 + 103 * kMs, {EncodeDownloadRequest(1, {0x1800, 1}, {0x91, 0x01, 0, 0})}, kT0 + 104 * kMs);
  EXPECT_THAT(f, Contains("581#8000180130000906"));  // another COB-ID while the PDO is valid
  f = d.At(kT0 + 104 * kMs, {EncodeDownloadRequest(1, {0x1A00, 2}, {0x08, 0x00, 0x10, 0x20})}, kT0 + 105 * kMs);
  EXPECT_THAT(f, Contains("581#80001A0200000106"));  // the mapping is on: no entry may change
  // Map the SYNC counter (2010h) behind the position: 0x20100008 as entry 2.
  const std::vector<std::vector<std::uint8_t>> writes{{0}, {0x08, 0x00, 0x10, 0x20}, {2}};
  const std::vector<std::uint8_t> subs{0, 2, 0};
  for (std::size_t i = 0; i < writes.size(); ++i) {
    f = d.At(kT0 + (105 + i) * kMs, {EncodeDownloadRequest(1, {0x1A00, subs[i]}, writes[i])}, kT0 + (106 + i) * kMs);
    ASSERT_EQ(f.size(), 1U);
    EXPECT_EQ(f[0].substr(0, 6), "581#60") << f[0];
  }
  f = d.At(kT0 + 110 * kMs, {EncodeDownloadRequest(1, {0x1A00, 3}, {0x20, 0x00, 0x00, 0x70})}, kT0 + 111 * kMs);
  EXPECT_THAT(f, Contains("581#80001A0300000106"));  // count is non-zero
  d.At(kT0 + 111 * kMs, {EncodeNmt(NmtCommand::kStart, 1)}, kT0 + 112 * kMs);
  f = d.At(kT0 + 112 * kMs, {EncodeSync(std::uint8_t{7})}, kT0 + 113 * kMs);
  ASSERT_EQ(f.size(), 1U);
  EXPECT_EQ(f[0].size(), std::string("181#").size() + 10);  // 5 bytes: position, counter
  EXPECT_EQ(f[0].substr(12), "07");
}

// CiA 301: while operational a TPDO's COB-ID may be written to make the PDO invalid (CANopenNode
// accepts it); the PDO then stops, its other parameters may be changed, and it is made valid again.
TEST(DeviceSim, ATpdoIsInvalidatedWhileOperationalAsCia301Allows) {
  Drive d(Config());
  d.At(kT0, {}, kT0 + 100 * kMs);
  d.At(kT0 + 100 * kMs, {EncodeNmt(NmtCommand::kStart, 1)}, kT0 + 101 * kMs);
  auto f = d.At(kT0 + 101 * kMs, {EncodeDownloadRequest(1, {0x1800, 1}, {0x81, 0x01, 0, 0x80})}, kT0 + 102 * kMs);
  EXPECT_THAT(f, ElementsAre("581#6000180100000000"));  // 0x80000181 taken while operational
  EXPECT_EQ(d.sim.NodeState(1), 0x05);
  f = d.At(kT0 + 102 * kMs, {Sync()}, kT0 + 103 * kMs);
  EXPECT_THAT(f, Not(Contains(::testing::StartsWith("181#"))));  // an invalid PDO is not sent
  f = d.At(kT0 + 103 * kMs, {EncodeDownloadRequest(1, {0x1800, 2}, {1})}, kT0 + 104 * kMs);
  EXPECT_THAT(f, ElementsAre("581#6000180200000000"));  // invalid: its transmission type may change
  f = d.At(kT0 + 104 * kMs, {EncodeDownloadRequest(1, {0x1800, 1}, {0x81, 0x01, 0, 0})}, kT0 + 105 * kMs);
  EXPECT_THAT(f, ElementsAre("581#6000180100000000"));  // valid again
  f = d.At(kT0 + 105 * kMs, {EncodeDownloadRequest(1, {0x1800, 2}, {1})}, kT0 + 106 * kMs);
  EXPECT_THAT(f, ElementsAre("581#8000180222000008"));  // valid and operational: refused again
  f = d.At(kT0 + 106 * kMs, {Sync()}, kT0 + 107 * kMs);
  EXPECT_THAT(f, Contains(::testing::StartsWith("181#")));
}

// 2100h, 16 bytes, read-write: written by a segmented download (CiA 301 7.2.4.3.3 to .5, frames by
// hand), read back by a segmented upload.
TEST(DeviceSim, AnObjectLongerThanFourBytesIsWrittenByASegmentedDownload) {
  Drive d(Config());
  d.At(kT0, {}, kT0 + 100 * kMs);
  const auto frame = [](const std::vector<std::uint8_t>& bytes) {
    CanFrame f = MakeFrame(0x601, {});
    f.len = static_cast<std::uint8_t>(bytes.size());
    std::copy(bytes.begin(), bytes.end(), f.data.begin());
    return f;
  };
  // Initiate: segmented, size indicated (ccs 1, s 1): 16 bytes.
  auto f =
      d.At(kT0 + 100 * kMs, {frame(std::vector<std::uint8_t>{0x21, 0x00, 0x21, 0x00, 16, 0, 0, 0})}, kT0 + 101 * kMs);
  ASSERT_THAT(f, ElementsAre("581#6000210000000000"));
  // "lab 3, bench 2  " in 7 + 7 + 2 bytes; toggle 0, 1, 0; the last with c = 1 and 5 bytes unused.
  f = d.At(kT0 + 101 * kMs, {frame(std::vector<std::uint8_t>{0x00, 'l', 'a', 'b', ' ', '3', ',', ' '})},
           kT0 + 102 * kMs);
  ASSERT_THAT(f, ElementsAre("581#2000000000000000"));
  f = d.At(kT0 + 102 * kMs, {frame(std::vector<std::uint8_t>{0x10, 'b', 'e', 'n', 'c', 'h', ' ', '2'})},
           kT0 + 103 * kMs);
  ASSERT_THAT(f, ElementsAre("581#3000000000000000"));
  f = d.At(kT0 + 103 * kMs, {frame(std::vector<std::uint8_t>{0x0B, ' ', ' ', 0, 0, 0, 0, 0})}, kT0 + 104 * kMs);
  ASSERT_THAT(f, ElementsAre("581#2000000000000000"));
  // A write of another length is refused (0x06070012: length too high).
  f = d.At(kT0 + 104 * kMs, {frame(std::vector<std::uint8_t>{0x21, 0x00, 0x21, 0x00, 17, 0, 0, 0})}, kT0 + 105 * kMs);
  EXPECT_THAT(f, ElementsAre("581#8000210012000706"));
  // Read back: segmented upload of 16 bytes.
  f = d.At(kT0 + 105 * kMs, {EncodeUploadRequest(1, {0x2100, 0})}, kT0 + 106 * kMs);
  ASSERT_THAT(f, ElementsAre("581#4100210010000000"));
  f = d.At(kT0 + 106 * kMs, {EncodeUploadSegmentRequest(1, false)}, kT0 + 107 * kMs);
  EXPECT_THAT(f, ElementsAre("581#006C616220332C20"));  // "lab 3, "
}

TEST(DeviceSim, ARebootFaultSilencesTheNodeUntilItsBootUpAndLeavesItPreOperational) {
  DeviceSimConfig c = Config();
  c.start_operational = true;
  c.faults.reboots = {{3, 0.5}};
  Drive d(c);
  auto f = d.At(kT0 + 499 * kMs, {}, kT0 + 500 * kMs);
  f = d.At(kT0 + 501 * kMs, {Sync()}, kT0 + 510 * kMs);
  EXPECT_THAT(f, Not(Contains(::testing::StartsWith("183#"))));  // rebooting
  EXPECT_EQ(d.sim.NodeState(3), 0x00);
  f = d.At(kT0 + 510 * kMs, {}, kT0 + 560 * kMs);
  EXPECT_THAT(f, Contains("703#00"));
  f = d.At(kT0 + 560 * kMs, {Sync()}, kT0 + 570 * kMs);
  EXPECT_THAT(f, Not(Contains(::testing::StartsWith("183#"))));  // pre-operational: no PDO
  EXPECT_THAT(f, Contains(::testing::StartsWith("181#")));
  EXPECT_EQ(d.sim.injected().reboots, 1U);
  EXPECT_EQ(d.sim.injected().boot_ups, 1U);
}

// 1017h is read-write (CiA 301 §7.5.2.29): a master sets the heartbeat through it. The node sends
// one at once (CANopenNode's OD_write_1017) and then every new period; 0 stops them.
TEST(DeviceSim, AMasterSetsTheHeartbeatThrough1017h) {
  DeviceSimConfig c = Config();
  c.heartbeat_period_s = 0.0;  // 1017h = 0: no heartbeat
  Drive d(c);
  auto f = d.At(kT0, {}, kT0 + 100 * kMs);
  EXPECT_THAT(f, Contains("701#00"));
  f = d.At(kT0 + 100 * kMs, {EncodeUploadRequest(1, {0x1017, 0})}, kT0 + 2000 * kMs);
  EXPECT_THAT(f, ElementsAre("581#4B17100000000000"));  // 0 ms, and no heartbeat for 1.9 s
  f = d.At(kT0 + 2000 * kMs, {MakeFrame(0x601, {0x2B, 0x17, 0x10, 0x00, 0xC8, 0x00, 0x00, 0x00})},
           kT0 + 2450 * kMs);                                                         // 200 ms
  EXPECT_THAT(f, ElementsAre("581#6017100000000000", "701#7F", "701#7F", "701#7F"));  // at 2000.2, 2200.2, 2400.2
  f = d.At(kT0 + 2450 * kMs, {EncodeNmt(NmtCommand::kStart, 1)}, kT0 + 2500 * kMs);
  EXPECT_THAT(f, ElementsAre("701#05"));  // a state change is told at once
  f = d.At(kT0 + 2500 * kMs, {EncodeDownloadRequest(1, {0x1017, 0}, {0, 0})}, kT0 + 4000 * kMs);
  EXPECT_THAT(f, ElementsAre("581#6017100000000000"));  // 0: none any more
}

// 1005h (COB-ID SYNC), 1014h (COB-ID EMCY) and 1019h (synchronous counter overflow value) are
// there, read-write, with CANopenNode's checks; a node takes SYNC on its 1005h and of the length
// its 1019h says.
TEST(DeviceSim, HasTheSyncAndEmcyObjectsAndFollowsThem) {
  Drive d(Config());
  d.At(kT0, {}, kT0 + 100 * kMs);
  auto f = d.At(kT0 + 100 * kMs, {EncodeUploadRequest(1, {0x1005, 0})}, kT0 + 101 * kMs);
  EXPECT_THAT(f, ElementsAre("581#4305100080000000"));
  f = d.At(kT0 + 101 * kMs, {EncodeUploadRequest(2, {0x1014, 0})}, kT0 + 102 * kMs);
  EXPECT_THAT(f, ElementsAre("582#4314100082000000"));
  f = d.At(kT0 + 102 * kMs, {EncodeUploadRequest(3, {0x1019, 0})}, kT0 + 103 * kMs);
  EXPECT_THAT(f, ElementsAre("583#4F19100000000000"));  // no counter, as the SYNC configured
  f = d.At(kT0 + 103 * kMs, {EncodeDownloadRequest(1, {0x1019, 0}, {1})}, kT0 + 104 * kMs);
  EXPECT_THAT(f, ElementsAre("581#8019100030000906"));  // 1 is no overflow value
  f = d.At(kT0 + 104 * kMs, {EncodeDownloadRequest(1, {0x1019, 0}, {241})}, kT0 + 105 * kMs);
  EXPECT_THAT(f, ElementsAre("581#8019100030000906"));
  f = d.At(kT0 + 105 * kMs, {EncodeDownloadRequest(1, {0x1005, 0}, {0x80, 0x00, 0x00, 0x40})}, kT0 + 106 * kMs);
  EXPECT_THAT(f, ElementsAre("581#8005100030000906"));  // it produces no SYNC
  f = d.At(kT0 + 106 * kMs, {EncodeDownloadRequest(2, {0x1014, 0}, {0x90, 0x00, 0x00, 0x00})}, kT0 + 107 * kMs);
  EXPECT_THAT(f, ElementsAre("582#8014100030000906"));  // another id while EMCY is on
  // SYNC on 0x90 for node 1 only; node 2 sends no EMCY; node 1 counts SYNCs to 240.
  const std::vector<std::pair<std::uint16_t, std::vector<std::uint8_t>>> writes{{0x1005, {0x90, 0, 0, 0}},
                                                                                {0x1019, {240}}};
  for (const auto& [index, value] : writes) {
    f = d.At(kT0 + 107 * kMs, {EncodeDownloadRequest(1, {index, 0}, value)}, kT0 + 108 * kMs);
    ASSERT_EQ(f.size(), 1U);
    EXPECT_EQ(f[0].substr(0, 6), "581#60") << f[0];
  }
  f = d.At(kT0 + 108 * kMs, {EncodeDownloadRequest(2, {0x1014, 0}, {0x82, 0x00, 0x00, 0x80})}, kT0 + 109 * kMs);
  EXPECT_THAT(f, ElementsAre("582#6014100000000000"));
  d.At(kT0 + 109 * kMs, {EncodeNmt(NmtCommand::kStart, 0)}, kT0 + 110 * kMs);
  f = d.At(kT0 + 110 * kMs, {EncodeSync(std::uint8_t{7}, 0x90)}, kT0 + 120 * kMs);
  ASSERT_EQ(f.size(), 1U);
  EXPECT_EQ(f[0].substr(0, 4), "181#");
  // 0x80 with a counter: an error for nodes 2 and 3 (1019h 0), node 2 telling it by no EMCY.
  f = d.At(kT0 + 120 * kMs, {EncodeSync(std::uint8_t{8})}, kT0 + 130 * kMs);
  EXPECT_THAT(f, ElementsAre("083#4082111841000000", "702#7F", "703#7F"));
  EXPECT_EQ(d.sim.NodeState(1), 0x05);
  EXPECT_EQ(d.sim.NodeState(2), 0x7F);
}

// A counted SYNC to a node whose 1019h is 0 is no SYNC to it: EMCY 0x8240 (unexpected SYNC data
// length) with the communication and generic bits, pre-operational, no PDO; NMT Start cannot make
// it operational until a reset clears the error (CANopenNode's CO_SYNC_receive, CO_NMT_process).
TEST(DeviceSim, ACountedSyncToANodeWithout1019hIsAnErrorThatStopsIt) {
  DeviceSimConfig c = Config();
  c.devices.sync_counter_max = 240;
  c.sync_counter_overflow = 0;
  Drive d(c);
  d.At(kT0, {}, kT0 + 100 * kMs);
  d.At(kT0 + 100 * kMs, {EncodeNmt(NmtCommand::kStart, 0)}, kT0 + 110 * kMs);
  auto f = d.At(kT0 + 110 * kMs, {EncodeSync(std::uint8_t{1})}, kT0 + 120 * kMs);
  EXPECT_THAT(f, ElementsAre("081#4082111841000000", "082#4082111841000000", "083#4082111841000000", "701#7F", "702#7F",
                             "703#7F"));
  f = d.At(kT0 + 120 * kMs, {EncodeSync(std::uint8_t{2})}, kT0 + 130 * kMs);
  EXPECT_TRUE(f.empty()) << ::testing::PrintToString(f);  // the EMCY once; no PDO
  d.At(kT0 + 130 * kMs, {EncodeNmt(NmtCommand::kStart, 1)}, kT0 + 140 * kMs);
  EXPECT_EQ(d.sim.NodeState(1), 0x7F);
  f = d.At(kT0 + 140 * kMs, {EncodeUploadRequest(1, {0x1001, 0})}, kT0 + 141 * kMs);
  EXPECT_THAT(f, ElementsAre("581#4F01100011000000"));  // the error register
  // Configured (pre-operational), reset: the node takes the counted SYNC.
  d.At(kT0 + 141 * kMs, {EncodeNmt(NmtCommand::kResetCommunication, 1)}, kT0 + 200 * kMs);
  d.At(kT0 + 200 * kMs, {EncodeDownloadRequest(1, {0x1019, 0}, {240})}, kT0 + 201 * kMs);
  d.At(kT0 + 201 * kMs, {EncodeNmt(NmtCommand::kStart, 1)}, kT0 + 202 * kMs);
  EXPECT_EQ(d.sim.NodeState(1), 0x05);
  f = d.At(kT0 + 202 * kMs, {EncodeSync(std::uint8_t{3})}, kT0 + 210 * kMs);
  EXPECT_THAT(f, Contains(::testing::StartsWith("181#")));
  EXPECT_EQ(d.sim.injected().sync_length_errors, 8U);  // 3 nodes at SYNC 1 and 2, nodes 2 and 3 at SYNC 3
}

// A node that reboots without its stored settings comes back with 1017h and 1019h 0 and a hardware
// error (EMCY 0x5000) that keeps it pre-operational.
TEST(DeviceSim, ARebootWithoutItsSettingsLeavesANodeThatCannotStart) {
  DeviceSimConfig c = Config();
  c.start_operational = true;
  c.heartbeat_period_s = 0.2;
  c.devices.sync_counter_max = 240;
  c.faults.reboots = {{2, 0.5, true}};
  Drive d(c);
  d.At(kT0, {}, kT0 + 500 * kMs);
  auto f = d.At(kT0 + 500 * kMs, {}, kT0 + 600 * kMs);
  EXPECT_THAT(f, ElementsAre("702#00", "082#0050010000000000"));  // boot-up, then the hardware error
  f = d.At(kT0 + 600 * kMs, {EncodeUploadRequest(2, {0x1017, 0})}, kT0 + 601 * kMs);
  EXPECT_THAT(f, Contains("582#4B17100000000000"));  // 0 ms (it had 200)
  f = d.At(kT0 + 601 * kMs, {EncodeUploadRequest(2, {0x1019, 0})}, kT0 + 602 * kMs);
  EXPECT_THAT(f, Contains("582#4F19100000000000"));  // 0 (it had 240)
  d.At(kT0 + 602 * kMs, {EncodeNmt(NmtCommand::kStart, 2)}, kT0 + 610 * kMs);
  EXPECT_EQ(d.sim.NodeState(2), 0x7F);
  EXPECT_EQ(d.sim.NodeState(1), 0x05);
}

TEST(DeviceSim, ConfigurationErrors) {
  DeviceSimConfig c = Config();
  c.devices.phi.node_id = 1;
  c.devices.phi.field.can_id = 0x281;
  EXPECT_THROW(DeviceSimulator{c}, Error);
  DeviceSimConfig r = Config();
  r.faults.reboots = {{9, 1.0}};
  EXPECT_THROW(DeviceSimulator{r}, Error);
  DeviceSimConfig o = Config();
  o.sync_counter_overflow = 1;
  EXPECT_THROW(DeviceSimulator{o}, Error);
  o.sync_counter_overflow = 241;
  EXPECT_THROW(DeviceSimulator{o}, Error);
  // What sph_simulate refuses: a sphere the probe's beam misses, a form deeper than the sphere.
  DeviceSimConfig missed = Config();
  missed.spec.sphere_radius_mm = 0.5;
  missed.spec.probe_offset_mm = 5.0;
  try {
    DeviceSimulator sim(missed);
    ADD_FAILURE() << "a sphere the beam misses was taken";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::StartsWith("simulation: the probe ray misses the sphere at theta"));
  }
  DeviceSimConfig deep = Config();
  deep.spec.sphere_radius_mm = 0.5;
  deep.spec.centers_mm = {Eigen::Vector3d::Zero()};
  deep.spec.effects.form = {{2, 0, 1000.0}};  // 1 mm
  EXPECT_THROW(DeviceSimulator{deep}, Error);
  EXPECT_NO_THROW(DeviceSimulator{Config()});
}

}  // namespace
}  // namespace sph::can
