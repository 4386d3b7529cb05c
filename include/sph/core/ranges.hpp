// The valid ranges of the numbers the calibration side takes (sph/core/valid_range.hpp): one place
// for each limit, so that a host program's settings and the apps' options are refused with the
// same words.
#ifndef SPH_CORE_RANGES_HPP_
#define SPH_CORE_RANGES_HPP_

#include <cstddef>

#include "sph/io/points_file.hpp"
#include "sph/core/valid_range.hpp"
#include "sph/model/effect_terms.hpp"
#include "sph/model/scms_model.hpp"

namespace sph::ranges {

inline constexpr ValidRange kSphereRadiusMm{0.0, kMaxSphereRadiusMm, "mm", true};
inline constexpr ValidRange kProbeOffsetMm{0.0, kMaxProbeOffsetMm, "mm", true};
/// The seven errors: kScmsParamInfo's bounds, in deg or mm (and |d'| < d).
constexpr ValidRange ErrorRange(int p) {
  return {-kScmsParamInfo[static_cast<std::size_t>(p)].max_abs_report,
          kScmsParamInfo[static_cast<std::size_t>(p)].max_abs_report, ReportUnitsOf(p).coarse};
}
inline constexpr ValidRange kNoiseUm{0.0, 1000.0, "um"};
inline constexpr ValidRange kNoiseArcsec{0.0, 3600.0, "arcsec"};
inline constexpr ValidRange kCenterMm{-1000.0, 1000.0, "mm"};  ///< each coordinate of a centre
inline constexpr ValidRange kEffectArcsec{-kMaxEffectArcsec, kMaxEffectArcsec, "arcsec"};
inline constexpr ValidRange kEffectUm{-kMaxEffectUm, kMaxEffectUm, "um"};
/// A standard uncertainty as a displacement of the probed point (CalibrationOptions::max_std_um).
inline constexpr ValidRange kStdUm{0.0, 1e6, "um", true};
/// The Phi axis wobble's pivot distance along the axis (phi_wobble).
inline constexpr ValidRange kPivotMm{-kMaxPivotMm, kMaxPivotMm, "mm"};
/// The sphere on its mount and its form (the simulator).
inline constexpr ValidRange kMountRotationDeg{-kMaxMountRotationDeg, kMaxMountRotationDeg, "deg"};  ///< each component
inline constexpr ValidRange kFormDepthUm{0.0, kMaxEffectUm, "um", true};
inline constexpr ValidRange kFormWidthDeg{0.0, 180.0, "deg", true};
inline constexpr ValidRange kDirection{-1e6, 1e6, ""};  ///< each component of a direction (any length > 0)
inline constexpr ValidRange kCoverageProbability{0.5, 0.9999, ""};
inline constexpr ValidRange kRobustScaleSigma{0.01, 100.0, ""};  ///< the robust loss' scale, in units of the noise
/// The simulators' grid (positions per ring, rings), time step, outliers and probe range.
inline constexpr ValidRange kGridSteps{1.0, 1000000.0, ""};
inline constexpr ValidRange kSamplePeriodS{0.0, 86400.0, "s"};
inline constexpr ValidRange kOutlierFraction{0.0, 1.0, ""};
inline constexpr ValidRange kOutlierUm{0.0, 1e6, "um"};
inline constexpr ValidRange kProbeRangeMm{0.002, 10000.0, "mm"};
/// The Monte Carlo study: calibrations per eccentricity, sphere placements per trial, threads (0: all).
inline constexpr ValidRange kTrials{2.0, 1000000.0, ""};
inline constexpr ValidRange kSetups{1.0, 100.0, ""};
inline constexpr ValidRange kThreads{0.0, 1024.0, ""};

}  // namespace sph::ranges

#endif  // SPH_CORE_RANGES_HPP_
