// Calibration files: what sph_calibrate --output writes and compensation loads later.
//
// JSON, format "sph-calibration" version 1:
//   {
//     "format": "sph-calibration", "format_version": 1, "created_by": "sph_calibrate 0.1.0",
//     "probe_offset_mm": 25.0,              nominal d the errors refer to
//     "sphere_radius_mm": 20.0,             R0 of the reference sphere (information)
//     "geometry": {"alpha": {"value": 0.02, "unit": "deg"}, "a": {"value": 0.002, "unit": "mm"}, ...},
//     "covariance": {"parameters": ["alpha", ...], "units": ["deg", "mm", ...], "matrix": [[...], ...]},
//     "effects": [                          further effects of the machine (sph/model/effects.hpp), may be empty
//       {"id": "theta_encoder", "iso_name": "ECC (...)",     (iso_name: information, not read)
//        "parameters": [{"name": "theta_encoder.c2", "value": 5.5, "unit": "arcsec"}, ...]},
//       {"id": "phi_wobble", "pivot_mm": 80.0, ...},  where the Phi axis tilts about, |L| <= 10000 mm (default 0)
//       ...],
//     "effect_reference": {"r_ref_mm": .., "r_half_range_mm": .., "t_start_s": .., "t_span_s": ..,
//                          "r_fit_min_mm": .., "r_fit_max_mm": ..},
//                                           with effects: what u and tau are normalised by, and the
//                                           readings the probe terms were fitted over (optional)
//     "sphere_form": {                      optional: the calibration sphere's own form, when separated
//       "normalisation": "schmidt_semi_normalised", "frame": "body", "unit": "um",
//       "terms": [{"l": 2, "m": 0, "value_um": 0.06, "std_um": 0.004}, ...]},  l = 2..40, |m| <= l, each once
//     "source": {"points_file": "...", ...} free-form provenance
//   }
// Angles are stored in deg and lengths in mm; the covariance in the same units (deg^2, deg*mm, mm^2).
// Effect parameters are in arcsec (angle effects) or um (length effects). probe_drift is refused:
// a drift belongs to the run it was measured in, not to the machine.
#ifndef SPH_CORE_CALIBRATION_FILE_HPP_
#define SPH_CORE_CALIBRATION_FILE_HPP_

#include <iosfwd>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "sph/model/compensation.hpp"
#include "sph/model/effects.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/scms_model.hpp"

namespace sph {

inline constexpr int kCalibrationFormatVersion = 1;

/// Contents of a calibration file, in internal units (rad, mm).
struct CalibrationFile {
  ScmsGeometry geometry{};                  ///< the seven errors (rad, mm)
  double probe_offset_mm = 0.0;             ///< nominal d
  std::optional<double> sphere_radius_mm;   ///< R0 of the calibration sphere
  /// Covariance of the seven errors (rad, mm), when the calibration computed one.
  std::optional<Eigen::Matrix<double, kNumScmsParams, kNumScmsParams>> covariance;
  EffectModel effects;                          ///< further effects (no probe_drift), with their reference
  std::vector<std::vector<double>> effect_values;  ///< one block per term (rad, mm)
  /// The calibration sphere's own form on its body frame, when the calibration separated it from
  /// the machine (sph/model/form_model.hpp): Schmidt semi-normalised harmonics and their values.
  std::vector<FormTerm> form_terms;
  std::vector<double> form_values_mm;  ///< one per term [mm]
  std::vector<double> form_std_mm;     ///< their standard uncertainties [mm], when known (else empty)
  std::string created_by;
  std::vector<std::pair<std::string, std::string>> source;  ///< provenance, copied as strings
};

/// Writes a calibration file atomically. Throws sph::Error when it cannot be written.
void WriteCalibrationFile(const std::string& path, const CalibrationFile& cal);
/// Writes the calibration file's JSON text to `out`.
void WriteCalibration(std::ostream& out, const CalibrationFile& cal);

/// Reads a calibration file. Throws sph::Error naming the file and the problem when it is not
/// JSON, is of another format or version, or lacks a field.
CalibrationFile ReadCalibrationFile(const std::string& path);

/// As ReadCalibrationFile(), from a stream; `source` names it in messages.
CalibrationFile ParseCalibration(std::istream& in, const std::string& source);

/// The part of a calibration file that compensation uses (sph/model/compensation.hpp).
Calibration ToCalibration(const CalibrationFile& file);

/// ReadCalibrationFile() then ToCalibration(): the calibration for the header-only compensation.
/// Throws sph::Error as ReadCalibrationFile() does.
Calibration LoadCalibration(const std::string& path);

}  // namespace sph

#endif  // SPH_CORE_CALIBRATION_FILE_HPP_
