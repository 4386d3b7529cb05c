// What the study and benchmark programs simulate in common.
#ifndef SPH_BENCH_STUDY_DESIGNS_HPP_
#define SPH_BENCH_STUDY_DESIGNS_HPP_

#include <cmath>
#include <utility>
#include <vector>

#include "sph/simulation/simulate.hpp"
#include "sph/model/units.hpp"

namespace sph::bench {

/// form28: a form of the sphere of 0.050 um rms of degrees 2..8 on its body frame (the same terms
/// as bench/separation_study.sh's form28).
inline const std::vector<FormComponent>& Form28() {
  static const std::vector<FormComponent> form{
      {2, 0, 0.062},  {2, 2, -0.049}, {3, 1, 0.049},  {3, -3, 0.037}, {4, 0, -0.043}, {4, 2, 0.031}, {5, -2, 0.037},
      {5, 4, -0.025}, {6, 1, 0.031},  {6, -5, 0.025}, {7, 3, -0.025}, {8, 0, 0.025},  {8, -6, 0.019}};
  return form;
}

/// Two setups of the paper's pattern with the sphere at (2, 0, 0) mm, in one known orientation and
/// remounted in one the file calls unknown (turned by 90 deg about y, scanned in serpentine): the
/// second setup's form is its own.
inline void KnownAndUnknown(SimulationSpec& spec) {
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(2, 0, 0)};
  spec.mount_rotations_deg[1] = Eigen::Vector3d(0, 90, 0);
  spec.mount_unknown.insert(1);
  spec.scan_orders[1] = ScanOrder::kSerpentine;
}

/// Many small setups: the 4 x 3 grid (12 readings) in each of `setups` placements of the sphere at
/// 2 mm eccentricity, setup k turned by 7 k 360 / setups deg about the Theta axis and at height
/// 0.3 (k mod 9 - 4) mm: what an acquisition that starts a setup every few readings gives.
inline SimulationSpec ManySetups(int setups) {
  SimulationSpec spec;
  spec.pattern = GridPattern(4, 3);
  spec.seed = 5;
  spec.centers_mm.clear();
  for (int k = 0; k < setups; ++k) {
    const double a = 7.0 * 2.0 * kPi * k / setups;
    spec.centers_mm.emplace_back(2.0 * std::cos(a), 2.0 * std::sin(a), 0.3 * (k % 9 - 4));
  }
  return spec;
}

// P(X <= k) for X ~ Binomial(n, p), 0 < p < 1.
inline double BinomialCdf(int k, int n, double p) {
  double sum = 0.0;
  for (int i = 0; i <= k; ++i) {
    sum += std::exp(std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0) + i * std::log(p) +
                    (n - i) * std::log1p(-p));
  }
  return sum;
}

// The p at which `f`, falling in p, equals `target`, by bisection on (0, 1).
template <typename F>
double Solve(F f, double target) {
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) > target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// The exact (Clopper-Pearson) two-sided 95 % interval of a binomial rate, k of n: the p at which
// P(X >= k) = 2.5 % and the p at which P(X <= k) = 2.5 % (each CDF falls as p rises).
inline std::pair<double, double> ClopperPearson(int k, int n) {
  const double lo = k == 0 ? 0.0 : Solve([&](double p) { return BinomialCdf(k - 1, n, p); }, 0.975);
  const double hi = k == n ? 1.0 : Solve([&](double p) { return BinomialCdf(k, n, p); }, 0.025);
  return {lo, hi};
}

}  // namespace sph::bench

#endif  // SPH_BENCH_STUDY_DESIGNS_HPP_
