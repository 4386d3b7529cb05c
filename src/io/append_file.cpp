#include "sph/io/append_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "sph/core/error.hpp"

namespace sph {
namespace {

std::string Why(int err) { return std::strerror(err); }

// Offset just past the last '\n' in the file (0 if none), reading backwards in blocks.
off_t EndOfLastLine(int fd, off_t size) {
  char buf[4096];
  off_t end = size;
  while (end > 0) {
    const off_t start = end > static_cast<off_t>(sizeof buf) ? end - static_cast<off_t>(sizeof buf) : 0;
    const ssize_t n = ::pread(fd, buf, static_cast<std::size_t>(end - start), start);
    if (n <= 0) return -1;
    for (ssize_t i = n - 1; i >= 0; --i) {
      if (buf[i] == '\n') return start + i + 1;
    }
    end = start;
  }
  return 0;
}

// Why a file of this mode is not appended to, or null.
const char* RefusedKind(mode_t mode) {
  if (S_ISDIR(mode)) return "cannot open for appending: Is a directory";
  if (S_ISBLK(mode)) return "is a block device: refusing to write onto it";
  if (S_ISSOCK(mode)) return "is a socket: refusing to write onto it";
  return nullptr;
}

}  // namespace

void AppendFile::CheckTarget(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if (const char* why = RefusedKind(st.st_mode)) throw Error(path + ": " + why);
    if (::access(path.c_str(), W_OK) != 0) throw Error(path + ": cannot open for appending: " + Why(errno));
    return;
  }
  if (errno != ENOENT) throw Error(path + ": cannot open for appending: " + Why(errno));
  const std::size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : path.substr(0, slash == 0 ? 1 : slash);
  if (::access(dir.c_str(), W_OK | X_OK) != 0) throw Error(path + ": cannot open for appending: " + Why(errno));
}

std::string AppendFile::ReadStart(const std::string& path, std::size_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_size == 0) return "";
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(path + ": cannot read the existing content: " + Why(errno));
  std::string text(std::min<std::size_t>(max_bytes, static_cast<std::size_t>(st.st_size)), '\0');
  std::size_t got = 0;
  while (got < text.size()) {
    const ssize_t n = ::pread(fd, text.data() + got, text.size() - got, static_cast<off_t>(got));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int err = errno;
      ::close(fd);
      throw Error(path + ": cannot read the existing content: " + Why(err));
    }
    if (n == 0) break;
    got += static_cast<std::size_t>(n);
  }
  ::close(fd);
  text.resize(got);
  return text;
}

AppendFile::AppendFile(const std::string& path, double fsync_interval_s)
    : path_(path), fsync_interval_s_(fsync_interval_s) {
  struct stat before {};
  if (::stat(path.c_str(), &before) == 0) {
    if (const char* why = RefusedKind(before.st_mode)) throw Error(path + ": " + why);
  }
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error(path + ": cannot open for appending: " + Why(errno));
  struct stat st {};
  if (::fstat(fd_, &st) != 0) {
    const int err = errno;
    ::close(fd_);
    throw Error(path + ": cannot stat: " + Why(err));
  }
  if (const char* why = RefusedKind(st.st_mode)) {
    ::close(fd_);
    throw Error(path + ": " + why);
  }
  regular_ = S_ISREG(st.st_mode);
  off_t size = regular_ ? st.st_size : 0;
  if (size > 0) {
    const int rfd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    const off_t keep = rfd >= 0 ? EndOfLastLine(rfd, size) : -1;
    if (rfd >= 0) ::close(rfd);
    if (keep < 0) {
      ::close(fd_);
      throw Error(path + ": cannot read the existing content");
    }
    if (keep < size) {
      if (::ftruncate(fd_, keep) != 0) {
        const int err = errno;
        ::close(fd_);
        throw Error(path + ": cannot cut off an incomplete last line: " + Why(err));
      }
      truncated_bytes_ = static_cast<std::uint64_t>(size - keep);
      size = keep;
    }
  }
  size_ = static_cast<std::uint64_t>(size);
  had_content_ = size > 0;
}

AppendFile::~AppendFile() {
  try {
    Close();
  } catch (...) {  // a destructor must not throw; Close() is the way to see the error
  }
}

void AppendFile::Append(std::string_view records) {
  if (fd_ < 0) throw Error(path_ + ": append after close");
  const char* p = records.data();
  std::size_t left = records.size();
  while (left > 0) {
    const ssize_t n = ::write(fd_, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      // Never leave part of a record behind: cut back to the size before this call (a device
      // or a pipe holds nothing to cut).
      if (regular_ && ::ftruncate(fd_, static_cast<off_t>(size_)) != 0) {
        throw Error(path_ + ": cannot write: " + Why(err) +
                    "; cutting off the partial record failed too: " + Why(errno));
      }
      throw Error(path_ + ": cannot write: " + Why(err));
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  size_ += records.size();
  if (!dirty_) first_unsynced_ = std::chrono::steady_clock::now();
  dirty_ = true;
  if (fsync_interval_s_ == 0.0)
    Sync();
  else
    SyncIfDue();
}

void AppendFile::SyncIfDue() {
  if (!dirty_ || fd_ < 0 || fsync_interval_s_ < 0.0) return;
  const std::chrono::duration<double> age = std::chrono::steady_clock::now() - first_unsynced_;
  if (age.count() >= fsync_interval_s_) Sync();
}

void AppendFile::Sync() {
  if (fd_ < 0 || !dirty_) return;
  // EINVAL: a pipe or device that has nothing to sync.
  if (::fsync(fd_) != 0 && errno != EINVAL) throw Error(path_ + ": fsync failed: " + Why(errno));
  dirty_ = false;
  ++syncs_;
}

void AppendFile::Close() {
  if (fd_ < 0) return;
  const bool was_dirty = dirty_;
  int err = 0;
  if (was_dirty && ::fsync(fd_) != 0 && errno != EINVAL) err = errno;
  if (::close(fd_) != 0 && err == 0) err = errno;
  fd_ = -1;
  dirty_ = false;
  if (err != 0) throw Error(path_ + ": cannot close: " + Why(err));
}

}  // namespace sph
