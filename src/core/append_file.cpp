#include "sph/core/append_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

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

}  // namespace

AppendFile::AppendFile(const std::string& path, double fsync_interval_s)
    : path_(path), fsync_interval_s_(fsync_interval_s) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error(path + ": cannot open for appending: " + Why(errno));
  struct stat st {};
  if (::fstat(fd_, &st) != 0) {
    const int err = errno;
    ::close(fd_);
    throw Error(path + ": cannot stat: " + Why(err));
  }
  off_t size = st.st_size;
  if (size > 0 && S_ISREG(st.st_mode)) {
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
      // Never leave part of a record behind: cut back to the size before this call.
      if (::ftruncate(fd_, static_cast<off_t>(size_)) != 0) {
        throw Error(path_ + ": cannot write: " + Why(err) + "; cutting off the partial record failed too: " +
                    Why(errno));
      }
      throw Error(path_ + ": cannot write: " + Why(err));
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  size_ += records.size();
  if (!dirty_) first_unsynced_ = std::chrono::steady_clock::now();
  dirty_ = true;
  if (fsync_interval_s_ == 0.0) Sync();
  else SyncIfDue();
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
