// A reading of the machine as it gives it: the two axis angles in degrees and the probe reading
// in mm. Header-only, no dependencies.
//
// The library's one reading type in the machine's units: the points file's row (sph::Sample,
// sph/io/points_file.hpp) is a RawReading with its time and setup, and the model's reading
// (sph::EffectReading, sph/model/effects.hpp) is made from one, its angles converted to radians
// here and nowhere else.
#ifndef SPH_MODEL_READING_HPP_
#define SPH_MODEL_READING_HPP_

#include "sph/model/units.hpp"

namespace sph {

/// One raw reading as the machine gives it.
struct RawReading {
  double theta_deg = 0.0;  ///< Theta axis reading [deg]
  double phi_deg = 0.0;    ///< Phi axis reading [deg]
  double r_mm = 0.0;       ///< probe reading [mm]

  double theta_rad() const { return theta_deg * kRadPerDeg; }  ///< Theta axis reading [rad]
  double phi_rad() const { return phi_deg * kRadPerDeg; }      ///< Phi axis reading [rad]
};

/// The direction in which each axis approached the position of a reading (ISO 230-2): +1 from
/// smaller readings (positive approach), -1 from larger ones, 0 not known. A reversal term
/// (theta_reversal, phi_reversal) shifts a reading by half its value in the direction of approach.
struct MotionDirection {
  int theta = 0;
  int phi = 0;
};

}  // namespace sph

#endif  // SPH_MODEL_READING_HPP_
