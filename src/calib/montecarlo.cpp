#include "sph/calib/montecarlo.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>

#include "calibrate_rows.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/calib/design.hpp"
#include "sph/core/cancellation.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/parallel.hpp"
#include "sph/model/units.hpp"
#include "sph/sphere/sphere_fit.hpp"
#include "sph/sphere/sphere_form.hpp"
#include "sph/stats/gum.hpp"

namespace sph {
namespace {

std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

// Centres of one trial: `setups` placements at eccentricity e, random or the fixed design.
std::vector<Eigen::Vector3d> Centers(const MonteCarloStudyOptions& spec, double e_mm, std::uint64_t trial_seed) {
  std::vector<Eigen::Vector3d> out;
  if (spec.random_direction) {
    Random rng(SplitMix64(trial_seed ^ 0xD1B54A32D192ED03ULL));
    for (int j = 0; j < spec.setups; ++j) {
      const double x = rng.Normal(), y = rng.Normal(), z = rng.Normal();  // in this order on every compiler
      Eigen::Vector3d u(x, y, z);
      out.push_back(e_mm * u.normalized());
    }
    return out;
  }
  return PlacementCenters(spec, e_mm);
}

}  // namespace

std::vector<Eigen::Vector3d> PlacementCenters(const MonteCarloStudyOptions& spec, double e_mm) {
  std::vector<Eigen::Vector3d> out;
  const Eigen::Vector3d d = spec.direction.normalized();
  for (int j = 0; j < spec.setups; ++j) {
    const double a = 2.0 * kPi * j / spec.setups;
    out.emplace_back(e_mm * (std::cos(a) * d.x() - std::sin(a) * d.y()),
                     e_mm * (std::sin(a) * d.x() + std::cos(a) * d.y()), e_mm * d.z());
  }
  return out;
}

std::uint64_t TrialSeed(std::uint64_t seed, std::size_t k, std::size_t t) {
  return SplitMix64(SplitMix64(SplitMix64(seed) + k) + t);
}

namespace {

// What one trial leaves for the statistics.
struct Trial {
  ScmsGeometry geometry{};
  bool converged = false;
  // Random directions: this trial's predicted std and bias (its own design).
  std::array<double, kNumScmsParams> crlb{}, bias{};
};

// The exact readings of each eccentricity, when every trial measures the same placements (empty
// readings with random directions, where each trial has its own).
std::vector<PointsData> ExactReadings(const MonteCarloStudyOptions& spec) {
  std::vector<PointsData> exact(spec.eccentricities_mm.size());
  if (spec.random_direction) return exact;
  for (std::size_t k = 0; k < exact.size(); ++k) {
    SimulationSpec s = spec.base;
    s.centers_mm = PlacementCenters(spec, spec.eccentricities_mm[k]);
    exact[k] = SimulateExact(s);
  }
  return exact;
}

// What a thread keeps from trial to trial: the readings' table of each eccentricity (with fixed
// placements and no noise on the angles only r changes, so its sines and cosines are kept).
struct TrialScratch {
  explicit TrialScratch(std::size_t n_ecc) : tables(n_ecc) {}
  std::vector<std::unique_ptr<internal::ReadingTable>> tables;
};

// Trial t of eccentricity index k: its noisy readings, calibrated. `exact`: ExactReadings().
Trial RunTrial(const MonteCarloStudyOptions& spec, std::size_t k, std::size_t t, const std::vector<PointsData>& exact,
               TrialScratch& scratch) {
  CalibrationOptions copts;
  copts.sphere_radius_mm = spec.base.sphere_radius_mm;
  copts.probe_offset_mm = spec.base.probe_offset_mm;
  copts.analyse = false;
  const bool fixed_angles =
      !spec.random_direction && spec.base.noise_theta_arcsec == 0.0 && spec.base.noise_phi_arcsec == 0.0;
  SimulationSpec s = spec.base;
  s.seed = TrialSeed(spec.seed, k, t);
  PointsData data;
  if (spec.random_direction) {
    s.centers_mm = Centers(spec, spec.eccentricities_mm[k], s.seed);
    data = SimulateExact(s);
  } else {
    data = exact[k];
  }
  AddReadingNoise(data, s);
  std::unique_ptr<internal::ReadingTable>& table = scratch.tables[k];
  if (!fixed_angles || !table) {
    table = std::make_unique<internal::ReadingTable>(data);
  } else {
    table->SetReadings(data);
  }
  const CalibrationResult r = internal::CalibrateTable(data, *table, copts);
  Trial trial;
  trial.geometry = r.geometry;
  trial.converged = r.converged;
  if (spec.random_direction) {
    const PredictedUncertainty predicted = PredictUncertainty(s);
    for (int p = 0; p < kNumScmsParams; ++p) {
      trial.crlb[static_cast<std::size_t>(p)] = predicted.std(p);
      trial.bias[static_cast<std::size_t>(p)] = predicted.bias(p);
    }
  }
  return trial;
}

// Every trial of the study (eccentricity after eccentricity, trial after trial) on a pool of
// threads. Each trial's noise comes from its own seed, so the result does not depend on the
// threads; the first error stops nothing but is thrown at the end.
std::vector<Trial> RunTrials(const MonteCarloStudyOptions& spec, const std::function<void(long, long)>& progress) {
  const std::size_t n_ecc = spec.eccentricities_mm.size();
  const std::size_t n_trials = static_cast<std::size_t>(spec.trials);
  const long total = static_cast<long>(n_ecc * n_trials);
  const std::vector<PointsData> exact = ExactReadings(spec);
  std::vector<Trial> trials(static_cast<std::size_t>(total));
  std::atomic<long> done{0};
  std::mutex progress_mutex, error_mutex;
  std::string error;
  const long step = std::max(1L, total / 100);
  internal::ParallelFor(static_cast<std::size_t>(total), spec.threads, [&] {
    return [&, scratch = TrialScratch(n_ecc)](std::size_t i) mutable {
      try {
        trials[i] = RunTrial(spec, i / n_trials, i % n_trials, exact, scratch);
      } catch (const Cancelled&) {
        throw;  // stops the loop
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (error.empty()) error = e.what();
      }
      const long d = ++done;
      if (progress && (d % step == 0 || d == total)) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        progress(d, total);
      }
    };
  });
  if (!error.empty()) throw Error("Monte Carlo: " + error);
  return trials;
}

// The statistics of parameter p over the converged trials of one eccentricity (row.estimates;
// `trials`: all of that eccentricity's, in trial order). crlb2_sum, bias_sum: sums over the
// converged trials of their own predicted variance and bias (random directions); fixed: the
// prediction of the one design (fixed placements).
ParameterStats StatsOf(const MonteCarloStudyOptions& spec, const EccentricityResult& row, const Trial* trials, int p,
                       const std::array<double, kNumScmsParams>& crlb2_sum,
                       const std::array<double, kNumScmsParams>& bias_sum, const PredictedUncertainty& fixed) {
  ParameterStats st;
  const auto q = static_cast<std::size_t>(p);
  const double n = static_cast<double>(row.estimates.size());
  st.truth = spec.base.truth[q];
  if (spec.random_direction) {
    st.crlb = n > 0 ? std::sqrt(crlb2_sum[q] / n) : std::nan("");
    st.bias = n > 0 ? bias_sum[q] / n : std::nan("");
  } else {
    st.crlb = fixed.std(p);
    st.bias = fixed.bias(p);
  }
  const bool angle = kScmsParamInfo[q].quantity == Quantity::kAngle;
  st.crlb_displacement_um = st.crlb * (angle ? spec.base.sphere_radius_mm : 1.0) * kUmPerMm;
  st.determined = st.crlb_displacement_um <= spec.max_std_um;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // One design undetermined: its bound and bias say nothing. Random directions: each trial is
  // judged against its own bound, whatever the root mean square of the bounds.
  const bool blank = !st.determined && !spec.random_direction;
  if (blank) st.bias = nan;
  double sum = 0.0;
  for (const auto& g : row.estimates) sum += g[q];
  st.mean = n > 0 ? sum / n : nan;
  if (row.estimates.size() < 2) {  // no spread: no statistic of it
    st.std = st.se = st.z = st.std_over_crlb = st.z_bias = nan;
    return st;
  }
  double ss = 0.0;
  for (const auto& g : row.estimates) ss += (g[q] - st.mean) * (g[q] - st.mean);
  st.std = std::sqrt(ss / (n - 1.0));
  if (spec.random_direction) {
    std::vector<double> z;  // the trials whose own bound is finite
    for (int t = 0; t < row.trials; ++t) {
      const Trial& tr = trials[t];
      if (tr.converged && std::isfinite(tr.crlb[q])) z.push_back((tr.geometry[q] - st.truth) / tr.crlb[q]);
    }
    const double m = static_cast<double>(z.size());
    double zm = 0.0, zss = 0.0;
    for (double v : z) zm += v / m;
    for (double v : z) zss += (v - zm) * (v - zm);
    st.std_over_crlb = z.size() >= 2 ? std::sqrt(zss / (m - 1.0)) : nan;
  } else {
    st.std_over_crlb = st.std / st.crlb;
  }
  st.se = st.std / std::sqrt(n);
  st.z = st.se > 0.0 ? (st.mean - st.truth) / st.se : 0.0;
  st.z_bias = st.se > 0.0 ? (st.mean - st.truth - st.bias) / st.se : 0.0;
  if (blank) st.std_over_crlb = st.z_bias = nan;
  return st;
}

// The row of eccentricity index k from its spec.trials trials (in trial order).
EccentricityResult Summarise(const MonteCarloStudyOptions& spec, std::size_t k, const Trial* trials) {
  EccentricityResult row;
  row.eccentricity_mm = spec.eccentricities_mm[k];
  row.trials = spec.trials;
  std::array<double, kNumScmsParams> crlb2_sum{}, bias_sum{};
  for (int t = 0; t < spec.trials; ++t) {
    const Trial& tr = trials[t];
    if (!tr.converged) {
      row.not_converged.push_back(t);
      continue;
    }
    ++row.converged;
    row.estimates.push_back(tr.geometry);
    for (std::size_t p = 0; p < kNumScmsParams; ++p) {
      crlb2_sum[p] += tr.crlb[p] * tr.crlb[p];
      bias_sum[p] += tr.bias[p];
    }
  }
  PredictedUncertainty fixed;
  if (!spec.random_direction) {
    SimulationSpec at_truth = spec.base;
    at_truth.centers_mm = PlacementCenters(spec, row.eccentricity_mm);
    fixed = PredictUncertainty(at_truth);
  }
  for (int p = 0; p < kNumScmsParams; ++p) {
    row.params[static_cast<std::size_t>(p)] = StatsOf(spec, row, trials, p, crlb2_sum, bias_sum, fixed);
  }
  return row;
}

}  // namespace

