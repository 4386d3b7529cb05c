// Calibration files: what sph_calibrate --output writes and compensation loads later. JSON, format
// "sph-calibration" version 1; every field, its unit and what the reader refuses:
// docs/formats/calibration-files.md.
//
// The file stores angles in deg, lengths in mm and the effects' parameters in arcsec or um; this
// API works in rad and mm. The covariance's parameters are the seven errors, then every effect
// parameter in the order of the effects, then every term of the sphere's form, or the seven errors
// alone; its matrix is the combined one, A + sum_j s_j s_j^T u_j^2 (Type A and each Type B input).
// probe_drift is refused: a drift belongs to the run it was measured in, not to the machine.
#ifndef SPH_IO_CALIBRATION_FILE_HPP_
#define SPH_IO_CALIBRATION_FILE_HPP_

#include <cstddef>
#include <iosfwd>
#include <limits>
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

/// The largest calibration file the reader takes [bytes], twice the largest the writer makes:
/// the covariance of every parameter the format can hold (1965: the seven errors, every
/// component of every effect, the form's terms to degree 40) takes 127 MB in its layout.
/// Anything larger is no calibration file (a device, a stream that never ends).
inline constexpr std::size_t kMaxCalibrationFileBytes = std::size_t{256} << 20;

/// Contents of a calibration file, in internal units (rad, mm).
struct CalibrationFile {
  ScmsGeometry geometry{};                 ///< the seven errors (rad, mm)
  double probe_offset_mm = 0.0;            ///< nominal d
  std::optional<double> sphere_radius_mm;  ///< R0 of the calibration sphere
  /// Covariance of the seven errors (rad, mm), when the calibration computed one.
  std::optional<Eigen::Matrix<double, kNumScmsParams, kNumScmsParams>> covariance;
  EffectModel effects;                             ///< further effects (no probe_drift), with their reference
  /// The powers of tau of the probe drift the calibration fitted beside the rest and left out (a
  /// drift belongs to its run); empty: none fitted. Part of the model the values come from (the
  /// seven errors of a fit with a drift are those at the run's start).
  std::vector<int> probe_drift_powers;
  std::vector<std::vector<double>> effect_values;  ///< one block per term (rad, mm)
  /// The calibration sphere's own form on its body frame, when the calibration separated it from
  /// the machine (sph/model/form_model.hpp): Schmidt semi-normalised harmonics and their values.
  std::vector<FormTerm> form_terms;
  std::vector<double> form_values_mm;  ///< one per term [mm]
  std::vector<double> form_std_mm;     ///< their standard uncertainties [mm], when known (else empty)
  /// The covariance of every parameter the file applies (rad, mm): the seven errors, then the
  /// effects' parameters (term, then component order), then the form's coefficients; its
  /// top-left 7 x 7 block is `covariance`. Empty when the file holds the seven errors' alone.
  Eigen::MatrixXd parameter_covariance;
  /// What the covariance is made of, when the calibration's budget gave it: C = A + sum_j s_j s_j^T u_j^2.
  struct CovarianceInput {
    std::string input;         ///< "R0 (certificate)", "sphere temperature", "probe scale"
    std::string unit;          ///< of the input: "um", "K", "relative"
    double u = 0.0;            ///< its standard uncertainty, in `unit`
    Eigen::VectorXd per_unit;  ///< d(parameter)/d(input) per `unit`, internal units, one per covariance row
  };
  std::vector<CovarianceInput> covariance_inputs;
  /// Degrees of freedom of the covariance's Type A part; infinite when not stated.
  double covariance_type_a_dof = std::numeric_limits<double>::infinity();
  std::string created_by;
  std::vector<std::pair<std::string, std::string>> source;  ///< provenance, copied as strings
};

/// Writes a calibration file atomically. Throws sph::Error when it cannot be written.
void WriteCalibrationFile(const std::string& path, const CalibrationFile& cal);
/// Writes the calibration file's JSON text to `out`.
void WriteCalibration(std::ostream& out, const CalibrationFile& cal);

/// Reads a calibration file. Throws sph::Error naming the file and the problem when it is not
/// JSON (or holds a NUL byte, is larger than kMaxCalibrationFileBytes, nests deeper than any
/// calibration file, gives a key twice), is of another format or version, lacks a field, has a
/// field the format does not know in "geometry", a value out of its range, or a covariance that
/// is none (not symmetric, not positive semi-definite, a standard uncertainty larger than any
/// value of its parameter, inputs the matrix does not hold: see the file comment).
CalibrationFile ReadCalibrationFile(const std::string& path);

/// As ReadCalibrationFile(), from a stream; `source` names it in messages.
CalibrationFile ParseCalibration(std::istream& in, const std::string& source);

/// The names of the parameters of the file's full covariance, in its order: the seven errors,
/// every effect parameter, then "sphere_form.S(l,m)" for each form term.
std::vector<std::string> CalibrationParameterNames(const CalibrationFile& file);

/// The covariance of every parameter the file applies (rad, mm), in the order of
/// CalibrationParameterNames() when the file has it, else the seven errors' block alone; empty
/// without a covariance.
Eigen::MatrixXd AppliedCovariance(const CalibrationFile& file);

/// The covariance of the form's coefficients (mm^2, form_terms order): their block of the file's
/// full covariance, where the file carries one; else, with each term's std_mm, the diagonal of their
/// squares (`*correlated` false: the correlations are not known); else empty. `correlated` may be
/// null.
Eigen::MatrixXd FormCovariance(const CalibrationFile& file, bool* correlated = nullptr);

/// The part of a calibration file that compensation uses (sph/model/compensation.hpp).
Calibration ToCalibration(const CalibrationFile& file);

/// ReadCalibrationFile() then ToCalibration(): the calibration for the header-only compensation.
/// Throws sph::Error as ReadCalibrationFile() does.
Calibration LoadCalibration(const std::string& path);

}  // namespace sph

#endif  // SPH_IO_CALIBRATION_FILE_HPP_
