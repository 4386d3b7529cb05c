// sph_acquired --replay on candump logs written line by line: what a replay reads (the frames of
// one interface).
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
#include "sph/core/points_file.hpp"
#include "test_util.hpp"

namespace sph::apps {
namespace {

using ::testing::Contains;
using ::testing::HasSubstr;

constexpr std::int64_t kT0Us = 1700000000LL * 1000000;  // the logs' first SYNC [us since the epoch]

// "(1700000000.000100) can0 181#E8030000"
std::string Line(std::int64_t t_us, const std::string& iface, const std::string& frame) {
  char head[48];
  std::snprintf(head, sizeof head, "(%lld.%06lld) ", static_cast<long long>(t_us / 1000000),
                static_cast<long long>(t_us % 1000000));
  return head + iface + " " + frame + "\n";
}

// A PDO of `id` with a 4-byte little-endian value.
std::string Pdo(int id, std::uint32_t value) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%03X#%02X%02X%02X%02X", id, value & 0xFF, (value >> 8) & 0xFF, (value >> 16) & 0xFF,
                value >> 24);
  return buf;
}

// The default devices' values in cycle k: theta k * 1000 counts (2^24 a turn), phi 45 deg,
// r 5 mm + k nm.
constexpr std::uint32_t kPhi45 = 1U << 21;
std::uint32_t Theta(int k) { return static_cast<std::uint32_t>(k) * 1000U; }
std::uint32_t R(int k) { return 5000000U + static_cast<std::uint32_t>(k); }
double ThetaDeg(std::uint32_t raw) { return 360.0 * raw / 16777216.0; }

// Cycle k of a SYNC every `period_us` on `iface`: the SYNC and the three PDOs 100, 230 and 360 us
// after it; `skip` leaves out one device's PDO (0 theta, 1 phi, 2 probe).
std::string Cycle(int k, const std::string& iface = "can0", std::int64_t period_us = 10000, int skip = -1) {
  const std::int64_t t = kT0Us + k * period_us;
  std::string s = Line(t, iface, "080#");
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
Replay ReplayLog(const std::string& name, const std::string& log, void (*extra)(AcquireOptions&) = nullptr) {
  const std::string dir = sph::testing::MakeTempDir("replay_" + name);
  std::ofstream(dir + "/x.log") << log;
  AcquireOptions o;
  o.replay_path = dir + "/x.log";
  o.output_path = dir + "/p.txt";
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  o.devices.sync_period_ms = 10.0;
  if (extra != nullptr) extra(o);
  std::ostringstream err;
  Replay r;
  r.dir = dir;
  r.code = RunAcquire(o, err);
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

  const Replay can0 = ReplayLog("two_buses_can0", TwoBuses(), [](AcquireOptions& o) { o.replay_iface = "can0"; });
  EXPECT_EQ(can0.code, kExitSamplesLost) << can0.err;
  ASSERT_EQ(can0.rows.size(), 5U) << can0.err;
  for (const Sample& s : can0.rows) {  // each row is can0's own cycle: theta k * 1000 counts at t0 + k * 10 ms
    const int k = static_cast<int>(std::lround((s.t_s - 1700000000.0) * 100.0));
    EXPECT_NEAR(s.theta_deg, ThetaDeg(Theta(k)), 1e-9) << "row of cycle " << k;
  }
  EXPECT_THAT(can0.file, HasSubstr("theta no frame"));
  EXPECT_THAT(can0.err, HasSubstr("replayed the frames of can0; 24 frames of can1 left out"));

  const Replay can1 = ReplayLog("two_buses_can1", TwoBuses(), [](AcquireOptions& o) { o.replay_iface = "can1"; });
  EXPECT_EQ(can1.code, kExitOk) << can1.err;
  ASSERT_EQ(can1.rows.size(), 6U);
  for (const Sample& s : can1.rows) EXPECT_NEAR(s.theta_deg, ThetaDeg(0x4C4C4C), 1e-9);  // 107.294 deg

  const Replay none = ReplayLog("two_buses_can2", TwoBuses(), [](AcquireOptions& o) { o.replay_iface = "can2"; });
  EXPECT_EQ(none.code, kExitBadInput);
  EXPECT_THAT(none.err,
              HasSubstr("x.log: no frame of interface can2 (the log holds can0 (from line 1) and can1 (from line 2))"));
}

// A log of one interface is replayed whatever its name; its frame log keeps the name.
TEST(ReplayFromLines, TheOnlyInterfaceOfALogIsReplayedAndNamedInTheFrameLog) {
  std::string log;
  for (int k = 0; k < 3; ++k) log += Cycle(k, "vcan1");
  const Replay r = ReplayLog("one_bus", log, [](AcquireOptions& o) { o.can_log_path = o.output_path + ".log"; });
  EXPECT_EQ(r.code, kExitOk) << r.err;
  EXPECT_EQ(r.rows.size(), 3U);
  EXPECT_THAT(sph::testing::ReadWholeFile(r.dir + "/p.txt.log"), HasSubstr(") vcan1 080#"));
}

}  // namespace
}  // namespace sph::apps
