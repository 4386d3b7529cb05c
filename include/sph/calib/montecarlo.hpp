// Monte Carlo study of the calibration: repeated calibrations of simulated measurements, per
// sphere eccentricity, compared with the linearised (Cramer-Rao) prediction (sph/calib/design.hpp).
//
// Reproducibility: trial t of eccentricity k draws its noise (and, if asked, its directions) from
// seeds derived from (seed, k, t) alone, so results depend on the seed only, not on the number of
// threads or the order in which trials run.
#ifndef SPH_CALIB_MONTECARLO_HPP_
#define SPH_CALIB_MONTECARLO_HPP_

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "sph/simulation/simulate.hpp"
#include "sph/model/scms_model.hpp"

namespace sph {

struct MonteCarloStudyOptions {
  /// Truth, R0, d, pattern and noise; its centres and seed are replaced per trial.
  SimulationSpec base;
  std::vector<double> eccentricities_mm{0.5, 1.0, 1.5, 2.0};
  /// Direction of the eccentricity (normalised when used). With `setups` > 1, setup j is this
  /// direction turned by j * 360/setups deg about the Theta axis (z).
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
  bool random_direction = false;  ///< a uniformly random direction per trial (and per setup)
  int setups = 1;                 ///< sphere placements per trial, all at the same eccentricity
  int trials = 1000;
  std::uint64_t seed = 1;
  int threads = 0;  ///< 0: all hardware threads
  /// A parameter whose predicted std (CRLB), as a displacement of the probed point (angles times
  /// R0), exceeds this is undetermined at that eccentricity, as a calibration would report it
  /// (CalibrationOptions::max_std_um, the same default) [um].
  double max_std_um = 10.0;
};

/// Statistics of one parameter's estimates at one eccentricity, in internal units (rad, mm).
struct ParameterStats {
  double truth = 0.0;
  double mean = 0.0;  ///< NaN when no trial converged
  double std = 0.0;  ///< sample standard deviation over the converged trials (NaN, as all of its statistics, below two)
  double se = 0.0;   ///< standard error of the mean, std / sqrt(n)
  double z = 0.0;    ///< (mean - truth) / se
  /// Predicted std (design.hpp) at the truth. With random directions every trial has its own
  /// design: the root mean square of the trials' predicted std, sqrt(mean CRLB_t^2), which is the
  /// std of estimates pooled over random placements (total variance, the estimator unbiased).
  double crlb = 0.0;
  double bias = 0.0;  ///< predicted second-order bias (design.hpp); random directions: the trials' mean
  /// How close the estimates come to their bound: std / crlb for one design; with random
  /// directions the sample std of (estimate - truth) / CRLB_t, each trial against its own bound
  /// (a pooled std would be ruled by the few near-degenerate placements). 1: efficient.
  double std_over_crlb = 0.0;
  double z_bias = 0.0;  ///< (mean - truth - bias) / se
  /// The CRLB as a displacement [um] (angles times R0), and whether it is at most
  /// MonteCarloStudyOptions::max_std_um. When it is not, the design does not determine the parameter:
  /// std_over_crlb, bias and z_bias are NaN (a bound that does not hold the estimate near the
  /// truth, or an infinite one, gives no ratio and no second-order bias), crlb is kept (+inf in
  /// the design's null space). With random directions each trial is judged against its own bound
  /// (trials whose bound is infinite are left out of std_over_crlb) whatever the root mean square.
  double crlb_displacement_um = 0.0;
  bool determined = true;
};

struct EccentricityResult {
  double eccentricity_mm = 0.0;
  int trials = 0;
  int converged = 0;
  /// Trials (0-based, in trial order) that did not converge: left out of every statistic.
  std::vector<int> not_converged;
  std::array<ParameterStats, kNumScmsParams> params{};
  std::vector<ScmsGeometry> estimates;  ///< one per converged trial, in trial order
};

struct MonteCarloStudy {
  std::vector<EccentricityResult> rows;
};

/// The sphere centres of the fixed-direction design at eccentricity e_mm: spec.setups centres,
/// setup j along spec.direction turned by j * 360/setups deg about the Theta axis (z).
std::vector<Eigen::Vector3d> PlacementCenters(const MonteCarloStudyOptions& spec, double e_mm);

/// The seed of trial t at eccentricity index k (a SplitMix64 mix of the three).
std::uint64_t TrialSeed(std::uint64_t seed, std::size_t k, std::size_t t);

/// Runs the study. `progress(done, total)` is called from the worker threads, serialised, about
/// a hundred times over the run; it may be empty. Throws sph::Error on an impossible spec.
MonteCarloStudy RunMonteCarlo(const MonteCarloStudyOptions& spec,
                              const std::function<void(long done, long total)>& progress = {});

/// Least-squares sphericity [um] of a sphere centred at `center_mm`, read exactly (no noise) from
/// the machine of `base` (truth, R0, d, pattern) and evaluated with `geometry` (all zero: the
/// nominal model): the peak-to-valley of the radial residuals about the geometric least-squares
/// sphere of the evaluated points.
double EvaluatedSphericityUm(const SimulationSpec& base, const Eigen::Vector3d& center_mm,
                             const ScmsGeometry& geometry);

/// The eccentricity e in [0, max_mm] along `direction` at which the nominal model's sphericity
/// (EvaluatedSphericityUm with zero errors) equals target_um, found by bisection (the sphericity
/// grows with e over that range); nothing when target_um is outside the range's values.
std::optional<double> EccentricityForNominalSphericity(const SimulationSpec& base, const Eigen::Vector3d& direction,
                                                       double target_um, double max_mm);

/// One sphere of the sphericity study (the paper's Table 3), in um.
struct SphericityRow {
  double eccentricity_mm = 0.0;  ///< found so that `before` equals the target
  double before_um = 0.0;        ///< evaluated with the nominal (zero) errors
  double after_one_um = 0.0;     ///< with one calibration at the calibration eccentricity
  double after_median_um = 0.0;  ///< median over up to 101 Monte Carlo calibrations there (NaN without)
  double after_mean_um = 0.0;    ///< with the Monte Carlo mean errors there (NaN without)
};

/// The paper's Table 3: for each target "before" sphericity, the sphere along the study's
/// direction whose nominal-model sphericity it is, evaluated before and after calibration. The
/// one calibration uses spec.base's noise at `calibration_e_mm` with spec.seed; the median and
/// mean use the study's estimates at that eccentricity if `result` has it. A target that no
/// eccentricity below R0/2 reaches gives a row of NaN.
std::vector<SphericityRow> SphericityStudy(const MonteCarloStudyOptions& spec, const MonteCarloStudy& result,
                                           const std::vector<double>& before_targets_um, double calibration_e_mm);

}  // namespace sph

#endif  // SPH_CALIB_MONTECARLO_HPP_
