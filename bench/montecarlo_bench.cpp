// Wall time of the Monte Carlo study (calibrations only; no Table 3, no figures).
//
//   build/bench/montecarlo_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// peak_rss_MB is the process' peak: BM_DefaultStudy/2 runs first, so its figure is its own.
#include <benchmark/benchmark.h>

#include "peak_rss.hpp"
#include "sph/calib/montecarlo.hpp"

namespace {

// The default study: 4 eccentricities x 1000 calibrations of 288 points, on all cores.
void BM_DefaultStudy(benchmark::State& state) {
  sph::MonteCarloStudyOptions spec;
  spec.threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    const sph::MonteCarloStudy r = sph::RunMonteCarlo(spec);
    benchmark::DoNotOptimize(r.rows.data());
  }
  state.counters["calibrations_per_s"] =
      benchmark::Counter(4000.0 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["peak_rss_MB"] = sph::bench::PeakRssMb();
}
BENCHMARK(BM_DefaultStudy)->Arg(2)->Arg(1)->Iterations(1)->UseRealTime()->Unit(benchmark::kMillisecond);

// 200 calibrations at 2 mm with theta_steps x phi_steps points, on `threads` threads.
void BM_StudyPoints(benchmark::State& state) {
  sph::MonteCarloStudyOptions spec;
  spec.eccentricities_mm = {2.0};
  spec.trials = 200;
  spec.base.pattern = sph::GridPattern(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  spec.threads = static_cast<int>(state.range(2));
  for (auto _ : state) {
    const sph::MonteCarloStudy r = sph::RunMonteCarlo(spec);
    benchmark::DoNotOptimize(r.rows.data());
  }
  state.counters["points"] = static_cast<double>(spec.base.pattern.size());
  state.counters["calibrations_per_s"] =
      benchmark::Counter(200.0 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_StudyPoints)
    ->Args({24, 12, 1})
    ->Args({48, 24, 1})
    ->Args({96, 48, 1})
    ->Args({24, 12, 2})
    ->Args({48, 24, 2})
    ->Args({96, 48, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// Growth over the number of placements: 2 calibrations of `setups` placements of the paper's 288
// readings at 2 mm (sph_montecarlo --trials 2 --no-table3 --setups N --eccentricities-mm 2), each
// with the prediction of its design (PredictUncertainty(), through the block structure of the
// Jacobian), on 2 threads.
void BM_StudySetups(benchmark::State& state) {
  sph::MonteCarloStudyOptions spec;
  spec.eccentricities_mm = {2.0};
  spec.trials = 2;
  spec.setups = static_cast<int>(state.range(0));
  spec.threads = 2;
  for (auto _ : state) {
    const sph::MonteCarloStudy r = sph::RunMonteCarlo(spec);
    benchmark::DoNotOptimize(r.rows.data());
  }
  state.counters["setups"] = static_cast<double>(spec.setups);
  state.counters["peak_rss_MB"] = sph::bench::PeakRssMb();
}
BENCHMARK(BM_StudySetups)->Arg(25)->Arg(50)->Arg(100)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
