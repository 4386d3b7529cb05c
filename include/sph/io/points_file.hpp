// Points files, format "sph-points 1": the interface between acquisition, calibration and
// measurement. Text, one sample a line, rows in acquisition order (docs/formats/points-files.md):
//
//   # sph-points 1
//   # sphere_radius_mm: 20
//   # probe_offset_mm: 25
//   # columns: theta_deg phi_deg r_mm t_s setup
//   0.000000 7.500000 5.0912345 0.00 0
//
// '#' lines are comments; "# key: value" lines before the first sample are header fields, and
// "# key@<setup>: value" ones belong to one setup (the orientation of the sphere on its mount:
// "# mount_rotation_deg@1: 0 0 90"; another sphere measured in that setup: "# sphere_radius_mm@2: 10"). Columns
// theta_deg, phi_deg, r_mm are required; t_s (acquisition time) and setup (integer id of one placement of the sphere)
// are optional. Without a columns line: theta_deg phi_deg r_mm.
#ifndef SPH_IO_POINTS_FILE_HPP_
#define SPH_IO_POINTS_FILE_HPP_

#include <iosfwd>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "sph/io/parameter_settings.hpp"
#include "sph/model/reading.hpp"

namespace sph {

/// Format version this library reads and writes.
inline constexpr int kPointsFormatVersion = 1;

/// One row of a points file: a reading of the three axes (theta_deg, phi_deg, r_mm), when it was
/// taken and in which setup.
struct Sample : RawReading {
  double t_s = 0.0;        ///< acquisition time [s]; the row index when the file has no t_s column
  int setup = 0;           ///< sphere placement id; 0 when the file has no setup column
};

/// How the sphere sits on its mount in one setup. A known orientation is the rotation vector
/// (axis times angle, in deg) of the rotation R that takes the sphere's body frame into the frame
/// that turns with the Theta axis: a point of the surface relative to the sphere's centre is
/// p_theta = R * p_body. Unknown: the sphere was remounted at an orientation nobody measured.
struct MountRotation {
  std::optional<Eigen::Vector3d> rotation_deg;  ///< nothing when unknown

  bool known() const { return rotation_deg.has_value(); }
  static MountRotation Known(const Eigen::Vector3d& rotation_deg) { return {rotation_deg}; }
  static MountRotation Unknown() { return {}; }
  /// The same statement, number for number (SameOrientation() compares them as rotations).
  bool operator==(const MountRotation& other) const { return rotation_deg == other.rotation_deg; }
  bool operator!=(const MountRotation& other) const { return !(*this == other); }
};

/// The largest magnitude of each component of a mount rotation's rotation vector that files and
/// options accept [deg]: a turn either way about any axis, written as the user likes it.
inline constexpr double kMaxMountRotationDeg = 360.0;

/// How far apart two mount rotations may be and still be one orientation [deg]: far above the
/// rounding of a rotation vector's conversion (1e-13 deg), far below any mount's repeatability
/// (a point of a 20 mm sphere moves 0.35 nm).
inline constexpr double kMountRotationToleranceDeg = 1e-6;

/// Whether `a` and `b` state one orientation of the sphere: both unknown, or both known and the
/// rotation between them within kMountRotationToleranceDeg ("0 -270 0" is "0 90 0"; "0 0 0",
/// "0 0 360" and a setup without the field are the reference orientation).
bool SameOrientation(const MountRotation& a, const MountRotation& b);

/// Header fields of a points file.
struct PointsHeader {
  std::optional<double> sphere_radius_mm;  ///< R0 from the sphere's certificate [mm]
  std::optional<double> probe_offset_mm;   ///< nominal probe zero distance d [mm]
  std::vector<std::string> columns;        ///< column names in file order
  /// The sphere's orientation on its mount by setup id ("mount_rotation_deg@<setup>"). A setup
  /// without an entry holds the sphere in the reference orientation (R = I).
  std::map<int, MountRotation> mount_rotations;
  /// The setups that measured another sphere than the reference one, by setup id: that sphere's
  /// radius from its certificate ("sphere_radius_mm@<setup>") [mm]. A setup without an entry
  /// measured the reference sphere (sphere_radius_mm); setups with the same radius measured the
  /// same other sphere (FormKey()).
  std::map<int, double> sphere_radii_mm;
  /// Other "key: value" header fields, in file order; copied into reports.
  std::vector<std::pair<std::string, std::string>> metadata;

