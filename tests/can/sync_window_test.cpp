// No sample the pipeline received is lost or paired with the wrong SYNC: lost SYNCs, lost PDOs,
// kernel drops, SYNC counters carried in the PDOs, and nodes that reboot mid-run. The scenarios
// are written frame by frame; the runs on the simulated bus check every sample against what the
// devices sent for its SYNC.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <random>

#include "sim_bus.hpp"
#include "sph/can/device_sim.hpp"
#include "sph/can/master.hpp"
#include "sph/can/pipeline.hpp"

namespace sph::can {
namespace {

using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr std::int64_t kMs = 1000000;
constexpr std::int64_t kT0 = 1700000000LL * 1000000000LL;

struct Sink {
  std::vector<Sample> samples;
  std::vector<std::string> notes;
  std::vector<std::string> logs;
  AcquisitionPipeline::Callbacks Callbacks() {
    return {[this](const Sample& s) { samples.push_back(s); }, [this](const std::string& n) { notes.push_back(n); },
            [this](LogLevel, const std::string& l) { logs.push_back(l); }};
  }
};

PipelineConfig Config(double period_s, std::uint8_t counter_max) {
  PipelineConfig c;
  c.theta.counts_per_rev = 3600;
  c.phi.counts_per_rev = 3600;
  c.sync_period_s = period_s;
  c.sync_counter_max = counter_max;
  return c;
}

// Cycle k's values: theta k/10 deg, phi 45 deg, r 5 mm + k nm.
CanFrame Pdo(const PipelineConfig& c, int device, int k, std::int64_t t_ns, int counter = -1) {
  CanFrame f;
  const FieldLayout& l = device == kTheta ? c.theta.field : device == kPhi ? c.phi.field : c.probe.field;
  f.id = l.can_id;
  InsertField(f, l, device == kTheta ? k : device == kPhi ? 450 : 5000000 + k);
  if (counter >= 0) {
    f.len = 5;
    f.data[4] = static_cast<std::uint8_t>(counter);
  }
  f.t_ns = t_ns;
  return f;
}

CanFrame Sync(std::int64_t t_ns, std::optional<std::uint8_t> counter = std::nullopt) {
  CanFrame f = EncodeSync(counter);
  f.t_ns = t_ns;
  return f;
}

std::int64_t T(int k) { return kT0 + k * kMs; }

// The hole: the probe's PDO of cycle 1 is lost and so is SYNC 2; the devices answered SYNC 2
// all the same. Without the window, probe(2) would fill cycle 1 and pair with theta(1), phi(1).
TEST(SyncWindow, ALostSyncNoLongerLetsALaterPdoFillTheCycleBefore) {
  for (const auto& [period, counter] : {std::pair{0.001, 0}, std::pair{0.0, 200}, std::pair{0.001, 200}}) {
    const PipelineConfig c = Config(period, static_cast<std::uint8_t>(counter));
    Sink sink;
    AcquisitionPipeline p(c, sink.Callbacks());
    const bool counted = counter != 0;  // a lambda cannot capture a structured binding before C++20
    auto sync = [&](int k) { p.OnFrame(Sync(T(k), counted ? std::optional<std::uint8_t>(k + 1) : std::nullopt)); };
    sync(0);
    for (int d = 0; d < kNumDevices; ++d) p.OnFrame(Pdo(c, d, 0, T(0) + (d + 1) * 100000));
    sync(1);
    p.OnFrame(Pdo(c, kTheta, 1, T(1) + 100000));
    p.OnFrame(Pdo(c, kPhi, 1, T(1) + 200000));  // probe(1) lost; SYNC 2 lost
    for (int d = 0; d < kNumDevices; ++d) p.OnFrame(Pdo(c, d, 2, T(2) + (d + 1) * 100000));
    sync(3);
    for (int d = 0; d < kNumDevices; ++d) p.OnFrame(Pdo(c, d, 3, T(3) + (d + 1) * 100000));
    p.Finish();
    const std::string what = "period " + std::to_string(period) + " counter " + std::to_string(counter);
    ASSERT_EQ(sink.samples.size(), 3U) << what;
    for (const Sample& s : sink.samples) {  // each sample is one cycle: its theta, r and time agree
      const int k = static_cast<int>(std::lround(s.theta_deg * 10.0));
      EXPECT_NEAR(s.r_mm, 5.0 + k * 1e-6, 1e-12) << what;
      EXPECT_NEAR(s.t_s, static_cast<double>(T(k)) * 1e-9, 1e-6) << what;
    }
    EXPECT_DOUBLE_EQ(sink.samples[1].theta_deg, 0.2);  // cycle 2, recovered, its time interpolated
    EXPECT_EQ(p.counts().incomplete_cycles, 1U) << what;
    EXPECT_EQ(p.counts().missed_syncs, 1U);
    EXPECT_EQ(p.counts().recovered, 1U);
    EXPECT_EQ(p.counts().Losses(), 1U);
    EXPECT_THAT(sink.notes, Contains(StartsWith("1 incomplete SYNC cycle from t_s 1700000000.001000")));
    EXPECT_THAT(sink.notes, Contains("1 SYNC cycle missing (never received) between t_s 1700000000.001000 and "
                                     "1700000000.003000; 1 recovered from their PDOs (t_s interpolated)"));
  }
}

// Two PDOs in one period where one SYNC is known missing: they answer its two SYNCs; one PDO
// where two are missing and its place is unclear stays unused.
TEST(SyncWindow, PdosAreSplitByTheirTimeInTheWindow) {
  const PipelineConfig c = Config(0.001, 0);
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  p.OnFrame(Sync(T(0)));
  for (int k = 0; k < 3; ++k) {  // SYNC 1 and 2 never arrive; theta missed cycle 1
    if (k != 1) p.OnFrame(Pdo(c, kTheta, k, T(k) + 100000));
    p.OnFrame(Pdo(c, kPhi, k, T(k) + 200000));
    p.OnFrame(Pdo(c, kProbe, k, T(k) + 300000));
  }
  p.OnFrame(Sync(T(3)));
  p.Finish();
  ASSERT_EQ(sink.samples.size(), 2U);
  EXPECT_DOUBLE_EQ(sink.samples[0].theta_deg, 0.0);
  EXPECT_DOUBLE_EQ(sink.samples[1].theta_deg, 0.2);
  EXPECT_DOUBLE_EQ(sink.samples[1].r_mm, 5.000002);
  EXPECT_EQ(p.counts().missed_syncs, 2U);
  EXPECT_EQ(p.counts().recovered, 1U);
  EXPECT_THAT(sink.notes, Contains(HasSubstr("; 1 recovered from their PDOs (t_s interpolated); 1 with PDOs but no "
                                             "sample: theta no frame")));
}

// Frames the kernel dropped, with nothing (no counter, no period) to tell the cycles apart: the
// cycle's PDOs may answer a SYNC among the dropped frames, so none is used.
TEST(SyncWindow, AfterKernelDropsWithoutCounterOrPeriodNoPdoIsUsed) {
  const PipelineConfig c = Config(0.0, 0);
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  p.OnFrame(Sync(T(0)));
  p.OnFrame(Pdo(c, kTheta, 0, T(0) + 100000));
  p.OnRxOverflow(2, T(0) + 500000);  // probe(0) and SYNC 1, say
  p.OnFrame(Pdo(c, kPhi, 1, T(1) + 200000));
  p.OnFrame(Pdo(c, kProbe, 1, T(1) + 300000));
  p.OnFrame(Sync(T(2)));
  for (int d = 0; d < kNumDevices; ++d) p.OnFrame(Pdo(c, d, 2, T(2) + (d + 1) * 100000));
  p.OnFrame(Sync(T(3)));
  p.Finish();
  ASSERT_EQ(sink.samples.size(), 1U);
  EXPECT_DOUBLE_EQ(sink.samples[0].theta_deg, 0.2);
  EXPECT_THAT(sink.notes, Contains(HasSubstr("theta frames lost before it, phi frames lost before it, probe frames "
                                             "lost before it")));
  // A controller's RX overflow says the same.
  Sink s2;
  AcquisitionPipeline q(c, s2.Callbacks());
  q.OnFrame(Sync(T(0)));
  q.OnFrame(Pdo(c, kTheta, 0, T(0) + 100000));
  CanFrame ovf = MakeFrame(kErrFlag | 0x004, {0, 0x01, 0, 0, 0, 0, 0, 0}, T(0) + 500000);
  q.OnFrame(ovf);
  q.OnFrame(Pdo(c, kPhi, 1, T(1) + 200000));
  q.OnFrame(Pdo(c, kProbe, 1, T(1) + 300000));
  q.OnFrame(Sync(T(2)));
  q.Finish();
  EXPECT_TRUE(s2.samples.empty());
}

// Devices that map the SYNC counter into their PDO: each PDO goes to the cycle of its counter,
// however late it comes; one of a SYNC outside the window is not used.
TEST(SyncWindow, ACounterInThePdoPlacesItExactly) {
  PipelineConfig c = Config(0.0, 10);
  c.sync_counter_byte = {4, 4, 4};
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  p.OnFrame(Sync(T(0), 1));
  p.OnFrame(Pdo(c, kTheta, 0, T(0) + 100000, 1));
  p.OnFrame(Pdo(c, kPhi, 0, T(0) + 200000, 1));
  // SYNC 2 is lost; probe answers SYNC 1 late, after the phi PDO of SYNC 2.
  p.OnFrame(Pdo(c, kTheta, 1, T(1) + 100000, 2));
  p.OnFrame(Pdo(c, kPhi, 1, T(1) + 200000, 2));
  p.OnFrame(Pdo(c, kProbe, 0, T(1) + 250000, 1));
  p.OnFrame(Pdo(c, kProbe, 1, T(1) + 300000, 2));
  p.OnFrame(Pdo(c, kProbe, 7, T(1) + 400000, 7));  // stale: counter 7 is no SYNC of this window
  p.OnFrame(Sync(T(2), 3));
  p.Finish();
  ASSERT_EQ(sink.samples.size(), 2U);
  EXPECT_DOUBLE_EQ(sink.samples[0].theta_deg, 0.0);
  EXPECT_DOUBLE_EQ(sink.samples[0].r_mm, 5.0);
  EXPECT_DOUBLE_EQ(sink.samples[1].theta_deg, 0.1);
  EXPECT_DOUBLE_EQ(sink.samples[1].r_mm, 5.000001);
  EXPECT_EQ(p.counts().unplaced, 1U);
  PipelineConfig bad = c;
  bad.sync_counter_byte = {1, -1, -1};  // inside theta's value
  EXPECT_THROW(bad.Validate(), std::exception);
}

TEST(SyncWindow, CounterAndTimeTogetherTellGapsLongerThanTheCounter) {
  const PipelineConfig c = Config(0.001, 10);
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  p.OnFrame(Sync(T(0), 1));
  p.OnFrame(Sync(T(23), 4));  // 22 missed: the counter alone says 2
  p.Finish();
  EXPECT_EQ(p.counts().missed_syncs, 22U);
}

// A SYNC producer that restarts its counter (as after an NMT reset) between two SYNCs one period
// apart: not missed SYNCs, else the window would be cut into pieces too small for its PDOs.
TEST(SyncWindow, ACounterThatRestartsIsTakenByTheTime) {
  for (const double period : {0.001, 0.0}) {  // configured, or as observed
    const PipelineConfig c = Config(period, 10);
    Sink sink;
    AcquisitionPipeline p(c, sink.Callbacks());
    const std::uint8_t counters[] = {4, 5, 1, 2};  // 5 -> 1: restarted
    for (int k = 0; k < 4; ++k) {
      p.OnFrame(Sync(T(k), counters[k]));
      for (int d = 0; d < kNumDevices; ++d) p.OnFrame(Pdo(c, d, k, T(k) + (d + 1) * 100000));
    }
    p.Finish();
    EXPECT_EQ(sink.samples.size(), 4U) << period;
    EXPECT_EQ(p.counts().missed_syncs, 0U) << period;
    EXPECT_EQ(p.counts().counter_jumps, 1U) << period;
    EXPECT_THAT(sink.logs, Contains(HasSubstr("the SYNC counter went from 5 to 1 in 0.001000 s: a restarted counter")));
  }
}

// A log whose SYNC times do not advance while the counter says one was missed: nothing to split
// the window by, so its PDOs are not used (found by the fuzzer: this divided by zero).
TEST(SyncWindow, SyncsWhoseTimeDoesNotAdvanceLeaveTheirPdosUnplaced) {
  const PipelineConfig c = Config(0.0, 10);
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  p.OnFrame(Sync(T(0), 1));
  for (int d = 0; d < kNumDevices; ++d) p.OnFrame(Pdo(c, d, 0, T(0)));
  p.OnFrame(Sync(T(0), 3));  // the same time, one SYNC missed
  p.Finish();
  EXPECT_TRUE(sink.samples.empty());
  EXPECT_EQ(p.counts().unplaced, 3U);
  EXPECT_EQ(p.counts().missed_syncs, 1U);
}

TEST(SyncWindow, ARebootIsAGapInTheFile) {
  const PipelineConfig c = Config(0.001, 0);
  Sink sink;
  AcquisitionPipeline p(c, sink.Callbacks());
  auto cycle = [&](int k, bool with_theta) {
    p.OnFrame(Sync(T(k)));
    for (int d = 0; d < kNumDevices; ++d) {
      if (d != kTheta || with_theta) p.OnFrame(Pdo(c, d, k, T(k) + (d + 1) * 100000));
    }
  };
  cycle(0, true);
  p.OnFrame(MakeFrame(0x701, {0x00}, T(0) + 800000));  // boot-up of node 1 (theta)
  for (int k = 1; k < 5; ++k) cycle(k, false);
  cycle(5, true);
  cycle(6, true);
  p.Finish();
  EXPECT_EQ(sink.samples.size(), 3U);
  EXPECT_EQ(p.counts().reboots, 1U);
  ASSERT_GE(sink.notes.size(), 3U);
  EXPECT_EQ(sink.notes[0],
            "gap start t_s 1700000000.000800: theta (node 1) rebooted (boot-up message): no theta "
            "values until it sends again");
  EXPECT_EQ(sink.notes[1],
            "4 incomplete SYNC cycles from t_s 1700000000.001000 to 1700000000.004000 (no sample "
            "written): theta no frame (rebooted)");
  EXPECT_EQ(sink.notes[2],
            "gap end t_s 1700000000.005000: theta (node 1) sends again, 0.004 s after its reboot (4 "
            "SYNC cycles without it)");
}

// ------------------------------------------------------------------ on the simulated bus
// The daemon's side of a run: master and pipeline on the bus, SYNC produced every 10 ms.
struct Acquisition {
  Acquisition(DeviceSimConfig sc, std::uint8_t counter_max) : sim(Prepare(sc, counter_max)), bus(&sim, kT0) {
    sim.set_recording(true);
    pc = Prepare(sc, counter_max).devices;
    pc.sync_period_s = 0.0;  // produced: gaps by the counter only
    MasterConfig mc;
    mc.nodes = MasterNodesFor(pc);
    master = std::make_unique<CanopenMaster>(
        mc, CanopenMaster::Callbacks{[this](const CanFrame& f) { bus.Send(f); }, nullptr,
                                     [this](const std::string& n) { sink.notes.push_back(n); }});
    bus.set_host({[this](const CanFrame& f) {
                    master->OnFrame(f);
                    if (pipeline) pipeline->OnFrame(f);
                  },
                  [this](std::int64_t t) {
                    master->OnTime(t);
                    if (!pipeline && master->phase() == CanopenMaster::Phase::kRunning) {
                      pipeline = std::make_unique<AcquisitionPipeline>(pc, sink.Callbacks());
                      bus.ProduceSync(t + 10 * kMs, 10 * kMs, pc.sync_counter_max);
                    }
                  },
                  [this] { return master->NextDeadline(); }});
  }
  static DeviceSimConfig Prepare(DeviceSimConfig sc, std::uint8_t counter_max) {
    sc.spec.pattern = GridPattern(6, 2);
    sc.stop_s = 0.5;
    sc.move_s = 0.2;
    sc.start_time_s = static_cast<double>(kT0) * 1e-9;
    sc.sync_period_s = 0.01;
    sc.start_operational = false;
    sc.devices.sync_counter_max = counter_max;
    return sc;
  }
  // Every sample equals what the devices sent for the SYNC of its time.
  void ExpectEverySampleIsItsCycle() const {
    std::map<std::int64_t, const SimCycleRecord*> by_time;
    for (const SimCycleRecord& r : sim.records()) by_time[r.sync_ns] = &r;
    for (const Sample& s : sink.samples) {
      const auto t = static_cast<std::int64_t>(std::llround(s.t_s * 1e9));
      auto it = by_time.lower_bound(t - 5000);  // t_s is a double: within 5 us
      ASSERT_NE(it, by_time.end());
      ASSERT_LT(std::llabs(it->first - t), 5000) << s.t_s;
      const SimCycleRecord& r = *it->second;
      ASSERT_TRUE(r.sent[kTheta] && r.sent[kPhi] && r.sent[kProbe]) << s.t_s;
      EXPECT_EQ(s.theta_deg, r.value[kTheta]) << s.t_s;
      EXPECT_EQ(s.phi_deg, r.value[kPhi]) << s.t_s;
      EXPECT_EQ(s.r_mm, r.value[kProbe]) << s.t_s;
    }
  }