MonteCarloStudy RunMonteCarlo(const MonteCarloStudyOptions& spec, const std::function<void(long, long)>& progress) {
  if (spec.trials < 2) throw Error("Monte Carlo: at least 2 trials are needed");
  if (spec.setups < 1) throw Error("Monte Carlo: at least one setup per trial is needed");
  if (spec.eccentricities_mm.empty()) throw Error("Monte Carlo: no eccentricity given");
  if (!spec.random_direction && !(spec.direction.norm() > 0.0)) throw Error("Monte Carlo: the direction is zero");
  if (!(spec.max_std_um > 0.0)) throw Error("Monte Carlo: max_std_um must be positive");
  const std::vector<Trial> trials = RunTrials(spec, progress);
  MonteCarloStudy result;
  for (std::size_t k = 0; k < spec.eccentricities_mm.size(); ++k) {
    result.rows.push_back(Summarise(spec, k, trials.data() + k * static_cast<std::size_t>(spec.trials)));
  }
  return result;
}

double EvaluatedSphericityUm(const SimulationSpec& base, const Eigen::Vector3d& center_mm,
                             const ScmsGeometry& geometry) {
  SimulationSpec s = base;
  s.centers_mm = {center_mm};
  const PointsData exact = SimulateExact(s);
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(exact.samples.size());
  for (const Sample& smp : exact.samples) {
    pts.push_back(ScmsPoint(geometry, smp.theta_rad(), smp.phi_rad(), smp.r_mm, s.probe_offset_mm));
  }
  const LeastSquaresSphere fit = FitSphereLeastSquares(pts);
  if (!fit.sphere.ok) throw Error("sphericity: the evaluated points determine no sphere");
  return RadialPeakToValley(pts, fit.sphere.center) * kUmPerMm;
}