  /// Which form the readings of `setup` see, as a key that setups sharing one set of form
  /// coefficients share: "" for the reference sphere in a known orientation; "unknown@<setup>"
  /// for a sphere remounted at an unknown orientation (tied to no other setup); "sphere_radius_mm
  /// <R>" for another sphere in a known orientation (its mount rotation then refers to that
  /// sphere's body frame): setups that give the same radius measured the same sphere.
  std::string FormKey(int setup) const;
};

/// What the sphere's certificate and the measuring conditions state, with their uncertainties:
/// the header fields of the same names (docs/formats/points-files.md), checked for range when the file is read
/// and kept among the header's metadata. Empty: not stated.
struct SphereConditions {
  std::optional<double> sphere_radius_u_um;      ///< standard uncertainty of R0 (certificate, k = 1) [um]
  std::optional<double> sphere_temperature_c;    ///< the sphere's temperature while measured [deg C]
  std::optional<double> sphere_temperature_u_c;  ///< its standard uncertainty [K]
  std::optional<double> sphere_cte_per_k;        ///< the sphere's linear expansion coefficient [1/K]
  std::optional<double> probe_scale_u;           ///< relative standard uncertainty of the probe's scale [1]
  std::optional<double> probe_range_mm;          ///< the probe's measuring range: readings 0 to it [mm]
  /// The certificate's bound of the sphere's form: its RMS over the sphere, k = 1 [um]
  /// (sph/calib/known_form.hpp).
  std::optional<double> sphere_form_rms_um;
};

/// One header field of SphereConditions: its key and the range a value must lie in.
struct ConditionField {
  const char* key;
  std::optional<double> SphereConditions::*field;
  double min, max;
  const char* unit;
  const char* what;  ///< for help texts
};
inline constexpr ConditionField kConditionFields[] = {
    {"sphere_radius_u_um", &SphereConditions::sphere_radius_u_um, 0.0, 1000.0, "um",
     "Standard uncertainty of R0 from the sphere's certificate (k = 1) [um]; default 0: R0 taken as exact"},
    {"sphere_temperature_c", &SphereConditions::sphere_temperature_c, -60.0, 100.0, "deg C",
     "The sphere's temperature while measured [deg C]; with sphere_cte_per_k, R0 (certified at 20 deg C) is "
     "corrected to it; default 20"},
    {"sphere_temperature_u_c", &SphereConditions::sphere_temperature_u_c, 0.0, 50.0, "K",
     "Standard uncertainty of the sphere's temperature [K]; default 0"},
    {"sphere_cte_per_k", &SphereConditions::sphere_cte_per_k, 0.0, 1e-3, "1/K",
     "The sphere's linear expansion coefficient [1/K] (steel about 11.5e-6); default 0: no correction"},
    {"probe_scale_u", &SphereConditions::probe_scale_u, 0.0, 0.5, "(relative)",
     "Relative standard uncertainty of the probe's scale [1]; default 0"},
    {"probe_range_mm", &SphereConditions::probe_range_mm, 0.002, 10000.0, "mm",
     "The probe's measuring range, readings 0 to it [mm]: probe terms are then given at its ends, the same "
     "numbers at any eccentricity; default: the range of the readings"},
    {"sphere_form_rms_um", &SphereConditions::sphere_form_rms_um, 1e-6, 1000.0, "um",
     "The certificate's bound of the sphere's form, its RMS over the sphere (k = 1) [um]: a zero-mean prior on the "
     "form's coefficients of degrees 2 to what the pattern resolves (at most 8), the same variance each; with "
     "--sphere-form, checked against the known form"},
};

/// The conditions among the header's metadata (values the reader has checked).
SphereConditions ConditionsOf(const PointsHeader& header);

/// A device that identified itself over SDO when the file was acquired: a header field
/// "device_<role>" as sph_acquired writes it from the node's identity object (1008h, 1018h),
/// "node 1; name \"...\"; vendor_id 0x...; product_code 0x...; revision 0x...; serial 0x...; ...".
/// Each value as written; empty where the line has none.
struct HeaderDevice {
  std::string role;  ///< the key less "device_": "theta_encoder", "phi_encoder", "probe"
  std::string node, name, vendor_id, product_code, revision, serial;
  /// The line's other items, each "key value" as written ("tpdo 1 cob_id 0x181", ...).
  std::vector<std::string> other;
};

/// The devices among header fields (PointsHeader::metadata), in file order. Never throws: an item
/// that is not "key value" is kept in `other` as written.
std::vector<HeaderDevice> DevicesOf(const std::vector<std::pair<std::string, std::string>>& metadata);

/// The header fields "fix" and "prior" (sph/io/parameter_settings.hpp): what the run that made
/// the file states about the calibration's parameters, checked when the file is read and kept
/// among the header's metadata. Empty: none.
inline constexpr const char* kFixKey = "fix";
inline constexpr const char* kPriorKey = "prior";
std::vector<FixedParameter> FixedParametersOf(const PointsHeader& header);
std::vector<ParameterPrior> ParameterPriorsOf(const PointsHeader& header);

/// A whole points file in memory.
struct PointsData {
  std::string source;  ///< where it came from, for messages (a path, or a name given by the caller)
  PointsHeader header;
  std::vector<Sample> samples;
  bool has_time = false;   ///< the file had a t_s column
  bool has_setup = false;  ///< the file had a setup column
  /// The file line of each sample, for messages; empty for data not read from a file.
  std::vector<long> sample_lines;

