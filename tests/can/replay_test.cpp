// sph_acquired --replay on candump logs written line by line: what a replay reads (the frames of
// one interface), PDOs that come late or SYNCs that come twice, a log replayed without its SYNC
// period, SYNC counters out of range, the stops of points mode.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "acquire_cmd.hpp"
#include "sph/io/points_file.hpp"
#include "test_util.hpp"

namespace sph::apps {
namespace {

using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::Not;

constexpr std::int64_t kT0Us = 1700000000LL * 1000000;  // the logs' first SYNC [us since the epoch]

// "(1700000000.000100) can0 181#E8030000"
std::string Line(std::int64_t t_us, const std::string& iface, const std::string& frame) {
  char head[48];
  std::snprintf(head, sizeof head, "(%lld.%06lld) ", static_cast<long long>(t_us / 1000000),
                static_cast<long long>(t_us % 1000000));
  return head + iface + " " + frame + "\n";
}

// A PDO of `id` with a 4-byte little-endian value and, when `counter` >= 0, a fifth byte.
std::string Pdo(int id, std::uint32_t value, int counter = -1) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%03X#%02X%02X%02X%02X", id, value & 0xFF, (value >> 8) & 0xFF, (value >> 16) & 0xFF,
                value >> 24);
  std::string s = buf;
  if (counter >= 0) {
    std::snprintf(buf, sizeof buf, "%02X", counter);
    s += buf;
  }
  return s;
}

// The default devices' values in cycle k: theta k * 1000 counts (2^24 a turn), phi 45 deg,
// r 5 mm + k nm.
constexpr std::uint32_t kPhi45 = 1U << 21;
std::uint32_t Theta(int k) { return static_cast<std::uint32_t>(k) * 1000U; }
std::uint32_t R(int k) { return 5000000U + static_cast<std::uint32_t>(k); }
double ThetaDeg(std::uint32_t raw) { return 360.0 * raw / 16777216.0; }

// A SYNC frame, with its counter byte when `counter` >= 0.
std::string SyncFrame(int counter = -1) {
  if (counter < 0) return "080#";
  char buf[16];
  std::snprintf(buf, sizeof buf, "080#%02X", counter);
  return buf;
}

// Cycle k of a SYNC every `period_us` on `iface`: the SYNC (with `counter` when >= 0) and the three
// PDOs 100, 230 and 360 us after it; `skip` leaves out one device's PDO (0 theta, 1 phi, 2 probe).
std::string Cycle(int k, const std::string& iface = "can0", std::int64_t period_us = 10000, int skip = -1,
                  int counter = -1) {
  const std::int64_t t = kT0Us + k * period_us;
  std::string s = Line(t, iface, SyncFrame(counter));
  if (skip != 0) s += Line(t + 100, iface, Pdo(0x181, Theta(k)));
  if (skip != 1) s += Line(t + 230, iface, Pdo(0x182, kPhi45));
  if (skip != 2) s += Line(t + 360, iface, Pdo(0x183, R(k)));
  return s;
}

struct Replay {
  std::string dir;  ///< the folder of the log and the outputs
  int code = -1;
  std::string err;
  std::string file;  ///< the points file as written ("" when none was made)
  std::vector<Sample> rows;
};

// Replays `log` (written into a folder of its own) with the default devices; `extra` adjusts the
// options.
Replay ReplayLog(const std::string& name, const std::string& log, void (*extra)(can::AcquisitionOptions&) = nullptr) {
  const std::string dir = sph::testing::MakeTempDir("replay_" + name);
  std::ofstream(dir + "/x.log") << log;
  AcquireOptions cli;
  can::AcquisitionOptions& o = cli.acq;
  o.replay_path = dir + "/x.log";
  o.output_path = dir + "/p.txt";
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  o.devices.sync_period_ms = 10.0;
  if (extra != nullptr) extra(o);
  std::ostringstream err;
  Replay r;
  r.dir = dir;
  r.code = RunAcquire(cli, err);
  r.err = err.str();
  if (std::ifstream(o.output_path)) {
    r.file = sph::testing::ReadWholeFile(o.output_path);
    r.rows = ReadPointsFile(o.output_path).samples;
  }
  return r;
}

