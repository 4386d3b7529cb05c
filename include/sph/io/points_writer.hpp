// Streaming output of points files (format sph-points 1, docs/formats/points-files.md): one record at a time,
// for acquisition. The file is readable by ReadPointsFile() after every record.
#ifndef SPH_IO_POINTS_WRITER_HPP_
#define SPH_IO_POINTS_WRITER_HPP_

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include "sph/io/append_file.hpp"
#include "sph/io/points_file.hpp"

namespace sph {

struct PointsWriterOptions {
  bool has_time = true;           ///< write the t_s column
  bool has_setup = false;         ///< write the setup column
  double fsync_interval_s = 1.0;  ///< see AppendFile: 0 every record, < 0 only at Close()
};

/// Appends samples to a points file, each row written (one write()) before Write() returns.
///
/// A new or empty file gets the header first (format line, sphere_radius_mm, probe_offset_mm,
/// the mount rotations, the radii of other spheres, the metadata, columns). An existing file is
/// continued, never rewritten: its header must name the same columns and, where both give them,
/// the same radius, probe offset, mount rotation (the same orientation: SameOrientation()) and
/// sphere radius of each setup, else the constructor throws sph::Error ("points.txt: has columns
/// 'theta_deg phi_deg r_mm' but this run writes 'theta_deg phi_deg r_mm t_s': use another
/// file"). The fields of a setup the file does not hold yet are written before its first row.
/// A setup that already has rows keeps the orientation and sphere they were recorded with: a
/// mount rotation (other than the reference orientation) or another sphere's radius for a setup
/// whose rows the file holds without one is refused ("points.txt: setup 1 has rows (the first at
/// line 7) in the reference orientation (...): give this placement a setup of its own"), since
/// the field would relabel the rows before it. Such a run is refused rather than moved to a new
/// setup id: the id is the user's name of a placement, which their notes and later runs use.
/// An incomplete last line is cut off (see AppendFile). Rows have the same 10 decimals as
/// WritePoints() (t_s: 6).
///
/// The existing file is checked before it is opened: a file that is not a points file (its
/// first line is not "# sph-points 1") or whose header does not match is refused untouched.
class PointsWriter {
 public:
  PointsWriter(const std::string& path, const PointsHeader& header, const PointsWriterOptions& options);
  /// Throws the sph::Error the constructor would for the file now at `path` (not a points
  /// file, another header, a directory, a folder that does not exist), without opening,
  /// creating or changing anything.
  static void CheckContinuable(const std::string& path, const PointsHeader& header, const PointsWriterOptions& options);

  /// One row. Throws sph::Error on a write error (full disk), leaving the file as it was.
  void Write(const Sample& sample);
  /// A '#' comment line (between samples the reader skips it). Text that would read as a
  /// "key: value" header field in a file without samples is prefixed with "note ", and line
  /// breaks become spaces, so a comment never changes the header.
  void WriteComment(std::string_view text);
  void SyncIfDue() { file_.SyncIfDue(); }
  void Sync() { file_.Sync(); }
  void Close() { file_.Close(); }

  /// The file had content when opened: this run continues it.
  bool resumed() const { return resumed_; }
  std::uint64_t truncated_bytes() const { return file_.truncated_bytes(); }
  std::uint64_t samples_written() const { return samples_written_; }
  const std::string& path() const { return file_.path(); }
  AppendFile& file() { return file_; }

  /// The row for `sample`, with its '\n'.
  static std::string FormatRow(const Sample& sample, bool has_time, bool has_setup);

 private:
  /// The per-setup fields ("mount_rotation_deg@<setup>", "sphere_radius_mm@<setup>" to its
  /// value) that this run does not write: those the file at `path` holds anywhere (header, or
  /// between samples where an appending run wrote a new setup's), and a reference orientation
  /// its setup's rows already have; the file is read only when `header` has such fields to
  /// check. Throws as CheckContinuable() says.
  using SetupFields = std::map<std::string, std::string>;
  static SetupFields Continuable(const std::string& path, const PointsHeader& header,
                                 const PointsWriterOptions& options);
  PointsWriter(const std::string& path, const PointsHeader& header, const PointsWriterOptions& options,
               const SetupFields& in_file);

  AppendFile file_;
  PointsWriterOptions options_;
  bool resumed_ = false;
  std::uint64_t samples_written_ = 0;
};

}  // namespace sph

#endif  // SPH_IO_POINTS_WRITER_HPP_
