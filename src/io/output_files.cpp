#include "sph/io/output_files.hpp"

#include <fcntl.h>
#include <limits.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <streambuf>

#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/io/cleanup.hpp"

namespace sph {
namespace {

std::string ErrnoText(int err) { return std::strerror(err); }

// Writes all of [data, data + size) to `fd`, retrying on EINTR and short writes; 0 or an errno.
int WriteAll(int fd, const char* data, std::size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return 0;
}

// What a terminal would act on instead of showing it, written so that it shows: the C0 controls
// but tab and line feed, DEL and the C1 controls (U+0080 to U+009F) as \u00hh (JSON's own escape,
// so a JSON text stays JSON with the same strings), bytes that are no UTF-8 as \xHH. Text a file
// brought in (a header field in a report) can then neither move the cursor, retitle or clear the
// terminal nor hide what is printed. The bytes [begin, end) are escaped into `out`; the return is
// where an unfinished character at the end starts (kept for the next bytes), or `end` when `last`.
const char* EscapeControls(const char* begin, const char* end, bool last, std::string& out) {
  char hex[8];
  for (const char* p = begin; p < end;) {
    const auto c = static_cast<unsigned char>(*p);
    if (c < 0x80) {
      if ((c < 0x20 && c != '\n' && c != '\t') || c == 0x7F) {
        std::snprintf(hex, sizeof hex, "\\u%04x", c);
        out += hex;
      } else {
        out += static_cast<char>(c);
      }
      ++p;
      continue;
    }
    const std::size_t n = Utf8CharLength(std::string_view(p, static_cast<std::size_t>(end - p)));
    if (n == 0) {
      const std::size_t want = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : 2;
      bool unfinished = !last && c >= 0xC2 && c <= 0xF4 && static_cast<std::size_t>(end - p) < want;
      for (const char* q = p + 1; unfinished && q < end; ++q) {
        unfinished = (static_cast<unsigned char>(*q) & 0xC0) == 0x80;
      }
      if (unfinished) return p;
      std::snprintf(hex, sizeof hex, "\\x%02X", c);
      out += hex;
      ++p;
    } else if (n == 2 && c == 0xC2 && static_cast<unsigned char>(p[1]) < 0xA0) {
      std::snprintf(hex, sizeof hex, "\\u%04x", static_cast<unsigned char>(p[1]));
      out += hex;
      p += 2;
    } else {
      out.append(p, n);
      p += n;
    }
  }
  return end;
}

// An output stream buffer over a file descriptor that remembers the first write error; with
// `escape`, what it writes goes through EscapeControls() (standard output).
class FdStreamBuf : public std::streambuf {
 public:
  explicit FdStreamBuf(int fd, bool escape = false) : fd_(fd), escape_(escape) {
    setp(buffer_, buffer_ + sizeof buffer_);
  }
  int error() const { return error_; }

