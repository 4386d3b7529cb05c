// Throughput of the acquisition pipeline: how many CAN frames per second it turns into samples,
// from frames in memory (also with lost SYNCs, whose windows are split into their cycles) and from
// candump log lines (the replay path without file I/O); and the cost of one SDO transfer between
// the client and a server in memory (the master's identification).
//
//   build/bench/can_pipeline_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "sph/can/candump_log.hpp"
#include "sph/can/device_sim.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/can/sdo.hpp"
#include "sph/can/sdo_server.hpp"

namespace {

// Traffic of a simulated SCMS at 1 kHz SYNC: three devices, 24 x 2 pattern points, heartbeats;
// with `sync_drop`, that share of the SYNCs is missing (their PDOs still come).
std::vector<sph::can::CanFrame> MakeTraffic(double sync_drop) {
  sph::can::DeviceSimConfig config;
  config.spec.pattern = sph::GridPattern(24, 2);
  config.sync_period_s = 0.001;
  config.devices.sync_period_s = 0.001;
  config.stop_s = 0.3;
  config.move_s = 0.2;
  config.faults.sync_drop_probability = sync_drop;
  sph::can::DeviceSimulator sim(config);
  std::vector<sph::can::CanFrame> all;
  while (sim.NextCycle(all)) {  // appends the cycle's frames
  }
  return all;
}

const std::vector<sph::can::CanFrame>& Traffic() {
  static const std::vector<sph::can::CanFrame> frames = MakeTraffic(0.0);
  return frames;
}

sph::can::PipelineConfig Config(sph::can::Mode mode) {
  sph::can::PipelineConfig c;
  c.sync_period_s = 0.001;
  c.mode = mode;
  return c;
}

void BM_PipelineFrames(benchmark::State& state) {
  const auto& frames = Traffic();
  const auto mode = state.range(0) == 0 ? sph::can::Mode::kStream : sph::can::Mode::kPoints;
  std::uint64_t samples = 0, losses = 0;
  for (auto _ : state) {
    sph::can::AcquisitionPipeline pipeline(Config(mode), {[&](const sph::Sample&) { ++samples; }, {}, {}});
    for (const auto& f : frames) pipeline.OnFrame(f);
    pipeline.Finish();
    losses += pipeline.counts().Losses();
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(frames.size() * state.iterations()), benchmark::Counter::kIsRate);
  state.counters["losses"] = static_cast<double>(losses);
  state.SetLabel(mode == sph::can::Mode::kStream ? "stream" : "points");
  benchmark::DoNotOptimize(samples);
}
BENCHMARK(BM_PipelineFrames)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// 1 % of the SYNCs lost: their cycles are recovered from the PDOs split out of the windows.
void BM_PipelineLostSyncs(benchmark::State& state) {
  static const std::vector<sph::can::CanFrame> frames = MakeTraffic(0.01);
  std::uint64_t samples = 0, recovered = 0;
  for (auto _ : state) {
    sph::can::AcquisitionPipeline pipeline(Config(sph::can::Mode::kStream),
                                           {[&](const sph::Sample&) { ++samples; }, {}, {}});
    for (const auto& f : frames) pipeline.OnFrame(f);
    pipeline.Finish();
    recovered += pipeline.counts().recovered;
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(frames.size() * state.iterations()), benchmark::Counter::kIsRate);
  state.counters["recovered"] = static_cast<double>(recovered) / static_cast<double>(state.iterations());
  benchmark::DoNotOptimize(samples);
}
BENCHMARK(BM_PipelineLostSyncs)->Unit(benchmark::kMillisecond);

// One SDO upload of `bytes` bytes (expedited up to 4, else segmented) from a server in memory.
void BM_SdoUpload(benchmark::State& state) {
  sph::can::ObjectDictionary od;
  od.Set({0x1008, 0}, std::vector<std::uint8_t>(static_cast<std::size_t>(state.range(0)), 'a'));
  sph::can::SdoServer server(1, &od);
  sph::can::SdoClient client(1, 500000000);
  std::size_t frames = 0;
  for (auto _ : state) {
    sph::can::CanFrame f = client.StartUpload({0x1008, 0}, 0);
    for (;;) {
      const sph::can::SdoClient::Step s = client.OnFrame(*server.OnRequest(f));
      frames += 2;
      if (s.status != sph::can::SdoClient::Status::kContinue) break;
      f = s.frame;
    }
    benchmark::DoNotOptimize(client.data().data());
  }
  state.counters["frames_per_transfer"] = static_cast<double>(frames) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_SdoUpload)->Arg(4)->Arg(24)->Unit(benchmark::kNanosecond);

void BM_ReplayLines(benchmark::State& state) {
  std::vector<std::string> lines;
  for (const auto& f : Traffic()) lines.push_back(sph::can::FormatCandumpLine(f, "can0"));
  std::uint64_t samples = 0;
  for (auto _ : state) {
    sph::can::AcquisitionPipeline pipeline(Config(sph::can::Mode::kStream),
                                           {[&](const sph::Sample&) { ++samples; }, {}, {}});
    sph::can::CanFrame frame;
    std::string iface, error;
    for (const auto& line : lines) {
      if (sph::can::ParseCandumpLine(line, frame, iface, error)) pipeline.OnFrame(frame);
    }
    pipeline.Finish();
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(lines.size() * state.iterations()), benchmark::Counter::kIsRate);
  benchmark::DoNotOptimize(samples);
}
BENCHMARK(BM_ReplayLines)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
