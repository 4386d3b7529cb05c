// A Monte Carlo study as sph_montecarlo's options state it: checked and run, with its report, so
// that the app and a host program (the Python module) run the same study from the same words.
// Messages name each setting as the option that sets it ("--trials: must be >= 2 ...").
#ifndef SPH_CALIB_MONTECARLO_OPTIONS_HPP_
#define SPH_CALIB_MONTECARLO_OPTIONS_HPP_

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "sph/calib/montecarlo.hpp"
#include "sph/calib/montecarlo_report.hpp"
#include "sph/simulation/simulation_options.hpp"

namespace sph {

/// What sph_montecarlo studies (all its options but the plans and the files it writes).
struct MonteCarloOptions {
  MachineOptions machine;  ///< truth, sphere, pattern, noise
  std::vector<double> eccentricities_mm{0.5, 1.0, 1.5, 2.0};
  std::string direction = "1,0,0";  ///< "x,y,z", any length > 0
  bool random_direction = false;
  int setups = 1;
  int trials = 1000;
  std::uint64_t seed = 1;
  int threads = 0;           ///< 0: all hardware threads
  double max_std_um = 10.0;  ///< a parameter whose predicted std, as a displacement, exceeds this is undetermined
  bool table3 = true;        ///< the paper's Table 3, from the study's calibrations at ...
  double table3_calibration_e_mm = 2.0;  ///< ... this eccentricity, one of eccentricities_mm
};

/// The study the options describe. Throws sph::Error naming the option and the problem: a number
/// out of its range, an eccentricity outside [0, R0), a zero direction, Table 3 at an
/// eccentricity not studied.
MonteCarloStudyOptions MonteCarloSpecOf(const MonteCarloOptions& o);

/// A study run: its spec, its results, Table 3 when asked, and how long the calibrations took.
struct MonteCarloRun {
  MonteCarloStudyOptions spec;
  MonteCarloStudy study;
  std::optional<PaperTable3> table3;
  std::string direction;     ///< as the options gave it
  double wall_time_s = 0.0;  ///< RunMonteCarlo()'s wall time

  /// The JSON report as sph_montecarlo --json writes it (StudyJson()).
  std::string JsonReport() const;
};

/// RunMonteCarlo() of MonteCarloSpecOf(o) (`progress` as there), then Table 3 when o.table3.
MonteCarloRun RunMonteCarloStudy(const MonteCarloOptions& o,
                                 const std::function<void(long done, long total)>& progress = {});

}  // namespace sph

#endif  // SPH_CALIB_MONTECARLO_OPTIONS_HPP_