std::optional<double> EccentricityForNominalSphericity(const SimulationSpec& base, const Eigen::Vector3d& direction,
                                                       double target_um, double max_mm) {
  const Eigen::Vector3d u = direction.normalized();
  const ScmsGeometry nominal{};
  auto f = [&](double e) { return EvaluatedSphericityUm(base, e * u, nominal) - target_um; };
  double lo = 0.0, hi = max_mm;
  double f_lo = f(lo);
  if (f_lo > 0.0 || f(hi) < 0.0) return std::nullopt;
  for (int it = 0; it < 80 && hi - lo > 1e-9; ++it) {
    const double mid = 0.5 * (lo + hi);
    const double f_mid = f(mid);
    if ((f_mid < 0.0) == (f_lo < 0.0)) {
      lo = mid;
      f_lo = f_mid;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

std::vector<SphericityRow> SphericityStudy(const MonteCarloStudyOptions& spec, const MonteCarloStudy& result,
                                           const std::vector<double>& before_targets_um, double calibration_e_mm) {
  SimulationSpec cal_spec = spec.base;
  cal_spec.centers_mm = PlacementCenters(spec, calibration_e_mm);
  cal_spec.seed = spec.seed;
  CalibrationOptions copts;
  copts.sphere_radius_mm = spec.base.sphere_radius_mm;
  copts.probe_offset_mm = spec.base.probe_offset_mm;
  copts.analyse = false;
  const CalibrationResult one = Calibrate(Simulate(cal_spec), copts);

  const EccentricityResult* at_cal = nullptr;
  for (const auto& row : result.rows) {
    if (std::abs(row.eccentricity_mm - calibration_e_mm) < 1e-12 && !row.estimates.empty()) at_cal = &row;
  }
  ScmsGeometry mean{};
  if (at_cal != nullptr) {
    for (int p = 0; p < kNumScmsParams; ++p)
      mean[static_cast<std::size_t>(p)] = at_cal->params[static_cast<std::size_t>(p)].mean;
  }
  // What one calibration typically achieves: the median over the first calibrations of the study
  // (a single calibration's "after" values scatter by a factor of two or so).
  constexpr std::size_t kMedianOf = 101;

  const Eigen::Vector3d dir = spec.direction.normalized();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<SphericityRow> rows;
  for (double target : before_targets_um) {
    SphericityRow row{nan, nan, nan, nan, nan};
    const auto e = EccentricityForNominalSphericity(spec.base, dir, target, 0.5 * spec.base.sphere_radius_mm);
    if (e) {
      const Eigen::Vector3d c = *e * dir;
      row.eccentricity_mm = *e;
      row.before_um = EvaluatedSphericityUm(spec.base, c, ScmsGeometry{});
      row.after_one_um = EvaluatedSphericityUm(spec.base, c, one.geometry);
      if (at_cal != nullptr) {
        row.after_mean_um = EvaluatedSphericityUm(spec.base, c, mean);
        std::vector<double> v;
        for (std::size_t t = 0; t < std::min(kMedianOf, at_cal->estimates.size()); ++t) {
          v.push_back(EvaluatedSphericityUm(spec.base, c, at_cal->estimates[t]));
        }
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
        row.after_median_um = v[v.size() / 2];
      }
    }
    rows.push_back(row);
  }
  return rows;
}

}  // namespace sph
