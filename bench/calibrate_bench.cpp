// Cost of one calibration at the paper's settings (288 points, 2 mm eccentricity, 0.05 um noise).
//
//   build/bench/calibrate_bench --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <sstream>
#include <string>

#include "sph/calib/calibrate_workflow.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/io/calibration_file.hpp"
#include "sph/io/points_file.hpp"
#include "sph/simulation/simulate.hpp"
#include "study_designs.hpp"

namespace {

sph::PointsData Data(int theta_steps, int phi_steps) {
  sph::SimulationSpec spec;
  spec.pattern = sph::GridPattern(theta_steps, phi_steps);
  return sph::Simulate(spec);
}

sph::CalibrationOptions Options(bool analyse) {
  sph::CalibrationOptions o;
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  o.analyse = analyse;
  return o;
}

// Calibrations of `data`, one per benchmark iteration, with their points and LM iterations.
void RunCalibrations(benchmark::State& state, const sph::PointsData& data, const sph::CalibrationOptions& o) {
  int iterations = 0;
  for (auto _ : state) {
    const sph::CalibrationResult r = sph::Calibrate(data, o);
    iterations = r.iterations;
    benchmark::DoNotOptimize(r.geometry);
  }
  state.counters["points"] = static_cast<double>(data.samples.size());
  state.counters["lm_iterations"] = iterations;
}

// Solve only: problem building and the solve.
void BM_CalibrateSolve(benchmark::State& state) {
  RunCalibrations(state, Data(static_cast<int>(state.range(0)), static_cast<int>(state.range(1))), Options(false));
}
BENCHMARK(BM_CalibrateSolve)->Args({24, 12})->Args({48, 24})->Args({96, 48})->Unit(benchmark::kMillisecond);

// Everything sph_calibrate computes: solve, residuals, covariance, observability.
void BM_CalibrateFull(benchmark::State& state) {
  const sph::PointsData data = Data(24, 12);
  const sph::CalibrationOptions o = Options(true);
  for (auto _ : state) {
    const sph::CalibrationResult r = sph::Calibrate(data, o);
    benchmark::DoNotOptimize(r.analysis.std);
  }
}
BENCHMARK(BM_CalibrateFull)->Unit(benchmark::kMillisecond);

// Growth over the number of setups: calibrations of `setups` placements of 12 readings each, with
// the analysis and the outlier rule (what sph_calibrate --no-trace computes), which eliminate
// each setup's centre first (a Schur complement): the cost grows with the setups, not their cube.
void BM_CalibrateSetups(benchmark::State& state) {
  const sph::PointsData data = sph::Simulate(sph::bench::ManySetups(static_cast<int>(state.range(0))));
  RunCalibrations(state, data, Options(true));
  state.counters["setups"] = static_cast<double>(state.range(0));
}
BENCHMARK(BM_CalibrateSetups)->Arg(25)->Arg(50)->Arg(100)->Arg(200)->Unit(benchmark::kMillisecond);

// Solve only, of the points file named by SPH_BENCH_POINTS (its header's R0 and d): the same data
// another implementation is timed on (bench/peer_scipy.sh). Registered only when it is set.
void BM_CalibrateFile(benchmark::State& state, const std::string& path) {
  const sph::PointsData data = sph::ReadPointsFile(path);
  sph::CalibrationOptions o = Options(false);
  o.sphere_radius_mm = data.header.sphere_radius_mm.value_or(o.sphere_radius_mm);
  o.probe_offset_mm = data.header.probe_offset_mm.value_or(o.probe_offset_mm);
  RunCalibrations(state, data, o);
}

// The workflow of sph_calibrate on the points file named by SPH_BENCH_POINTS, with its three
// outputs rendered: what the Python module's sph.calibrate(path) does in C++ (bench/python_overhead.py
// compares the two). Registered only when it is set.
void BM_CalibrateWorkflowFile(benchmark::State& state, const std::string& path) {
  for (auto _ : state) {
    const sph::CalibrationWorkflowResult run = sph::RunCalibrationWorkflow(path, {});
    std::ostringstream text, file;
    run.WriteTextReport(text);
    if (run.usability.usable) sph::WriteCalibration(file, run.MakeCalibrationFile());
    benchmark::DoNotOptimize(run.JsonReport());
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (const char* path = std::getenv("SPH_BENCH_POINTS")) {
    benchmark::RegisterBenchmark("BM_CalibrateFile", BM_CalibrateFile, std::string(path))
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark("BM_CalibrateWorkflowFile", BM_CalibrateWorkflowFile, std::string(path))
        ->Unit(benchmark::kMillisecond);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
