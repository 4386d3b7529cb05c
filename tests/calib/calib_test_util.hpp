// Helpers shared by the calibration tests.
#ifndef SPH_TESTS_CALIB_CALIB_TEST_UTIL_HPP_
#define SPH_TESTS_CALIB_CALIB_TEST_UTIL_HPP_

#include "sph/calib/calibrator.hpp"

namespace sph::testing {

/// The options of the paper's study: R0 = 20 mm, d = 25 mm, the rest at their defaults.
inline CalibrationOptions PaperOptions() {
  CalibrationOptions o;
  o.sphere_radius_mm = 20.0;
  o.probe_offset_mm = 25.0;
  return o;
}

}  // namespace sph::testing

#endif  // SPH_TESTS_CALIB_CALIB_TEST_UTIL_HPP_