  /// "points.txt:120" for sample i (0-based), or "points.txt: sample 115" without line numbers.
  std::string WhereIs(std::size_t i) const;

  /// The distinct setup ids, ascending.
  std::vector<int> SetupIds() const;
};

/// A change of an axis reading no larger than this is no motion [deg]: above the jitter of an encoder
/// at standstill, far below any step of a measuring pattern (0.36 arcsec).
inline constexpr double kStandstillDeg = 1e-4;

/// The direction in which each axis approached each sample (MotionDirection), from the order of the
/// rows within its setup (the acquisition order): the sign of the change of the axis' reading from
/// the setup's previous row. An axis that did not move (kStandstillDeg) keeps the direction of its
/// last move, for it stands where that move left it; before its first move in the setup, the
/// direction of that move (the start approached as the scan goes on); an axis that never moves in a
/// setup, +1. A change goes the shorter way round, as a rotary axis turns: 345 to 0 deg is a move of
/// +15 deg (a ring scan keeps one direction), 0 to 90 deg one of +90 deg. Computed once from the
/// samples as read, for every fit and test that needs it.
std::vector<MotionDirection> MotionDirections(const std::vector<Sample>& samples);

/// Reads a points file. Throws sph::Error with "path:line: problem" on any defect: unreadable
/// file, a NUL byte or a line longer than kMaxLineBytes (sph/core/text_input.hpp), unsupported
/// format version, duplicate header key, a header field whose text is not UTF-8 (reports and JSON
/// copy it), bad or non-positive radius or offset, a bad mount
/// rotation (not three numbers within kMaxMountRotationDeg nor "unknown") or radius of a setup's
/// sphere, a per-setup field that names no setup or whose setup id is not an integer, is given
/// twice, stands after a row of its setup (it would apply to rows recorded before it) or has no
/// samples (named at its header line), a columns line or another header field the reader takes
/// after the first sample, unknown, duplicate or missing column, wrong column count, a value that
/// is not a number or not finite, an angle beyond kMaxAngleDeg, a reading beyond kMaxReadingMm, a
/// time beyond kMaxTimeS, a non-integer setup id, no samples. A row's message says when the line
/// holds commas (values separated by commas, or a decimal comma).
PointsData ReadPointsFile(const std::string& path);

/// As ReadPointsFile(), from a stream; `source` names it in messages.
PointsData ParsePoints(std::istream& in, const std::string& source);

/// A header field: its key and value.
struct HeaderField {
  std::string key, value;
};

/// Readings a host holds in memory (arrays): `n` readings, each column's values `stride` apart
/// (1: an array of its own; 3: the columns of one (n, 3) array). t_s and setup may be null: not
/// given (the row index and setup 0, as a file without those columns).
struct PointsColumns {
  std::size_t n = 0;
  std::size_t stride = 1;
  const double* theta_deg = nullptr;
  const double* phi_deg = nullptr;
  const double* r_mm = nullptr;
  const double* t_s = nullptr;
  const double* setup = nullptr;  ///< integers, as doubles (a host's array of any number type)
};

/// Points of a host: the header fields (key, value) read as the lines "# key: value" of a file
/// after its format line (numbered 2, 3, ... in messages; a "columns" field is passed over, for
/// the columns given say which there are) and each reading checked as a row is, named
/// "<source>: sample <i>" (from 1): as ParsePoints() of the file WritePoints() would make, without
/// the text. Throws sph::Error as ParsePoints() does, and for a key that is not a header key
/// (IsHeaderKey()) or a value with a line break (which would begin another line of the file), a
/// value that is not finite, or a setup that is not an integer.
PointsData PointsFromColumns(const std::vector<HeaderField>& header, const PointsColumns& columns,
                             const std::string& source);

/// What looks wrong in readings that parsed well, in words, one warning each: angle columns that
/// span no more than a radian measure would (theta within 0..2 pi, phi within 0..pi: degrees are
/// expected, "theta_deg"), rows that repeat an earlier row exactly (a logger that wrote a sample
/// twice), and probe readings farther from the median reading than any point of the sphere can
/// be (its diameter, with the header's sphere_radius_mm), named by line. Empty when nothing does.
std::vector<std::string> PlausibilityWarnings(const PointsData& data);

/// Writes `data` in format sph-points 1 (header, then one row a sample). Columns: theta_deg
/// phi_deg r_mm, then t_s if data.has_time, then setup if data.has_setup. Mount rotations and the
/// radii of setups' spheres are written with the shortest digits that read back to the same doubles.
/// Throws sph::Error, before writing anything, for a metadata field that a file could not hold
/// as the one line "# key: value" (a key that is not a header key, a value with a line break).
void WritePoints(std::ostream& out, const PointsData& data);

/// WritePoints() to a file, atomically (sph/io/output_files.hpp).
void WritePointsFile(const std::string& path, const PointsData& data);

/// The largest sphere radius R0 and probe zero distance d that files and options accept [mm].
inline constexpr double kMaxSphereRadiusMm = 1000.0;
inline constexpr double kMaxProbeOffsetMm = 10000.0;

/// The largest magnitude of a time (column t_s) that files accept [s], 31 700 years: every time
/// sph writes (Unix times of acquisitions; a simulation's 1e7 samples a day apart end at
/// 8.6e11 s), with a span between two times that no computation overflows and a resolution of
/// 0.1 ms left in a double.
inline constexpr double kMaxTimeS = 1e12;

/// The largest magnitude of a probe reading (column r_mm) that files accept [mm]: the reach of
/// points (kMaxPointCoordinateMm), beyond which the readings are not in mm of any machine.
inline constexpr double kMaxReadingMm = 1e6;

/// The largest magnitude of an angle (columns theta_deg, phi_deg) that files accept [deg]:
/// 2.8 million turns of a multi-turn encoder, where a double still resolves 1e-7 deg.
inline constexpr double kMaxAngleDeg = 1e9;

/// The header field "key: value" for the radius and offset, and the allowed column names.
inline constexpr const char* kRadiusKey = "sphere_radius_mm";
inline constexpr const char* kProbeOffsetKey = "probe_offset_mm";
inline constexpr const char* kColumnsKey = "columns";
/// The per-setup header field of the sphere's orientation: "mount_rotation_deg@<setup>".
inline constexpr const char* kMountRotationKey = "mount_rotation_deg";

/// Whether `key` (the text before a header line's ':', trimmed) is a header key: a name of
/// letters, digits, '_' and '-', optionally followed by '@' and a setup id (any text without
/// spaces here, none too; the reader checks that it is an integer for the keys it knows).
/// Anything else before a colon is prose in a comment.
bool IsHeaderKey(std::string_view key);

/// The header field of a comment line, given as `body`, the text after its '#': "key: value" with
/// key and value trimmed and a valid key (IsHeaderKey()); nothing for a plain comment or prose
/// that happens to hold a colon. The one reading of a field, for the reader and the writer.
std::optional<HeaderField> HeaderFieldOf(std::string_view body);

/// The header key of the mount rotation of `setup`: "mount_rotation_deg@1".
std::string MountRotationKey(int setup);

/// The header key of the radius of the sphere measured in `setup`: "sphere_radius_mm@2".
std::string SphereRadiusKey(int setup);

/// The per-setup header lines of `header`, "# key: value\n" each: the mount rotations, then the
/// radii of other spheres (shortest digits that read back exactly), leaving out the keys that
/// `written` holds (those a file already has). The one writing of these fields.
std::string SetupFieldLines(const PointsHeader& header, const std::map<std::string, std::string>& written = {});

/// The value of a mount rotation's header field: "rx ry rz" (shortest digits that read back
/// exactly) or "unknown".
std::string MountRotationValue(const MountRotation& rotation);

/// Parses the value of a mount rotation's header field ("rx ry rz" in deg, or "unknown"). Throws
/// sph::Error "<where><key>: expected ..." on a wrong count of values or a value that is not a
/// finite number within kMaxMountRotationDeg; `key` names the field in the message
/// ("mount_rotation_deg@1").
MountRotation ParseMountRotation(const std::string& value, const std::string& key, const std::string& where);

}  // namespace sph

#endif  // SPH_IO_POINTS_FILE_HPP_
