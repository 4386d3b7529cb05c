#include "sph/can/pipeline.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/can/device_sim.hpp"
#include "sph/can/error_frame.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"

namespace sph::can {
namespace {

constexpr std::int64_t kMs = 1000000;
constexpr std::int64_t kT0 = 1700000000LL * 1000000000LL;

// Collects what the pipeline hands out.
struct Sink {
  std::vector<Sample> samples;
  std::vector<std::string> notes;
  std::vector<std::string> logs;
  AcquisitionPipeline::Callbacks Callbacks() {
    return {[this](const Sample& s) { samples.push_back(s); }, [this](const std::string& n) { notes.push_back(n); },
            [this](LogLevel, const std::string& l) { logs.push_back(l); }};
  }
};

PipelineConfig SmallConfig() {
  PipelineConfig c;
  c.theta.counts_per_rev = 3600;
  c.phi.counts_per_rev = 3600;
  c.sync_period_s = 0.001;
  return c;
}

CanFrame Pdo(const PipelineConfig& c, int device, std::int64_t raw, std::int64_t t_ns) {
  CanFrame f;
  const FieldLayout& l = device == kTheta ? c.theta.field : device == kPhi ? c.phi.field : c.probe.field;
  f.id = l.can_id;
  InsertField(f, l, raw);
  f.t_ns = t_ns;
  return f;
}

CanFrame Sync(std::int64_t t_ns, std::optional<std::uint8_t> counter = std::nullopt) {
  CanFrame f = EncodeSync(counter);
  f.t_ns = t_ns;
  return f;
}

// A full cycle k: SYNC then the three PDOs (theta = k deg/10, phi 45 deg, r = 5 mm + k nm).
void Cycle(AcquisitionPipeline& p, const PipelineConfig& c, int k, int skip = -1) {
  const std::int64_t t = kT0 + k * kMs;
  p.OnFrame(Sync(t));
  if (skip != kTheta) p.OnFrame(Pdo(c, kTheta, k, t + 100000));
  if (skip != kPhi) p.OnFrame(Pdo(c, kPhi, 450, t + 200000));
  if (skip != kProbe) p.OnFrame(Pdo(c, kProbe, 5000000 + k, t + 300000));
}

TEST(Pipeline, OneSamplePerSyncCycleWithTheSyncTime) {
  const PipelineConfig c = SmallConfig();
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  for (int k = 0; k < 5; ++k) Cycle(p, c, k);
  p.Finish();
  ASSERT_EQ(sink.samples.size(), 5U);
  EXPECT_DOUBLE_EQ(sink.samples[3].theta_deg, 0.3);
  EXPECT_DOUBLE_EQ(sink.samples[3].phi_deg, 45.0);
  EXPECT_DOUBLE_EQ(sink.samples[3].r_mm, 5.000003);
  EXPECT_DOUBLE_EQ(sink.samples[3].t_s, static_cast<double>(kT0 + 3 * kMs) * 1e-9);
  EXPECT_EQ(p.counts().samples, 5U);
  EXPECT_EQ(p.counts().cycles, 5U);
  EXPECT_EQ(p.counts().Losses(), 0U);
  EXPECT_TRUE(sink.notes.empty());
}

TEST(Pipeline, IncompleteCyclesAreCountedAndNotedNeverFilled) {
  const PipelineConfig c = SmallConfig();
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  Cycle(p, c, 0);
  Cycle(p, c, 1, kProbe);
  Cycle(p, c, 2, kProbe);
  Cycle(p, c, 3, kTheta);
  Cycle(p, c, 4);
  p.Finish();
  EXPECT_EQ(sink.samples.size(), 2U);
  EXPECT_EQ(p.counts().incomplete_cycles, 3U);
  EXPECT_EQ(p.counts().missing[kProbe], 2U);
  EXPECT_EQ(p.counts().missing[kTheta], 1U);
  EXPECT_EQ(p.counts().Losses(), 3U);
  ASSERT_EQ(sink.notes.size(), 2U);  // the two probe cycles in one note
  EXPECT_EQ(sink.notes[0],
            "2 incomplete SYNC cycles from t_s 1700000000.001000 to 1700000000.002000 (no sample "
            "written): probe no frame");
  EXPECT_EQ(sink.notes[1],
            "1 incomplete SYNC cycle from t_s 1700000000.003000 to 1700000000.003000 (no sample "
            "written): theta no frame");
}

// The last cycle's PDOs may have come after the end (a stop, the end of a log): it is noted as
// cut, not lost, so that a stopped live run and the replay of its log end alike.
TEST(Pipeline, AnUnfinishedLastCycleIsCutByTheEndNotLost) {
  const PipelineConfig c = SmallConfig();
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  Cycle(p, c, 0);
  Cycle(p, c, 1, kPhi);
  p.Finish();
  EXPECT_EQ(p.counts().incomplete_cycles, 0U);
  EXPECT_EQ(p.counts().cut_by_stop, 1U);
  EXPECT_EQ(p.counts().Losses(), 0U);
  EXPECT_EQ(sink.samples.size(), 1U);
  ASSERT_EQ(sink.notes.size(), 1U);
  EXPECT_EQ(sink.notes[0],
            "the SYNC cycle of t_s 1700000000.001000 was cut by the end of the acquisition (no sample "
            "written)");
}

TEST(Pipeline, MalformedAndFlaggedValuesMakeTheCycleIncomplete) {
  const PipelineConfig c = SmallConfig();
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  const std::int64_t t = kT0;
  p.OnFrame(Sync(t));
  p.OnFrame(Pdo(c, kTheta, 1, t + 1));
  p.OnFrame(MakeFrame(c.phi.field.can_id, {1, 2}, t + 2));  // short
  p.OnFrame(Pdo(c, kProbe, 5000000, t + 3));
  p.OnFrame(Sync(t + kMs));
  p.OnFrame(Pdo(c, kTheta, 5000, t + kMs + 1));  // 5000 >= 3600 counts: out of range
  p.OnFrame(Pdo(c, kPhi, 1, t + kMs + 2));
  p.OnFrame(Pdo(c, kProbe, 0x7FFFFFFF, t + kMs + 3));  // over range
  Cycle(p, c, 2);
  p.Finish();
  ASSERT_EQ(sink.samples.size(), 1U);
  EXPECT_DOUBLE_EQ(sink.samples[0].theta_deg, 0.2);
  EXPECT_EQ(p.counts().malformed[kPhi], 1U);
  EXPECT_EQ(p.counts().flagged[kTheta], 1U);
  EXPECT_EQ(p.counts().flagged[kProbe], 1U);
  EXPECT_EQ(p.counts().incomplete_cycles, 2U);
  ASSERT_EQ(sink.notes.size(), 2U);
  EXPECT_NE(sink.notes[0].find("phi frame too short"), std::string::npos) << sink.notes[0];
  EXPECT_NE(sink.notes[1].find("theta out of range, probe out of range"), std::string::npos) << sink.notes[1];
}

// Two PDOs of one device in one SYNC period: one of them may answer a SYNC that never arrived
// (or come late from the previous one), so neither is paired with this SYNC.
TEST(Pipeline, TwoPdosOfADeviceInOneCycleAreNeitherUsedAndPdosBeforeTheFirstSync) {
  const PipelineConfig c = SmallConfig();
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  p.OnFrame(Pdo(c, kProbe, 1, kT0 - 10));
  Cycle(p, c, 0);
  p.OnFrame(Pdo(c, kProbe, 99, kT0 + 900000));
  Cycle(p, c, 1);
  p.Finish();
  EXPECT_EQ(p.counts().outside_cycle, 1U);
  EXPECT_EQ(p.counts().duplicates, 1U);
  EXPECT_EQ(p.counts().incomplete_cycles, 1U);
  ASSERT_EQ(sink.samples.size(), 1U);
  EXPECT_DOUBLE_EQ(sink.samples[0].r_mm, 5.000001);
  ASSERT_EQ(sink.notes.size(), 1U);
  EXPECT_NE(sink.notes[0].find("probe 2 PDOs"), std::string::npos) << sink.notes[0];
}

TEST(Pipeline, MissedSyncsByCounter) {
  PipelineConfig c = SmallConfig();
  c.sync_counter_max = 4;
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  p.OnFrame(Sync(kT0, 3));
  p.OnFrame(Sync(kT0 + kMs, 4));
  p.OnFrame(Sync(kT0 + 2 * kMs, 1));  // wrap: fine
  p.OnFrame(Sync(kT0 + 5 * kMs, 4));  // 2 and 3 missing
  p.Finish();
  EXPECT_EQ(p.counts().missed_syncs, 2U);
  EXPECT_EQ(p.counts().incomplete_cycles, 3U);  // no PDOs at all here; the last one is cut by the end
  EXPECT_EQ(p.counts().cut_by_stop, 1U);
}

TEST(Pipeline, MissedSyncsByTimeGap) {
  const PipelineConfig c = SmallConfig();  // 1 ms period
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  Cycle(p, c, 0);
  Cycle(p, c, 1);
  Cycle(p, c, 5);  // 2, 3, 4 never came
  p.Finish();
  EXPECT_EQ(p.counts().missed_syncs, 3U);
  EXPECT_EQ(p.counts().samples, 3U);
  ASSERT_EQ(sink.notes.size(), 1U);
  EXPECT_EQ(sink.notes[0],
            "3 SYNC cycles missing (never received) between t_s 1700000000.001000 and "
            "1700000000.005000");
}

TEST(Pipeline, HeartbeatLossStateChangesEmcyAndErrorFrames) {
  PipelineConfig c = SmallConfig();
  c.heartbeat_timeout_s = 0.5;
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  CanFrame hb = EncodeHeartbeat(1, NmtState::kOperational);
  hb.t_ns = kT0;
  p.OnFrame(hb);
  CanFrame hb2 = EncodeHeartbeat(2, NmtState::kPreOperational);
  hb2.t_ns = kT0 + 100 * kMs;
  p.OnFrame(hb2);
  p.OnTime(kT0 + 700 * kMs);  // node 3 never sent one since the start, node 1 silent 0.7 s
  EXPECT_EQ(p.counts().not_operational, 1U);
  EXPECT_EQ(p.counts().heartbeats_lost, 3U);  // node 1 0.7 s, node 2 0.6 s silent, node 3 never seen
  CanFrame emcy = EncodeEmergency({3, 0x8130, 0x11, {}});
  emcy.t_ns = kT0 + 800 * kMs;
  p.OnFrame(emcy);
  CanFrame bad_emcy = MakeFrame(0x083, {1}, kT0 + 801 * kMs);
  p.OnFrame(bad_emcy);
  CanFrame off = MakeErrorFrame(kErrBusOff);
  off.t_ns = kT0 + 802 * kMs;
  p.OnFrame(off);
  p.OnFrame(MakeErrorFrame(kErrController, {0, 4}));
  EXPECT_EQ(p.counts().emergencies, 1U);
  EXPECT_EQ(p.counts().malformed_other, 1U);
  EXPECT_EQ(p.counts().error_frames, 2U);
  EXPECT_EQ(p.counts().bus_off, 1U);
  bool saw_emcy = false, saw_lost = false;
  for (const auto& l : sink.logs) {
    saw_emcy |= l.find("probe node 3: EMCY 0x8130") != std::string::npos;
    saw_lost |= l.find("node 1 (theta): heartbeat lost") != std::string::npos;
  }
  EXPECT_TRUE(saw_emcy);
  EXPECT_TRUE(saw_lost);
}

// What the bus and the nodes tell goes into the file as a comment at its place among the rows (a
// row is written when its cycle is resolved, after events of later times came): EMCY, the error
// state it opens (the rows in it counted) and its reset, an error frame, a full transmit queue, a
// node leaving operational (a gap, closed by its first PDO after), a heartbeat lost and back.
TEST(Pipeline, WhatTheBusAndTheNodesTellIsWrittenAtItsPlaceAmongTheRows) {
  PipelineConfig c = SmallConfig();
  c.heartbeat_timeout_s = 0.0035;
  std::vector<std::string> file;  // rows and comments, in the order written
  AcquisitionPipeline p(c, {[&](const Sample& s) { file.push_back(internal::Format("row %.4f", s.t_s - 1.7e9)); },
                            [&](const std::string& n) { file.push_back("# " + n); }, nullptr});
  const auto at = [](double ms) { return kT0 + static_cast<std::int64_t>(ms * 1e6); };
  const auto heartbeat = [&](int node, NmtState state, double ms) {
    CanFrame hb = EncodeHeartbeat(node, state);
    hb.t_ns = at(ms);
    p.OnFrame(hb);
  };
  const auto emcy = [&](std::uint16_t code, std::uint8_t reg, double ms) {
    CanFrame e = EncodeEmergency({3, code, reg, {}});
    e.t_ns = at(ms);
    p.OnFrame(e);
  };
  // Nodes 1 and 3 send a heartbeat in every cycle, node 2 until cycle 8.
  NmtState phi = NmtState::kOperational;
  const auto cycle = [&](int k, int skip = -1) {
    Cycle(p, c, k, skip);
    heartbeat(1, NmtState::kOperational, k + 0.5);
    heartbeat(3, NmtState::kOperational, k + 0.5);
    if (k <= 8) heartbeat(2, phi, k + 0.5);
  };
  for (int k = 0; k < 3; ++k) cycle(k);
  emcy(0x4210, 0x09, 2.7);  // temperature: an error state
  for (int k = 3; k < 6; ++k) cycle(k);
  CanFrame err = MakeErrorFrame(kErrController, {0, 0x04});
  err.t_ns = at(5.7);
  p.OnFrame(err);
  p.OnTxQueueFull("SYNC", at(5.75));
  emcy(0x0000, 0x00, 5.8);  // error reset
  phi = NmtState::kPreOperational;
  heartbeat(2, phi, 5.9);
  for (int k = 6; k < 8; ++k) cycle(k, kPhi);  // no phi PDO while pre-operational
  phi = NmtState::kOperational;
  heartbeat(2, phi, 7.8);
  for (int k = 8; k < 13; ++k) cycle(k);  // node 2's last heartbeat at 8.5 ms: lost after 12 ms
  heartbeat(2, phi, 13.2);
  cycle(13);
  p.Finish();
  const std::vector<std::string> expected{
      "row 0.0000",
      "row 0.0010",
      "row 0.0020",
      "# EMCY t_s 1700000000.002700: probe node 3: EMCY 0x4210 (temperature), error register 0x09, data 00 00 00 00 "
      "00",
      "# error state start t_s 1700000000.002700: node 3 (probe) signals an error (error register 0x09): the rows "
      "until its error state ends come from a device in an error state",
      "row 0.0030",
      "row 0.0040",
      "row 0.0050",
      "# error frame t_s 1700000000.005700: controller-problem{rx-error-warning}",
      "# transmit queue full t_s 1700000000.005750: a SYNC was not sent",
      "# EMCY t_s 1700000000.005800: probe node 3: EMCY 0x0000 (error reset or no error), error register 0x00, data "
      "00 00 00 00 00",
      "# error state end t_s 1700000000.005800: node 3 (probe): error reset (EMCY 0x0000) after 0.003 s; 3 rows "
      "written in the error state",
      "# node state t_s 1700000000.005900: node 2 (phi): pre-operational (was operational)",
      "# gap start t_s 1700000000.005900: phi (node 2) left operational (pre-operational): no phi values until it "
      "sends again",
      "# 2 incomplete SYNC cycles from t_s 1700000000.006000 to 1700000000.007000 (no sample written): phi no frame "
      "(not operational)",
      "# node state t_s 1700000000.007800: node 2 (phi): operational (was pre-operational)",
      "# gap end t_s 1700000000.008000: phi (node 2) sends again, 0.002 s after it left operational (2 SYNC cycles "
      "without it)",
      "row 0.0080",
      "row 0.0090",
      "row 0.0100",
      "row 0.0110",
      "row 0.0120",
      "# heartbeat lost t_s 1700000000.012100: node 2 (phi): heartbeat lost (none for 0.004 s)",
      "row 0.0130",
      "# heartbeat back t_s 1700000000.013200: node 2 (phi): heartbeat back after 0.005 s without (operational)",
  };

  EXPECT_EQ(file, expected);
  EXPECT_EQ(p.counts().error_states, 1U);
  EXPECT_EQ(p.counts().error_state_rows, 3U);
  EXPECT_EQ(p.counts().tx_queue_full, 1U);
  EXPECT_EQ(p.counts().heartbeats_back, 1U);
}

// A heartbeat never seen and then back: the gap is the time since the start, not an epoch time.
TEST(Pipeline, AHeartbeatBackAfterNeverBeingSeenTellsTheGap) {
  PipelineConfig c = SmallConfig();
  c.heartbeat_timeout_s = 1.5;
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  p.OnTime(kT0);
  p.OnTime(kT0 + 1600 * kMs);
  CanFrame hb = EncodeHeartbeat(2, NmtState::kOperational);
  hb.t_ns = kT0 + 3002 * kMs;
  p.OnFrame(hb);
  EXPECT_THAT(sink.logs, ::testing::Contains("node 2 (phi): heartbeat lost (never seen in 1.600 s)"));
  EXPECT_THAT(sink.logs, ::testing::Contains("node 2 (phi): heartbeat back after 3.002 s without (operational)"));
}

TEST(Pipeline, PointsModeAveragesEachStop) {
  PipelineConfig c = SmallConfig();
  c.mode = Mode::kPoints;
  c.standstill = {0.05, 0.0095, 0.0, 3};
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  // 30 cycles at theta 1.0 deg, r alternating 5.000/5.002; then a move; then 30 cycles at 2.0 deg.
  for (int k = 0; k < 70; ++k) {
    const std::int64_t t = kT0 + k * kMs;
    const int theta_counts = k < 30 ? 10 : k < 40 ? 10 + (k - 29) : 20;
    p.OnFrame(Sync(t));
    p.OnFrame(Pdo(c, kTheta, theta_counts, t + 1));
    p.OnFrame(Pdo(c, kPhi, 450, t + 2));
    p.OnFrame(Pdo(c, kProbe, 5000000 + (k % 2) * 2000, t + 3));
  }
  p.Finish();
  ASSERT_EQ(sink.samples.size(), 2U);
  EXPECT_DOUBLE_EQ(sink.samples[0].theta_deg, 1.0);
  EXPECT_NEAR(sink.samples[0].r_mm, 5.001, 1e-4);  // 20 samples after a 10 ms dwell, alternating
  EXPECT_DOUBLE_EQ(sink.samples[1].theta_deg, 2.0);
  EXPECT_EQ(p.counts().points, 2U);
  ASSERT_EQ(sink.notes.size(), 2U);
  EXPECT_EQ(sink.notes[0].rfind("scatter of the point above: n 20,", 0), 0U) << sink.notes[0];
}

TEST(Pipeline, ConfigurationErrors) {
  PipelineConfig c;
  c.phi.field.can_id = c.theta.field.can_id;
  EXPECT_THROW(c.Validate(), Error);
  PipelineConfig d;
  d.probe.field.can_id = 0x080;
  EXPECT_THROW(d.Validate(), Error);
  PipelineConfig e;
  e.sync_counter_max = 1;
  EXPECT_THROW(e.Validate(), Error);
}

// The simulator and the pipeline agree on every fault: what was injected is what was counted.
TEST(PipelineWithSimulator, EveryInjectedFaultIsCounted) {
  DeviceSimConfig sc;
  sc.spec.pattern = GridPattern(6, 3);
  sc.sync_period_s = 0.01;
  sc.stop_s = 1.0;
  sc.move_s = 0.3;
  sc.devices.sync_counter_max = 200;
  sc.faults.drop_probability = 0.01;
  sc.faults.short_probability = 0.005;
  sc.faults.sync_drop_probability = 0.01;
  sc.faults.probe_out_of_range_probability = 0.005;
  sc.faults.error_frame_period_s = 2.0;
  sc.faults.bus_off_at_s = {5.0};
  sc.faults.silences = {{kPhi, 10.0, 12.0}};
  sc.faults.emergencies = {{kProbe, 3.0, 0x5000}};
  DeviceSimulator sim(sc);
  PipelineConfig pc = sc.devices;
  pc.heartbeat_timeout_s = 1.5;
  Sink sink;
  AcquisitionPipeline p(pc, sink.Callbacks());
  std::vector<CanFrame> frames;
  while (sim.NextCycle(frames)) {
    for (const CanFrame& f : frames) p.OnFrame(f);
    frames.clear();
  }
  p.Finish();
  const SimInjected& in = sim.injected();
  const PipelineCounts& n = p.counts();
  EXPECT_EQ(n.missed_syncs, in.syncs_dropped);
  // Every cycle is a sample, an incomplete cycle, a missed SYNC without a sample, or the last one.
  EXPECT_EQ(n.samples + n.incomplete_cycles + (n.missed_syncs - n.recovered) + n.cut_by_stop, in.cycles);
  EXPECT_GT(n.recovered, 0U);  // dropped SYNCs whose PDOs all came: samples, timed by interpolation
  for (int d = 0; d < kNumDevices; ++d) {
    const auto i = static_cast<std::size_t>(d);
    EXPECT_EQ(n.malformed[i], in.shortened[i]) << DeviceName(d);
  }
  EXPECT_EQ(n.error_frames, in.error_frames);
  EXPECT_EQ(n.bus_off, 1U);
  EXPECT_EQ(n.emergencies, 1U);
  EXPECT_EQ(n.heartbeats_lost, 1U);  // phi silent 2 s > 1.5 s
  EXPECT_GT(n.incomplete_cycles, in.silent_cycles[kPhi]);
  EXPECT_EQ(sink.samples.size(), n.samples);
  EXPECT_GT(in.dropped[kProbe], 0U);
  EXPECT_GT(in.probe_out_of_range, 0U);
}

TEST(PipelineWithSimulator, NoSampleLostAt1kHzForTenMinutes) {
  DeviceSimConfig sc;
  sc.spec.pattern = GridPattern(24, 12);
  sc.sync_period_s = 0.001;
  sc.stop_s = 1.5;
  sc.move_s = 0.6;  // 288 points: 604 s
  DeviceSimulator sim(sc);
  ASSERT_GE(sim.total_cycles(), 600000U);
  std::uint64_t samples = 0;
  AcquisitionPipeline p(sc.devices, {[&](const Sample&) { ++samples; }, nullptr, nullptr});
  std::vector<CanFrame> frames;
  while (sim.NextCycle(frames)) {
    for (const CanFrame& f : frames) p.OnFrame(f);
    frames.clear();
  }
  p.Finish();
  EXPECT_EQ(samples, sim.total_cycles());
  EXPECT_EQ(p.counts().Losses(), 0U);
}

}  // namespace
}  // namespace sph::can
