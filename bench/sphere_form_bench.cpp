// Cost of the sphere evaluation of sph_measure on large point sets: the geometric least-squares
// fit and the minimum-zone sphere (from the least-squares centre), full sphere and hemisphere.
//
//   build/bench/sphere_form_bench --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
//
// The points: directions uniform over the sphere (or upper hemisphere), radius 20 mm, a smooth
// form error of about 2 um peak to valley plus 0.1 um of noise, centre (2, 0, 0) mm, seed 1.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "sph/sphere/sphere_fit.hpp"
#include "sph/sphere/sphere_form.hpp"

namespace {

std::vector<Eigen::Vector3d> FormedSphere(int n, bool hemisphere) {
  std::mt19937 rng(1);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d u = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    if (hemisphere) u.z() = std::abs(u.z());
    const double form_mm = 1e-3 * (std::sin(3.0 * u.x()) * u.y() + 0.5 * u.z() * u.z()) + 1e-4 * g(rng);
    pts.push_back(Eigen::Vector3d(2.0, 0.0, 0.0) + (20.0 + form_mm) * u);
  }
  return pts;
}

void BM_LeastSquaresSphere(benchmark::State& state) {
  const auto pts = FormedSphere(static_cast<int>(state.range(0)), state.range(1) != 0);
  for (auto _ : state) {
    const sph::LeastSquaresSphere fit = sph::FitSphereLeastSquares(pts);
    benchmark::DoNotOptimize(fit.sphere.radius);
  }
  state.counters["points"] = static_cast<double>(pts.size());
}
BENCHMARK(BM_LeastSquaresSphere)->Args({10000, 0})->Args({10000, 1})->Unit(benchmark::kMillisecond);

// The minimum-zone width alone, started at the least-squares centre (computed once, outside).
void BM_MinimumZoneSphere(benchmark::State& state) {
  const auto pts = FormedSphere(static_cast<int>(state.range(0)), state.range(1) != 0);
  const Eigen::Vector3d start = sph::FitSphereLeastSquares(pts).sphere.center;
  sph::MinimumZoneSphere mz;
  for (auto _ : state) {
    mz = sph::FitSphereMinimumZone(pts, start);
    benchmark::DoNotOptimize(mz.width);
  }
  state.counters["points"] = static_cast<double>(pts.size());
  state.counters["width_um"] = mz.width * 1e3;
  state.counters["lp_steps"] = mz.iterations;
  state.counters["lp_iterations"] = mz.lp_iterations;
}
BENCHMARK(BM_MinimumZoneSphere)
    ->Args({1000, 0})
    ->Args({10000, 0})
    ->Args({10000, 1})
    ->Args({100000, 0})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
