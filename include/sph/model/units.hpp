// Unit conversions used across sph. Internally angles are in rad and lengths in mm; files and
// reports use deg (the paper's tables), urad, mm and um.
#ifndef SPH_MODEL_UNITS_HPP_
#define SPH_MODEL_UNITS_HPP_

namespace sph {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kRadPerDeg = kPi / 180.0;
inline constexpr double kDegPerRad = 180.0 / kPi;
inline constexpr double kUmPerMm = 1000.0;
inline constexpr double kMmPerUm = 1.0e-3;
inline constexpr double kUradPerRad = 1.0e6;
inline constexpr double kRadPerArcsec = kRadPerDeg / 3600.0;

}  // namespace sph

#endif  // SPH_MODEL_UNITS_HPP_