// A log of `candump -l any`: can0 and can1 both carry the SCMS's ids, their frames interleaved;
// can0's theta PDO of cycle 3 is lost. Nothing of can1 may fill it.
std::string TwoBuses() {
  std::vector<std::string> lines;  // "(seconds.micro) iface frame": sorted by time, stable
  for (int k = 0; k < 6; ++k) {
    std::istringstream a(Cycle(k, "can0", 10000, k == 3 ? 0 : -1));
    const std::int64_t t = kT0Us + k * 10000 + 50;
    std::istringstream b(Line(t, "can1", "080#") + Line(t + 100, "can1", Pdo(0x181, 0x4C4C4C)) +
                         Line(t + 230, "can1", Pdo(0x182, kPhi45)) + Line(t + 360, "can1", Pdo(0x183, R(k))));
    for (std::string l; std::getline(a, l);) lines.push_back(l);
    for (std::string l; std::getline(b, l);) lines.push_back(l);
  }
  std::stable_sort(lines.begin(), lines.end(),
                   [](const std::string& x, const std::string& y) { return x.substr(0, 19) < y.substr(0, 19); });
  std::string log;
  for (const std::string& l : lines) log += l + "\n";
  return log;
}

TEST(ReplayFromLines, ALogOfTwoInterfacesIsRefusedUntilOneIsChosen) {
  const Replay any = ReplayLog("two_buses", TwoBuses());
  EXPECT_EQ(any.code, kExitBadInput) << any.err;
  EXPECT_THAT(any.err, HasSubstr("x.log: frames of 2 interfaces, can0 (from line 1) and can1 (from line 2): choose "
                                 "one with --replay-iface"));
  EXPECT_EQ(any.file, "") << "no points file is made";

  const Replay can0 =
      ReplayLog("two_buses_can0", TwoBuses(), [](can::AcquisitionOptions& o) { o.replay_iface = "can0"; });
  EXPECT_EQ(can0.code, kExitSamplesLost) << can0.err;
  ASSERT_EQ(can0.rows.size(), 5U) << can0.err;
  for (const Sample& s : can0.rows) {  // each row is can0's own cycle: theta k * 1000 counts at t0 + k * 10 ms
    const int k = static_cast<int>(std::lround((s.t_s - 1700000000.0) * 100.0));
    EXPECT_NEAR(s.theta_deg, ThetaDeg(Theta(k)), 1e-9) << "row of cycle " << k;
  }
  EXPECT_THAT(can0.file, HasSubstr("theta no frame"));
  EXPECT_THAT(can0.err, HasSubstr("replayed the frames of can0; 24 frames of can1 left out"));

  const Replay can1 =
      ReplayLog("two_buses_can1", TwoBuses(), [](can::AcquisitionOptions& o) { o.replay_iface = "can1"; });
  EXPECT_EQ(can1.code, kExitOk) << can1.err;
  ASSERT_EQ(can1.rows.size(), 6U);
  for (const Sample& s : can1.rows) EXPECT_NEAR(s.theta_deg, ThetaDeg(0x4C4C4C), 1e-9);  // 107.294 deg

  const Replay none =
      ReplayLog("two_buses_can2", TwoBuses(), [](can::AcquisitionOptions& o) { o.replay_iface = "can2"; });
  EXPECT_EQ(none.code, kExitBadInput);
  EXPECT_THAT(none.err,
              HasSubstr("x.log: no frame of interface can2 (the log holds can0 (from line 1) and can1 (from line 2))"));
}

// A log of one interface is replayed whatever its name; its frame log keeps the name.
TEST(ReplayFromLines, TheOnlyInterfaceOfALogIsReplayedAndNamedInTheFrameLog) {
  std::string log;
  for (int k = 0; k < 3; ++k) log += Cycle(k, "vcan1");
  const Replay r =
      ReplayLog("one_bus", log, [](can::AcquisitionOptions& o) { o.can_log_path = o.output_path + ".log"; });
  EXPECT_EQ(r.code, kExitOk) << r.err;
  EXPECT_EQ(r.rows.size(), 3U);
  EXPECT_THAT(sph::testing::ReadWholeFile(r.dir + "/p.txt.log"), HasSubstr(") vcan1 080#"));
}

// The devices carry the counter of the SYNC they answer in their PDO's fifth byte.
void CountedPdos(can::AcquisitionOptions& o) {
  o.devices.sync_counter_max = 240;
  o.devices.theta.sync_counter_byte = 4;
  o.devices.phi.sync_counter_byte = 4;
  o.devices.probe_sync_counter_byte = 4;
}