 protected:
  int overflow(int c) override {
    if (!Drain(false)) return traits_type::eof();
    if (!traits_type::eq_int_type(c, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(c);
      pbump(1);
    }
    return traits_type::not_eof(c);
  }
  int sync() override { return Drain(true) ? 0 : -1; }

 private:
  // Writes the buffer; `last`: nothing follows soon (a flush), so an unfinished character is
  // escaped rather than kept.
  bool Drain(bool last) {
    const char* end = pptr();
    if (!escape_) {
      if (error_ == 0 && end > pbase()) error_ = WriteAll(fd_, pbase(), static_cast<std::size_t>(end - pbase()));
      setp(buffer_, buffer_ + sizeof buffer_);
      return error_ == 0;
    }
    std::string out;
    const char* kept = EscapeControls(pbase(), end, last, out);
    if (error_ == 0 && !out.empty()) error_ = WriteAll(fd_, out.data(), out.size());
    const auto left = static_cast<int>(end - kept);
    std::memmove(buffer_, kept, static_cast<std::size_t>(left));
    setp(buffer_, buffer_ + sizeof buffer_);
    pbump(left);
    return error_ == 0;
  }

  int fd_;
  bool escape_;
  int error_ = 0;
  char buffer_[1 << 16];
};

std::string Shown(const std::string& path) { return path == "-" ? "- (standard output)" : path; }

// What a name is now: the file itself (a symbolic link followed), or nothing.
struct Target {
  bool exists = false;
  struct stat st {};
  std::string path;  // the name to write: the link's target for a symbolic link
};

Target Resolve(const std::string& path) {
  Target t;
  t.path = path;
  struct stat lst {};
  if (::lstat(path.c_str(), &lst) != 0) {
    if (errno == ENOENT) return t;
    throw Error(path + ": cannot write: " + ErrnoText(errno));
  }
  if (S_ISLNK(lst.st_mode)) {
    char real[PATH_MAX];
    if (::realpath(path.c_str(), real) == nullptr) {
      throw Error(path + ": is a symbolic link to a file that cannot be reached (" + ErrnoText(errno) + ")");
    }
    t.path = real;
    if (::stat(real, &t.st) != 0) throw Error(path + ": cannot write: " + ErrnoText(errno));
  } else {
    t.st = lst;
  }
  t.exists = true;
  return t;
}

// An existing regular file `path` (`real` the file itself) that the user may not write is not
// replaced, as cp and sort -o refuse: its permissions deny the user writing it (access(2)), or it
// grants writing to nobody (no w bit, which root could otherwise override). Throws sph::Error.
void CheckReplaceable(const std::string& path, const std::string& real, mode_t mode) {
  if (!S_ISREG(mode)) return;
  const int denied = ::access(real.c_str(), W_OK) != 0 ? errno : 0;
  if (denied == 0 && (mode & 0222) != 0) return;
  char octal[8];
  std::snprintf(octal, sizeof octal, "%04o", static_cast<unsigned>(mode & 07777));
  throw Error(path + ": cannot write: " + (denied != 0 ? ErrnoText(denied) : std::string("it is read-only")) +
              " (mode " + octal +
              "): refusing to replace a file that may not be written; make it writable or give another name");
}

const char* RefusedKind(mode_t mode) {
  if (S_ISDIR(mode)) return "is a directory; give the name of a file";
  if (S_ISBLK(mode)) return "is a block device: refusing to write onto it";
  if (S_ISSOCK(mode)) return "is a socket: refusing to write onto it";
  return nullptr;
}

}  // namespace

// ---- RunPaths -------------------------------------------------------------------------------------

struct RunPaths::Entry {
  std::string name, path;
  bool is_std = false;  // "-"
  bool exists = false;
  dev_t dev = 0;
  ino_t ino = 0;
  mode_t mode = 0;
  std::string normal;  // absolute, links and dots resolved as far as the path exists

  std::string Describe() const { return name + " " + Shown(path); }
};

namespace {

std::shared_ptr<const RunPaths::Entry> Identify(const std::string& name, const std::string& path, bool output) {
  auto e = std::make_shared<RunPaths::Entry>();
  e->name = name;
  e->path = path;
  e->is_std = path == "-";
  struct stat st {};
  const int found = e->is_std ? ::fstat(output ? STDOUT_FILENO : STDIN_FILENO, &st) : ::stat(path.c_str(), &st);
  if (found == 0) {
    e->exists = true;
    e->dev = st.st_dev;
    e->ino = st.st_ino;
    e->mode = st.st_mode;
  }
  if (!e->is_std) {
    std::error_code ec;
    const auto normal = std::filesystem::weakly_canonical(std::filesystem::absolute(path, ec), ec);
    if (!ec) e->normal = normal.lexically_normal().string();
  }
  return e;
}

bool SameFile(const RunPaths::Entry& a, const RunPaths::Entry& b) {
  if (a.exists && b.exists) return a.dev == b.dev && a.ino == b.ino;
  if (a.is_std || b.is_std) return a.is_std && b.is_std;
  return !a.normal.empty() && a.normal == b.normal;
}

// Character devices (/dev/null, a terminal) may take several outputs.
bool Shareable(const RunPaths::Entry& e) { return e.exists && S_ISCHR(e.mode); }

}  // namespace

RunPaths& RunPaths::Input(const std::string& name, const std::string& path) {
  if (!path.empty()) inputs_.push_back(Identify(name, path, false));
  return *this;
}

RunPaths& RunPaths::Output(const std::string& name, const std::string& path) {
  if (path.empty()) return *this;
  const auto out = Identify(name, path, true);
  if (out->exists && !out->is_std) CheckReplaceable(out->Describe(), path, out->mode);
  if (!Shareable(*out)) {
    for (const auto& in : inputs_) {
      if (SameFile(*out, *in)) {
        throw Error(out->Describe() + " is also the input " + in->Describe() +
                    ": an output never replaces an input; choose another name");
      }
    }
    for (const auto& other : outputs_) {
      if (!SameFile(*out, *other)) continue;
      if (out->is_std && other->is_std) {
        throw Error(other->name + " and " + out->name + " both write to standard output: give one of them a file");
      }
      throw Error(other->Describe() + " and " + out->Describe() +
                  " are the same file: give each output a file of its own");
    }
  }
  outputs_.push_back(out);
  return *this;
}

// ---- OutputFiles ----------------------------------------------------------------------------------

struct OutputFiles::Staged {
  enum Kind { kRename, kDirect, kStdout } kind = kRename;
  std::string path;     // as given, for messages
  std::string target;   // the name renamed onto or written to
  std::string tmp;      // kRename: the temporary file
  int cleanup = -1;     // its registration
  std::string content;  // kDirect, kStdout

