// Cost of tracing the residual: the trace that sph_calibrate runs by default.
//
//   build/bench/trace_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "peak_rss.hpp"
#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"
#include "sph/select/trace.hpp"
#include "study_designs.hpp"

namespace {

sph::CalibrationOptions Options() {
  sph::CalibrationOptions o;
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  return o;
}

// The paper's study (one position, no further effect), or the example with undeclared effects
// (two positions, a Theta encoder error and a probe drift: two effects added).
sph::PointsData Data(bool undeclared) {
  sph::SimulationSpec spec;
  if (undeclared) {
    spec.seed = 7;
    spec.centers_mm = {Eigen::Vector3d(2.0, 0.0, 0.0), Eigen::Vector3d(0.0, -3.0, 0.5)};
    spec.effects.model.terms = {{sph::Effect::kThetaEncoder, {{2, 0, false}, {3, 0, true}}},
                                {sph::Effect::kProbeDrift, {{1, 0, false}}}};
    spec.effects.values = {{6 * sph::kRadPerArcsec, -4 * sph::kRadPerArcsec}, {0.6 * sph::kMmPerUm}};
  }
  return sph::Simulate(spec);
}

// Seven-error calibration, then the whole trace: every candidate with its pruning and 5-fold
// cross-validation, round after round.
void BM_Trace(benchmark::State& state) {
  const sph::PointsData data = Data(state.range(0) != 0);
  const sph::CalibrationOptions o = Options();
  sph::TraceOptions trace;
  trace.threads = static_cast<int>(state.range(1));
  std::size_t added = 0;
  for (auto _ : state) {
    const sph::CalibrationResult base = sph::Calibrate(data, o);
    const sph::TraceResult r = sph::TraceResidual(data, o, base, trace);
    added = r.added.size();
    benchmark::DoNotOptimize(r.after.cv_rms_um);
  }
  state.counters["points"] = static_cast<double>(data.samples.size());
  state.counters["effects_added"] = static_cast<double>(added);
}
BENCHMARK(BM_Trace)->ArgsProduct({{0, 1}, {1, 2}})->ArgNames({"undeclared", "threads"})->Unit(benchmark::kMillisecond);

// The trace of the paper's study on the 96 x 48 grid (4608 points), 2 threads, and its memory:
// peak_rss_MB is the process' peak, its own when run alone (--benchmark_filter=BM_Trace4608).
void BM_Trace4608(benchmark::State& state) {
  sph::SimulationSpec spec;
  spec.pattern = sph::GridPattern(96, 48);
  const sph::PointsData data = sph::Simulate(spec);
  const sph::CalibrationOptions o = Options();
  sph::TraceOptions trace;
  trace.threads = 2;
  for (auto _ : state) {
    const sph::CalibrationResult base = sph::Calibrate(data, o);
    const sph::TraceResult r = sph::TraceResidual(data, o, base, trace);
    benchmark::DoNotOptimize(r.after.cv_rms_um);
  }
  state.counters["points"] = static_cast<double>(data.samples.size());
  state.counters["peak_rss_MB"] = sph::bench::PeakRssMb();
}
BENCHMARK(BM_Trace4608)->UseRealTime()->Unit(benchmark::kMillisecond);

// A separation: the sphere in five orientations on its mount (turned by 90 and 180 deg about z,
// tilted by 90 deg about x and y), 288 points each (1440 in all), each setup in another scan
// order, with a form of 0.05 um rms of degrees 2..8, a Theta encoder error of 5 arcsec at 3 per
// turn and a probe drift of 0.4 um: the form's degree chosen, the effects found beside it, 2 threads.
void BM_Trace1440FiveOrientations(benchmark::State& state) {
  sph::SimulationSpec spec;
  spec.seed = 3;
  spec.centers_mm = std::vector<Eigen::Vector3d>(5, Eigen::Vector3d(2.0, 0.0, 0.0));
  spec.mount_rotations_deg = {{1, {0, 0, 90}}, {2, {0, 0, 180}}, {3, {90, 0, 0}}, {4, {0, 90, 0}}};
  spec.scan_orders = {{1, sph::ScanOrder::kSerpentine},
                      {2, sph::ScanOrder::kColumns},
                      {3, sph::ScanOrder::kReversed},
                      {4, sph::ScanOrder::kShuffled}};
  spec.effects.model.terms = {{sph::Effect::kThetaEncoder, {{3, 0, false}}},
                              {sph::Effect::kProbeDrift, {{1, 0, false}}}};
  spec.effects.values = {{5 * sph::kRadPerArcsec}, {0.4 * sph::kMmPerUm}};
  spec.effects.form = sph::bench::Form28();
  const sph::PointsData data = sph::Simulate(spec);
  const sph::CalibrationOptions o = Options();
  sph::TraceOptions trace;
  trace.threads = 2;
  std::size_t added = 0;
  int degree = 0;
  for (auto _ : state) {
    const sph::CalibrationResult base = sph::Calibrate(data, o);
    const sph::TraceResult r = sph::TraceResidual(data, o, base, trace);
    added = r.added.size();
    degree = r.form.degree_max;
    benchmark::DoNotOptimize(r.after.cv_rms_um);
  }
  state.counters["points"] = static_cast<double>(data.samples.size());
  state.counters["effects_added"] = static_cast<double>(added);
  state.counters["form_degree"] = degree;
  state.counters["peak_rss_MB"] = sph::bench::PeakRssMb();
}
BENCHMARK(BM_Trace1440FiveOrientations)->UseRealTime()->Unit(benchmark::kMillisecond);

// Growth over the number of setups: the seven-error calibration and its trace (what sph_calibrate
// computes by default) of `setups` placements of 12 readings each (the 200 setups: 2400 readings).
void BM_TraceSetups(benchmark::State& state) {
  const sph::PointsData data = sph::Simulate(sph::bench::ManySetups(static_cast<int>(state.range(0))));
  const sph::CalibrationOptions o = Options();
  sph::TraceOptions trace;
  trace.threads = 2;
  for (auto _ : state) {
    const sph::CalibrationResult base = sph::Calibrate(data, o);
    const sph::TraceResult r = sph::TraceResidual(data, o, base, trace);
    benchmark::DoNotOptimize(r.after.cv_rms_um);
  }
  state.counters["setups"] = static_cast<double>(state.range(0));
}
BENCHMARK(BM_TraceSetups)->Arg(25)->Arg(50)->Arg(100)->Arg(200)->UseRealTime()->Unit(benchmark::kMillisecond);

// One fit with one effect term of 6 parameters (Theta encoder harmonics 2..4), with the analysis.
void BM_FitOneEffect(benchmark::State& state) {
  const sph::PointsData data = Data(false);
  const sph::CalibrationOptions o = Options();
  const sph::CalibrationResult base = sph::Calibrate(data, o);
  sph::EffectModel model;
  model.terms = {sph::DefaultTerm(sph::Effect::kThetaEncoder, 4, 2)};
  model.terms[0].components.erase(model.terms[0].components.begin(), model.terms[0].components.begin() + 2);
  model.reference = sph::EffectReferenceOf(data.samples);
  for (auto _ : state) {
    const sph::EffectFit fit = sph::FitEffects(data, o, model, sph::EffectFitStart::From(base));
    benchmark::DoNotOptimize(fit.rss_mm2);
  }
}
BENCHMARK(BM_FitOneEffect)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
