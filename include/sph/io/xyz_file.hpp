// Plain coordinate files: one point a line, "x y z", as coordinate measuring machines, other
// instruments and the NIST algorithm-testing data sets give them.
//
//   # any comment
//   -648.78997  244.45589  710.25315
//   -646.3582   244.08709  710.28793
//
// - Fields are separated by spaces, tabs or commas; CRLF line ends are accepted.
// - Blank lines and lines starting with '#' are skipped.
// - The NIST layout is accepted too: when the first line that is not a comment holds a single
//   integer, it is the number of points that follow, and the file must hold exactly that many.
// - Every value must be a finite number. Units are the caller's (sph_measure: mm).
#ifndef SPH_IO_XYZ_FILE_HPP_
#define SPH_IO_XYZ_FILE_HPP_

#include <iosfwd>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace sph {

/// Reads a coordinate file. Throws sph::Error "path:line: problem" on any defect: unreadable file,
/// a line without exactly three numbers, a value that is not a finite number, a point count that
/// the file does not hold, no points.
std::vector<Eigen::Vector3d> ReadXyzFile(const std::string& path);

/// As ReadXyzFile(), from a stream; `source` names it in messages.
std::vector<Eigen::Vector3d> ParseXyz(std::istream& in, const std::string& source);

/// Writes "# <comment>" lines, then one "x y z" line a point with 10 decimals (0.1 pm in mm).
void WriteXyz(std::ostream& out, const std::vector<Eigen::Vector3d>& points, const std::vector<std::string>& comments);

/// WriteXyz() to a file, atomically (sph/io/output_files.hpp); "-" writes to standard output.
void WriteXyzFile(const std::string& path, const std::vector<Eigen::Vector3d>& points,
                  const std::vector<std::string>& comments);

}  // namespace sph

#endif  // SPH_IO_XYZ_FILE_HPP_