// Cycle k with SYNC counter k + 1, each PDO carrying it; `late_theta` moves theta's PDO to 50 us
// after the next SYNC.
std::string CountedCycle(int k, bool late_theta = false) {
  const std::int64_t t = kT0Us + k * 10000;
  std::string s = Line(t, "can0", SyncFrame(k + 1));
  if (!late_theta) s += Line(t + 100, "can0", Pdo(0x181, Theta(k), k + 1));
  s += Line(t + 230, "can0", Pdo(0x182, kPhi45, k + 1));
  s += Line(t + 360, "can0", Pdo(0x183, R(k), k + 1));
  return s;
}

// A PDO belongs to the SYNC counter it carries: theta's PDO of cycle 3 (counter 4) comes 0.05 ms
// after SYNC 5 and still makes cycle 3's row; one two periods late is too late.
TEST(ReplayFromLines, APdoCarryingItsSyncCounterMayComeAfterTheNextSync) {
  std::string log;
  for (int k = 0; k < 6; ++k) log += CountedCycle(k, k == 3);
  const std::string sync5 = Line(kT0Us + 40000, "can0", SyncFrame(5));  // then theta of cycle 3, then cycle 4's
  log.insert(log.find(sync5) + sync5.size(), Line(kT0Us + 40050, "can0", Pdo(0x181, Theta(3), 4)));
  const Replay r = ReplayLog("late_pdo", log, CountedPdos);
  EXPECT_EQ(r.code, kExitOk) << r.err;
  ASSERT_EQ(r.rows.size(), 6U) << r.err;
  EXPECT_NEAR(r.rows[3].theta_deg, ThetaDeg(Theta(3)), 1e-9);
  EXPECT_NEAR(r.rows[3].t_s, 1700000000.03, 1e-7);
  EXPECT_THAT(r.err, Not(HasSubstr("not used")));

  std::string later;
  for (int k = 0; k < 6; ++k) {
    later += CountedCycle(k, k == 2);
    if (k == 4) later += Line(kT0Us + 4 * 10000 + 400, "can0", Pdo(0x181, Theta(2), 3));
  }
  const Replay q = ReplayLog("later_pdo", later, CountedPdos);
  EXPECT_EQ(q.code, kExitSamplesLost) << q.err;
  EXPECT_EQ(q.rows.size(), 5U);
  EXPECT_THAT(q.err, HasSubstr("theta PDO at 1700000000.040400 answers SYNC counter 3, not one of the window of "
                               "counter 5 (not used)"));
  EXPECT_THAT(q.file, HasSubstr("1 incomplete SYNC cycle from t_s 1700000000.020000 to 1700000000.020000 (no sample "
                                "written): theta no frame"));
}

// A SYNC received twice (the same counter 100 us later) is one SYNC: no empty cycle, the row
// timed by the first.
TEST(ReplayFromLines, ASyncRepeatedWithItsCounterIsTakenOnce) {
  std::string log;
  for (int k = 0; k < 6; ++k) {
    std::string c = Cycle(k, "can0", 10000, -1, k + 1);
    if (k == 2) {
      const std::string first = Line(kT0Us + 20000, "can0", SyncFrame(3));
      c.insert(first.size(), Line(kT0Us + 20050, "can0", SyncFrame(3)));
    }
    log += c;
  }
  const Replay r =
      ReplayLog("repeated_sync", log, [](can::AcquisitionOptions& o) { o.devices.sync_counter_max = 240; });
  EXPECT_EQ(r.code, kExitOk) << r.err;
  ASSERT_EQ(r.rows.size(), 6U) << r.err;
  EXPECT_NEAR(r.rows[2].t_s, 1700000000.02, 1e-7);
  EXPECT_NEAR(r.rows[2].theta_deg, ThetaDeg(Theta(2)), 1e-9);
  EXPECT_THAT(r.err, HasSubstr("the SYNC at t_s 1700000000.020050 repeats the counter 3 of the SYNC 0.000050 s "
                               "before: the same SYNC received twice, taken once"));
  EXPECT_THAT(r.err, HasSubstr("SYNC received twice 1"));
  EXPECT_THAT(r.file, Not(HasSubstr("incomplete")));
}