  void RemoveTemp() {
    if (!tmp.empty()) ::unlink(tmp.c_str());
    UnregisterTempFile(cleanup);
    tmp.clear();
    cleanup = -1;
  }
  ~Staged() { RemoveTemp(); }
};

OutputFiles::OutputFiles(std::ostream& standard_output) : standard_output_(standard_output), run_output_(true) {}
OutputFiles::OutputFiles() : standard_output_(std::cout), run_output_(false) {}
OutputFiles::~OutputFiles() = default;

namespace {

// A new temporary file beside `target` (".name.tmp.XXXXXX"), registered for cleanup; its
// descriptor is returned open.
int CreateTemp(const std::string& path, const std::string& target, std::string* tmp, int* cleanup) {
  const std::size_t slash = target.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : target.substr(0, slash == 0 ? 1 : slash);
  const std::string base = slash == std::string::npos ? target : target.substr(slash + 1);
  std::string name = (dir == "/" ? std::string("/") : dir + "/") + "." + base + ".tmp.XXXXXX";
  const int fd = ::mkstemp(name.data());
  if (fd < 0) throw Error(path + ": cannot create a file in '" + dir + "': " + ErrnoText(errno));
  *tmp = name;
  *cleanup = RegisterTempFile(name);
  return fd;
}

}  // namespace

void OutputFiles::Stage(const std::string& path, const std::function<void(std::ostream&)>& write) {
  auto s = std::make_unique<Staged>();
  s->path = path;
  s->target = path;
  mode_t mode = 0644;
  if (path == "-") {
    s->kind = Staged::kStdout;
  } else {
    const Target t = Resolve(path);
    s->target = t.path;
    if (t.exists) {
      if (const char* why = RefusedKind(t.st.st_mode)) throw Error(path + ": " + why);
      if (S_ISREG(t.st.st_mode)) {
        CheckReplaceable(path, t.path, t.st.st_mode);
        mode = t.st.st_mode & 07777;
      } else {
        s->kind = Staged::kDirect;  // a FIFO or a character device: written, never replaced
      }
    }
  }
  if (s->kind != Staged::kRename) {
    std::ostringstream buffer;
    buffer.precision(17);
    write(buffer);
    s->content = buffer.str();
    staged_.push_back(std::move(s));
    return;
  }
  const int fd = CreateTemp(path, s->target, &s->tmp, &s->cleanup);
  int err = 0;
  {
    FdStreamBuf buf(fd);
    std::ostream out(&buf);
    out.precision(17);
    try {
      write(out);  // on an exception `s` removes the temporary file
    } catch (...) {
      ::close(fd);
      throw;
    }
    out.flush();
    err = buf.error();
    if (err == 0 && !out) err = EIO;
  }
  if (err == 0 && ::fchmod(fd, mode) != 0) err = errno;
  if (err == 0 && ::fsync(fd) != 0) err = errno;
  if (::close(fd) != 0 && err == 0) err = errno;
  if (err != 0) throw Error(path + ": cannot write: " + ErrnoText(err));
  staged_.push_back(std::move(s));
}

std::string OutputFiles::StageProduced(const std::string& path) {
  auto s = std::make_unique<Staged>();
  s->path = path;
  const Target t = Resolve(path);
  s->target = t.path;
  if (t.exists && !S_ISREG(t.st.st_mode)) {
    const char* why = RefusedKind(t.st.st_mode);
    throw Error(path + ": " + (why ? why : "is not a regular file: an image is written to a regular file only"));
  }
  if (t.exists) CheckReplaceable(path, t.path, t.st.st_mode);
  const int fd = CreateTemp(path, s->target, &s->tmp, &s->cleanup);
  const int err = ::fchmod(fd, t.exists ? t.st.st_mode & 07777 : 0644) != 0 ? errno : 0;
  ::close(fd);
  if (err != 0) throw Error(path + ": cannot write: " + ErrnoText(err));
  std::string tmp = s->tmp;
  staged_.push_back(std::move(s));
  return tmp;
}

std::string OutputFiles::StagedName(const std::string& path) const {
  for (const auto& s : staged_) {
    if (s->path == path && s->kind == Staged::kRename) return s->tmp;
  }
  throw Error(path + ": not staged as a regular file");
}

void OutputFiles::Commit() {
  // The writes that can fail first, while every regular file is still untouched: standard
  // output, all the run wrote to it, ...
  bool to_standard_output = run_output_;
  for (auto& s : staged_) {
    if (s->kind != Staged::kStdout) continue;
    standard_output_.write(s->content.data(), static_cast<std::streamsize>(s->content.size()));
    to_standard_output = true;
  }
  if (to_standard_output) {
    standard_output_.flush();
    const std::string why = &standard_output_ == &std::cout ? FlushStandardOutput() : "";
    if (!why.empty() || !standard_output_) {
      throw Error("cannot write to standard output: " + (why.empty() ? std::string("write error") : why));
    }
  }
  // ... the FIFOs and character devices, ...
  for (auto& s : staged_) {
    if (s->kind == Staged::kDirect) {
      const int fd = ::open(s->target.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
      int err = fd < 0 ? errno : WriteAll(fd, s->content.data(), s->content.size());
      if (fd >= 0 && ::close(fd) != 0 && err == 0) err = errno;
      if (err != 0) throw Error(s->path + ": cannot write: " + ErrnoText(err));
    }
  }
  // ... and only then the renames.
  for (auto& s : staged_) {
    if (s->kind != Staged::kRename) continue;
    if (std::rename(s->tmp.c_str(), s->target.c_str()) != 0) {
      throw Error(s->path + ": cannot write: " + ErrnoText(errno));
    }
    UnregisterTempFile(s->cleanup);
    s->cleanup = -1;
    s->tmp.clear();
  }
  staged_.clear();
}

bool SameFile(const std::string& a, const std::string& b) {
  return SameFile(*Identify("", a, false), *Identify("", b, false));
}

void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write) {
  OutputFiles files;
  files.Stage(path, write);
  files.Commit();
}

struct StandardOutput::Buffer : FdStreamBuf {
  Buffer() : FdStreamBuf(STDOUT_FILENO, true) {}
  bool told = false;  // the failure was reported
};

namespace {
StandardOutput* g_standard_output = nullptr;
}  // namespace

StandardOutput::StandardOutput() : buffer_(std::make_unique<Buffer>()) {
  std::cout.flush();
  saved_ = std::cout.rdbuf(buffer_.get());
  g_standard_output = this;
}

StandardOutput::~StandardOutput() {
  std::cout.flush();
  std::cout.rdbuf(saved_);
  g_standard_output = nullptr;
}

std::string FlushStandardOutput() {
  std::cout.flush();
  if (g_standard_output != nullptr) {
    StandardOutput::Buffer& b = *g_standard_output->buffer_;
    b.pubsync();
    std::cout.clear();
    if (b.error() == 0 || b.told) return "";
    b.told = true;
    return ErrnoText(b.error());
  }
  errno = 0;
  const bool failed = std::fflush(stdout) != 0 || std::ferror(stdout) != 0 || !std::cout;
  if (!failed) return "";
  std::clearerr(stdout);
  std::cout.clear();
  return errno != 0 ? ErrnoText(errno) : "write error";
}

}  // namespace sph
