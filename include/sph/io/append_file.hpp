// A text file that only grows, for records that must survive a crash: acquisition output.
#ifndef SPH_IO_APPEND_FILE_HPP_
#define SPH_IO_APPEND_FILE_HPP_

#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>

namespace sph {

/// Appends whole records (text ending in '\n') to a file, each with one write() (O_APPEND), so a
/// record is in the file, and visible to readers, as soon as Append() returns. fsync() runs at
/// most `fsync_interval_s` after a record was written: 0 syncs every record, a negative interval
/// only at Close(). A crash of the process loses nothing that Append() wrote; a crash of the
/// machine loses at most the last interval.
///
/// Class invariant: the file holds only whole records. Opening cuts off an incomplete last line
/// (left by a machine crash or a full disk in an earlier run; truncated_bytes() says how much);
/// an Append() that fails (full disk, I/O error) cuts the file back to its size before the call
/// and throws sph::Error naming the path and strerror(errno). Nothing written before is ever
/// overwritten.
class AppendFile {
 public:
  /// Opens or creates `path` (mode 0644). Throws sph::Error when it cannot, or when `path` is a
  /// directory, a block device or a socket (a FIFO or a character device is written, never
  /// cut or replaced).
  AppendFile(const std::string& path, double fsync_interval_s);
  /// Throws the sph::Error the constructor would for what `path` is now (a directory, a block
  /// device, a folder that does not exist or cannot be written), without opening or creating
  /// anything: a program checks its outputs before it starts.
  static void CheckTarget(const std::string& path);
  /// The first `max_bytes` bytes of `path` (all of a shorter file); empty for a file that does
  /// not exist or is not a regular file. Throws sph::Error when it cannot be read. What a writer
  /// reads to check an existing file before it opens it.
  static std::string ReadStart(const std::string& path, std::size_t max_bytes);
  ~AppendFile();  ///< Close() without throwing
  AppendFile(const AppendFile&) = delete;
  AppendFile& operator=(const AppendFile&) = delete;

  /// Appends `records` with one write() (retrying short writes). On failure the file keeps its
  /// previous content and sph::Error is thrown; the object stays usable (a later Append may work).
  void Append(std::string_view records);
  /// fsync() when records written more than the interval ago are not yet synced.
  void SyncIfDue();
  /// fsync() now. Throws sph::Error on failure.
  void Sync();
  /// Syncs and closes; later calls do nothing. Throws sph::Error on failure.
  void Close();

  const std::string& path() const { return path_; }
  std::uint64_t size_bytes() const { return size_; }
  /// Bytes of an incomplete last line cut off when opening.
  std::uint64_t truncated_bytes() const { return truncated_bytes_; }
  /// The file had (whole) content when opened.
  bool had_content() const { return had_content_; }
  std::uint64_t syncs() const { return syncs_; }

 private:
  std::string path_;
  int fd_ = -1;
  double fsync_interval_s_;
  std::uint64_t size_ = 0;
  std::uint64_t truncated_bytes_ = 0;
  bool had_content_ = false;
  bool regular_ = false;
  bool dirty_ = false;
  std::chrono::steady_clock::time_point first_unsynced_{};
  std::uint64_t syncs_ = 0;
};

}  // namespace sph

#endif  // SPH_IO_APPEND_FILE_HPP_
