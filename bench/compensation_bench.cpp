// Compensation per point on the host (sph/model/compensation.hpp), with the seven errors alone and
// with effects of every kind but the probe's incidence and drift, in batches of 1152 readings (the
// grid of data/example/separation). Header-only and written against the API that has not changed,
// so that bench/compensation_before_after.sh builds it against an earlier commit too and runs both
// side by side. `--checksum` prints the bits of every point instead, to compare two builds;
// `--repeat N` compensates N batches with the effects, a fixed work for `perf stat`.
#include <benchmark/benchmark.h>

#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "sph/model/compensation.hpp"

namespace {

sph::Calibration MakeCalibration(bool effects) {
  sph::Calibration cal;
  cal.geometry = {3.49e-4, 0.002, 3.49e-4, 0.002, 3.49e-4, 0.002, -0.062};
  cal.probe_offset_mm = 25.0;
  if (!effects) return cal;
  cal.effects.reference.r_ref_mm = 4.94;
  cal.effects.reference.r_half_range_mm = 1.98;
  cal.effects.phi_wobble_pivot_mm = 80.0;
  const sph::Effect kinds[] = {sph::Effect::kThetaEncoder,      sph::Effect::kPhiEncoder,
                               sph::Effect::kThetaRadialMotion, sph::Effect::kThetaAxialMotion,
                               sph::Effect::kPhiWobble,         sph::Effect::kProbeGain,
                               sph::Effect::kProbeNonlinearity, sph::Effect::kPhiRadialMotion,
                               sph::Effect::kPhiAxialMotion,    sph::Effect::kThetaTiltMotion};
  double v = 1e-6;
  for (const sph::Effect e : kinds) {
    const sph::EffectTerm term = sph::DefaultTerm(e, 3);
    cal.effects.terms.push_back(term);
    std::vector<double> values;
    for (std::size_t i = 0; i < term.components.size(); ++i) values.push_back(v *= -1.07);
    cal.effect_values.push_back(values);
  }
  return cal;
}

std::vector<sph::RawReading> Readings() {
  std::vector<sph::RawReading> readings;
  for (int k = 0; k < 4; ++k) {
    for (int i = 0; i < 24; ++i) {
      for (int j = 0; j < 12; ++j) readings.push_back({15.0 * i, 7.5 + 15.0 * j, 3.0 + 0.4 * k + 0.01 * j});
    }
  }
  return readings;
}

void BM_Compensate(benchmark::State& state) {
  const sph::Calibration cal = MakeCalibration(state.range(0) != 0);
  const std::vector<sph::RawReading> readings = Readings();
  std::vector<Eigen::Vector3d> points(readings.size());
  for (auto _ : state) {
    sph::Compensate(cal, readings.data(), readings.size(), points.data());
    benchmark::DoNotOptimize(points.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * readings.size()));
  state.counters["s_per_point"] = benchmark::Counter(static_cast<double>(state.iterations() * readings.size()),
                                                      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_Compensate)->ArgName("effects")->Arg(0)->Arg(1);

int Checksum() {
  for (const bool effects : {false, true}) {
    const sph::Calibration cal = MakeCalibration(effects);
    const std::vector<sph::RawReading> readings = Readings();
    std::vector<Eigen::Vector3d> points(readings.size());
    sph::Compensate(cal, readings.data(), readings.size(), points.data());
    std::uint64_t hash = 1469598103934665603ull;  // FNV-1a over the bits of every coordinate
    for (const Eigen::Vector3d& p : points) {
      for (int c = 0; c < 3; ++c) {
        std::uint64_t bits;
        std::memcpy(&bits, &p[c], sizeof bits);
        for (int b = 0; b < 8; ++b) hash = (hash ^ ((bits >> (8 * b)) & 0xFF)) * 1099511628211ull;
      }
    }
    std::printf("effects=%d points=%zu fnv1a=%016" PRIx64 "\n", effects ? 1 : 0, points.size(), hash);
  }
  return 0;
}

/// A fixed amount of work, for counters of instructions and cycles (perf stat): `rounds` batches
/// with the effects.
int Repeat(int rounds) {
  const sph::Calibration cal = MakeCalibration(true);
  const std::vector<sph::RawReading> readings = Readings();
  std::vector<Eigen::Vector3d> points(readings.size());
  double sum = 0.0;
  for (int i = 0; i < rounds; ++i) {
    sph::Compensate(cal, readings.data(), readings.size(), points.data());
    sum += points[static_cast<std::size_t>(i) % points.size()][0];
  }
  std::printf("%d batches of %zu points, sum %.17g\n", rounds, readings.size(), sum);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 2 && std::strcmp(argv[1], "--checksum") == 0) return Checksum();
  if (argc == 3 && std::strcmp(argv[1], "--repeat") == 0) return Repeat(std::atoi(argv[2]));
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