// A log of a SYNC every 10 ms replayed without --sync-period-ms: the period is the log's.
TEST(ReplayFromLines, WithoutItsPeriodALogIsReplayedAtTheObservedPeriod) {
  std::string log;
  for (int k = 0; k < 50; ++k) log += Cycle(k);
  const Replay r = ReplayLog("no_period", log, [](can::AcquisitionOptions& o) { o.devices.sync_period_ms.reset(); });
  EXPECT_EQ(r.code, kExitOk) << r.err;
  EXPECT_EQ(r.rows.size(), 50U);
  EXPECT_THAT(r.err, HasSubstr("missed SYNC 0,"));
  EXPECT_THAT(r.file, Not(HasSubstr("missing")));
  // A SYNC that did not come is still found by the observed period, and its cycle recovered.
  std::string gap;
  for (int k = 0; k < 50; ++k) {
    std::string c = Cycle(k);
    if (k == 30) c.erase(0, c.find('\n') + 1);
    gap += c;
  }
  const Replay g =
      ReplayLog("no_period_gap", gap, [](can::AcquisitionOptions& o) { o.devices.sync_period_ms.reset(); });
  EXPECT_EQ(g.code, kExitOk) << g.err;
  EXPECT_EQ(g.rows.size(), 50U);
  EXPECT_THAT(g.err, HasSubstr("missed SYNC 1,"));
}

// The cycle of a SYNC that never came, recovered from its PDOs, is a cycle of the summary too.
TEST(ReplayFromLines, ARecoveredCycleCountsAsACycle) {
  std::string log;
  for (int k = 0; k < 6; ++k) {
    std::string c = Cycle(k);
    if (k == 3) c.erase(0, c.find('\n') + 1);  // SYNC 3 lost; its PDOs came
    log += c;
  }
  const Replay r = ReplayLog("recovered", log);
  EXPECT_EQ(r.code, kExitOk) << r.err;
  EXPECT_EQ(r.rows.size(), 6U);
  EXPECT_THAT(r.err, HasSubstr("summary: frames 23, SYNC 5, cycles 6, samples 6"));
  EXPECT_THAT(r.err, HasSubstr("missed SYNC 1, kernel drops (rx overflow) 0; recovered cycles of missed SYNC 1;"));
}

// Counters the producer cannot send (here above the overflow value 240) are warned about, and
// their SYNCs' cycles placed by time.
TEST(ReplayFromLines, SyncCountersOutOfRangeAreWarnedAboutAndNotUsed) {
  std::string log;
  for (int k = 0; k < 6; ++k) log += Cycle(k, "can0", 10000, -1, k == 3 ? 250 : k + 1);
  const Replay r = ReplayLog("counter_250", log, [](can::AcquisitionOptions& o) { o.devices.sync_counter_max = 240; });
  EXPECT_EQ(r.code, kExitOk) << r.err;
  EXPECT_EQ(r.rows.size(), 6U);
  EXPECT_THAT(r.err, HasSubstr("the SYNC at t_s 1700000000.030000 carries counter 250, outside 1..240 (the SYNC "
                               "counter overflow value): its cycle is placed by time"));
  EXPECT_THAT(r.err, HasSubstr("SYNC counters not usable 1"));
  // Counters where none is configured: one warning.
  const Replay q = ReplayLog("counter_unconfigured", log);
  EXPECT_EQ(q.code, kExitOk) << q.err;
  EXPECT_THAT(q.err, HasSubstr("the SYNC at t_s 1700000000.000000 carries a counter (1) but no SYNC counter is "
                               "configured: the SYNCs' counters are not used"));
}

// Points mode: 80 samples of one stop at 10 ms with a 0.2 s dwell average the last 60, whatever the
// start time (the epoch seconds rounded in a double used to decide it).
TEST(ReplayFromLines, ADwellTakesTheSameSamplesAtAnyStartTime) {
  for (int j = 20; j < 28; ++j) {  // starts 21 to 25 took 59 samples
    std::string log;
    const std::int64_t t0 = kT0Us + j * 1234567;
    for (int k = 0; k < 80; ++k) {
      const std::int64_t t = t0 + k * 10000;
      log += Line(t, "can0", "080#") + Line(t + 100, "can0", Pdo(0x181, 1000)) +
             Line(t + 230, "can0", Pdo(0x182, kPhi45)) + Line(t + 360, "can0", Pdo(0x183, 5000000));
    }
    const Replay r = ReplayLog("dwell", log, [](can::AcquisitionOptions& o) { o.mode = can::Mode::kPoints; });
    EXPECT_EQ(r.code, kExitOk) << r.err;
    ASSERT_EQ(r.rows.size(), 1U) << r.err;
    EXPECT_THAT(r.file, HasSubstr("scatter of the point above: n 60,")) << "start " << t0;
    EXPECT_NEAR(r.rows[0].t_s, static_cast<double>(t0) * 1e-6 + 0.495, 1e-6);  // the mean of 0.20 .. 0.79 s
  }
}

}  // namespace
}  // namespace sph::apps
