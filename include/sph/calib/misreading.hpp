// What a set-up that does not fit most likely got wrong, when its readings show it: the seven
// errors fitted again to the readings taken another way (the probe's reading running the other
// way, the probe's readings in um rather than mm, the Theta or the Phi angle in the other sense).
// One that fits as a machine of small errors does, far better than the readings as given, names
// the cause. A misread angle's sense often fits as well as the true one, with the errors' signs
// flipped: the readings show it only where they do not (docs/formats/points-files.md states the
// senses).
#ifndef SPH_CALIB_MISREADING_HPP_
#define SPH_CALIB_MISREADING_HPP_

#include <optional>
#include <string>

#include "sph/calib/calibrator.hpp"
#include "sph/io/points_file.hpp"

namespace sph {

/// A way of taking the readings under which they fit far better.
struct Misreading {
  std::string what;           ///< "the probe's reading runs the other way": the likely cause
  std::string taken_as;       ///< how they were taken: "r taken as r / 1000"
  std::string convention;     ///< what sph takes: "r grows towards the axes' common point"
  double rms_um = 0.0;        ///< the seven-error fit's rms taken so [um]
  double d_prime_mm = 0.0;    ///< and its d' [mm]
  double given_rms_um = 0.0;  ///< the fit's rms as given [um]

  /// "likely cause: the probe's reading runs the other way (with r taken as ..., the readings fit
  /// the seven errors with rms 0.05387 um and d' = -0.1407 mm, against 12.83 um as given): sph
  /// takes r growing towards ..."
  std::string Reason() const;
};

/// Whether the seven-error fit `fit` of `points` (under `options`) fails as a misreading makes it
/// fail: not converged, |d'| above a tenth of the smallest sphere's radius, or an error beyond the
/// bounds of kScmsParamInfo.
bool FitsAsAMisreading(const PointsData& points, const CalibrationOptions& options, const CalibrationResult& fit);

/// When FitsAsAMisreading(`as_given`): the way of taking the readings whose seven-error fit (under
/// `options`) converges, does not so fail, and has at most a fifth of as_given's rms; the one of
/// the smallest rms. Nothing when none does (or `as_given` does not fail so). A fit that throws
/// counts as none.
std::optional<Misreading> LikelyMisreading(const PointsData& points, const CalibrationOptions& options,
                                           const CalibrationResult& as_given);

}  // namespace sph

#endif  // SPH_CALIB_MISREADING_HPP_