  DeviceSimulator sim;
  PipelineConfig pc;
  testing::SimBus bus;
  std::unique_ptr<CanopenMaster> master;
  std::unique_ptr<AcquisitionPipeline> pipeline;
  Sink sink;
};

TEST(SyncWindowOnTheBus, ANodeRebootingMidRunIsRestartedAndNoSampleIsMisassigned) {
  for (const std::uint8_t counter : {std::uint8_t{0}, std::uint8_t{240}}) {
    DeviceSimConfig sc;
    sc.faults.reboots = {{1, 3.0}, {3, 4.5}};
    sc.faults.drop_probability = 0.02;
    sc.faults.sync_drop_probability = 0.0;
    Acquisition a(sc, counter);
    a.master->Begin(kT0);
    a.bus.RunUntil(kT0 + 12000 * kMs);
    ASSERT_NE(a.pipeline, nullptr);
    a.pipeline->Finish();
    EXPECT_EQ(a.master->counts().restarts, 2U);
    EXPECT_EQ(a.pipeline->counts().reboots, 2U);
    EXPECT_GT(a.sink.samples.size(), 500U);
    a.ExpectEverySampleIsItsCycle();
    int starts = 0, ends = 0;
    for (const std::string& n : a.sink.notes) {
      starts += n.rfind("gap start t_s ", 0) == 0;
      ends += n.rfind("gap end t_s ", 0) == 0;
    }
    EXPECT_EQ(starts, 2);
    EXPECT_EQ(ends, 2);
    // Every cycle the devices answered in full is a sample: none was lost.
    std::uint64_t complete = 0;
    for (const SimCycleRecord& r : a.sim.records()) complete += r.sent[0] && r.sent[1] && r.sent[2];
    EXPECT_EQ(a.sink.samples.size(), complete);
  }
}

TEST(SyncWindowOnTheBus, KernelDropsAndLostSyncsNeverPairTheWrongPdos) {
  // Follow mode's view: the daemon sees what the bus had, minus random frames (SYNCs too).
  DeviceSimConfig sc;
  sc.spec.pattern = GridPattern(6, 2);
  sc.stop_s = 0.5;
  sc.move_s = 0.2;
  sc.sync_period_s = 0.01;
  sc.devices.sync_counter_max = 0;
  sc.faults.drop_probability = 0.03;
  sc.faults.sync_drop_probability = 0.05;
  DeviceSimulator sim(sc);
  sim.set_recording(true);
  PipelineConfig pc = sc.devices;
  pc.sync_period_s = 0.01;
  Sink sink;
  AcquisitionPipeline p(pc, sink.Callbacks());
  std::vector<CanFrame> frames;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  while (sim.NextCycle(frames)) {
    for (const CanFrame& f : frames) {
      if (u(rng) < 0.01) {
        p.OnRxOverflow(1, f.t_ns);  // the kernel dropped this one
        continue;
      }
      p.OnFrame(f);
    }
    frames.clear();
  }
  p.Finish();
  std::map<std::int64_t, const SimCycleRecord*> by_time;
  for (const SimCycleRecord& r : sim.records()) by_time[r.sync_ns] = &r;
  ASSERT_GT(sink.samples.size(), 500U);
  for (const Sample& s : sink.samples) {
    const auto t = static_cast<std::int64_t>(std::llround(s.t_s * 1e9));
    auto it = by_time.lower_bound(t - 5000);
    ASSERT_NE(it, by_time.end());
    ASSERT_LT(std::llabs(it->first - t), 5000);
    EXPECT_EQ(s.theta_deg, it->second->value[kTheta]);
    EXPECT_EQ(s.r_mm, it->second->value[kProbe]);
  }
  EXPECT_GT(p.counts().recovered, 0U);
}

}  // namespace
}  // namespace sph::can
