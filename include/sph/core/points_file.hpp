// Points files, format "sph-points 1": the interface between acquisition, calibration and
// measurement. Text, one sample a line, rows in acquisition order (data/README.md):
//
//   # sph-points 1
//   # sphere_radius_mm: 20
//   # probe_offset_mm: 25
//   # columns: theta_deg phi_deg r_mm t_s setup
//   0.000000 7.500000 5.0912345 0.00 0
//
// '#' lines are comments; "# key: value" lines before the first sample are header fields.
// Columns theta_deg, phi_deg, r_mm are required; t_s (acquisition time) and setup (integer id of
// one placement of the sphere) are optional. Without a columns line: theta_deg phi_deg r_mm.
#ifndef SPH_CORE_POINTS_FILE_HPP_
#define SPH_CORE_POINTS_FILE_HPP_

#include <iosfwd>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace sph {

/// Format version this library reads and writes.
inline constexpr int kPointsFormatVersion = 1;

/// One reading of the three axes.
struct Sample {
  double theta_deg = 0.0;  ///< Theta axis reading [deg]
  double phi_deg = 0.0;    ///< Phi axis reading [deg]
  double r_mm = 0.0;       ///< probe reading [mm]
  double t_s = 0.0;        ///< acquisition time [s]; the row index when the file has no t_s column
  int setup = 0;           ///< sphere placement id; 0 when the file has no setup column
};

/// Header fields of a points file.
struct PointsHeader {
  std::optional<double> sphere_radius_mm;  ///< R0 from the sphere's certificate [mm]
  std::optional<double> probe_offset_mm;   ///< nominal probe zero distance d [mm]
  std::vector<std::string> columns;        ///< column names in file order
  /// Other "key: value" header fields, in file order; copied into reports.
  std::vector<std::pair<std::string, std::string>> metadata;
};

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

/// Reads a points file. Throws sph::Error with "path:line: problem" on any defect: unreadable
/// file, unsupported format version, duplicate header key, bad or non-positive radius or offset,
/// unknown, duplicate or missing column, wrong column count, a value that is not a number or not
/// finite, a non-integer setup id, no samples.
PointsData ReadPointsFile(const std::string& path);

/// As ReadPointsFile(), from a stream; `source` names it in messages.
PointsData ParsePoints(std::istream& in, const std::string& source);

/// What looks wrong in readings that parsed well, in words, one warning each: angle columns that
/// span no more than a radian measure would (theta within 0..2 pi, phi within 0..pi: degrees are
/// expected, "theta_deg"), rows that repeat an earlier row exactly (a logger that wrote a sample
/// twice), and probe readings farther from the median reading than any point of the sphere can
/// be (its diameter, with the header's sphere_radius_mm), named by line. Empty when nothing does.
std::vector<std::string> PlausibilityWarnings(const PointsData& data);

/// Writes `data` in format sph-points 1 (header, then one row a sample). Columns: theta_deg
/// phi_deg r_mm, then t_s if data.has_time, then setup if data.has_setup.
void WritePoints(std::ostream& out, const PointsData& data);

/// WritePoints() to a file, atomically (sph/core/output_files.hpp).
void WritePointsFile(const std::string& path, const PointsData& data);

/// The largest sphere radius R0 and probe zero distance d that files and options accept [mm].
inline constexpr double kMaxSphereRadiusMm = 1000.0;
inline constexpr double kMaxProbeOffsetMm = 10000.0;

/// The header field "key: value" for the radius and offset, and the allowed column names.
inline constexpr const char* kRadiusKey = "sphere_radius_mm";
inline constexpr const char* kProbeOffsetKey = "probe_offset_mm";
inline constexpr const char* kColumnsKey = "columns";

}  // namespace sph

#endif  // SPH_CORE_POINTS_FILE_HPP_
