#include "sph/calib/montecarlo_options.hpp"

#include <algorithm>
#include <chrono>

#include "sph/core/error.hpp"
#include "sph/core/ranges.hpp"
#include "sph/internal/format.hpp"

namespace sph {

using internal::Format;

MonteCarloStudyOptions MonteCarloSpecOf(const MonteCarloOptions& o) {
  CheckedValue(o.trials, ranges::kTrials, "--trials");
  CheckedValue(o.setups, ranges::kSetups, "--setups");
  CheckedValue(o.threads, ranges::kThreads, "--threads");
  CheckedValue(o.max_std_um, ranges::kStdUm, "--max-std-um");
  MonteCarloStudyOptions spec;
  spec.base = ToSimulationSpec(o.machine);
  spec.eccentricities_mm = o.eccentricities_mm;
  spec.direction = ParseVector3(o.direction, "--direction");
  if (!o.random_direction && !(spec.direction.norm() > 0.0)) throw Error("--direction must not be zero");
  spec.random_direction = o.random_direction;
  spec.setups = o.setups;
  spec.trials = o.trials;
  spec.seed = o.seed;
  spec.threads = o.threads;
  spec.max_std_um = o.max_std_um;
  if (spec.eccentricities_mm.empty()) throw Error("--eccentricities-mm: no eccentricity given (the study needs one)");
  for (double e : spec.eccentricities_mm) {
    if (!(e >= 0.0) || !(e < o.machine.sphere_radius_mm)) {
      throw Error("--eccentricities-mm: " + Format("%g", e) + " is not in [0, R0)");
    }
  }
  const auto& es = spec.eccentricities_mm;
  if (o.table3 && std::find(es.begin(), es.end(), o.table3_calibration_e_mm) == es.end()) {
    std::string list;
    for (double e : es) list += (list.empty() ? "" : ", ") + Format("%g", e);
    throw Error("--table3-calibration-e-mm " + Format("%g", o.table3_calibration_e_mm) +
                ": Table 3 uses the study's calibrations at one of the eccentricities studied (--eccentricities-mm " +
                list + "); choose one of them, add it to the study, or leave Table 3 out (--no-table3)");
  }
  return spec;
}

std::string MonteCarloRun::JsonReport() const {
  return StudyJson(spec, study, direction, wall_time_s, table3 ? &*table3 : nullptr);
}

MonteCarloRun RunMonteCarloStudy(const MonteCarloOptions& o,
                                 const std::function<void(long done, long total)>& progress) {
  MonteCarloRun run;
  run.spec = MonteCarloSpecOf(o);
  run.direction = o.direction;
  const auto t0 = std::chrono::steady_clock::now();
  run.study = RunMonteCarlo(run.spec, progress);
  run.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (o.table3) run.table3 = MakePaperTable3(run.spec, run.study, o.table3_calibration_e_mm);
  return run;
}

}  // namespace sph
