#include "gnuplot.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <utility>

#include "sph/core/cleanup.hpp"
#include "sph/core/error.hpp"
#include "sph/internal/format.hpp"

namespace sph::apps {

using internal::Format;

std::string GnuplotQuoted(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("''") : std::string(1, c);
  return q + "'";
}

std::string GnuplotDoubleQuoted(const std::string& s) {
  std::string q = "\"";
  for (const char c : s) {
    if (c == '\n') {
      q += "\\n";
    } else {
      if (c == '"' || c == '\\') q += '\\';
      q += c;
    }
  }
  return q + "\"";
}

namespace {

// The script in a temporary file of the folder, removed when this goes (or by the signal cleanup).
class ScriptFile {
 public:
  ScriptFile(const std::string& folder, const std::string& script, const std::string& what) {
    path_ = (folder.empty() ? std::string(".") : folder) + "/.sph-plot.XXXXXX";
    const int fd = ::mkstemp(path_.data());
    if (fd < 0) throw Error(what + ": cannot write the plot's script into '" + folder + "': " + std::strerror(errno));
    cleanup_ = RegisterTempFile(path_);
    const char* p = script.data();
    std::size_t left = script.size();
    int err = 0;
    while (left > 0 && err == 0) {
      const ssize_t n = ::write(fd, p, left);
      if (n < 0 && errno != EINTR) err = errno;
      if (n > 0) {
        p += n;
        left -= static_cast<std::size_t>(n);
      }
    }
    if (::close(fd) != 0 && err == 0) err = errno;
    if (err != 0) {
      Remove();
      throw Error(what + ": cannot write the plot's script: " + std::strerror(err));
    }
  }
  ~ScriptFile() { Remove(); }
  ScriptFile(const ScriptFile&) = delete;
  ScriptFile& operator=(const ScriptFile&) = delete;
  /// The name gnuplot opens from within the folder.
  std::string name() const { return path_.substr(path_.find_last_of('/') + 1); }

 private:
  void Remove() {
    if (!path_.empty()) ::unlink(path_.c_str());
    UnregisterTempFile(cleanup_);
    cleanup_ = -1;
  }
  std::string path_;
  int cleanup_ = -1;
};

using Clock = std::chrono::steady_clock;

// Milliseconds left until `deadline`, at least 0.
int MsLeft(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return left <= 0 ? 0 : left > 1000000 ? 1000000 : static_cast<int>(left);
}

// Appends what the child writes to `output` (up to 64 KiB) until it closes the pipe; false when
// `deadline` comes first.
bool ReadUntilClosed(int fd, Clock::time_point deadline, std::string& output) {
  char buf[4096];
  for (;;) {
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, MsLeft(deadline));
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) return false;
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return true;
    if (output.size() < 64 * 1024) output.append(buf, static_cast<std::size_t>(n));
  }
}

// Waits for the child to end without reaping it (its pid stays its own until then); false when
// `deadline` comes first.
bool AwaitExit(pid_t pid, Clock::time_point deadline) {
  for (;;) {
    siginfo_t info{};
    const int rc = ::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT);
    if (rc == 0 && info.si_pid == pid) return true;
    if (rc < 0 && errno != EINTR) return true;  // nothing to wait for: waitpid() says why
    if (MsLeft(deadline) == 0) return false;
    ::usleep(10000);
  }
}

// The child, started in a process group of its own with the signals the cleanup handles blocked,
// and registered with the cleanup before they are unblocked.
class Child {
 public:
  Child(std::vector<char*>& argv, const std::string& folder, int out_fd, const std::string& what) {
    sigset_t block, saved;
    sigemptyset(&block);
    for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) sigaddset(&block, sig);
    ::sigprocmask(SIG_BLOCK, &block, &saved);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::setpgid(0, 0);
      std::signal(SIGPIPE, SIG_DFL);  // the program's own choice (sph apps ignore it), not gnuplot's
      ::sigprocmask(SIG_SETMASK, &saved, nullptr);
      const int null_in = ::open("/dev/null", O_RDONLY);
      if (null_in >= 0) ::dup2(null_in, STDIN_FILENO);
      ::dup2(out_fd, STDOUT_FILENO);
      ::dup2(out_fd, STDERR_FILENO);
      if (::chdir(folder.c_str()) != 0) ::_exit(126);
      ::execvp(argv[0], argv.data());
      ::_exit(127);
    }
    const int err = errno;
    if (pid_ > 0) {
      ::setpgid(pid_, pid_);  // either side may win the race; both set the same group
      cleanup_ = RegisterChildProcess(pid_);
    }
    ::sigprocmask(SIG_SETMASK, &saved, nullptr);
    if (pid_ < 0) throw Error(what + ": cannot run gnuplot: " + std::strerror(err));
  }
  ~Child() {
    if (pid_ > 0) Kill();
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  pid_t pid() const { return pid_; }
  /// Kills the child's process group and waits for the child.
  void Kill() {
    ::kill(-pid_, SIGKILL);
    ::kill(pid_, SIGKILL);
    Reap();
  }
  /// Waits for the child (ended, or about to) and returns its wait status.
  int Reap() {
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
    UnregisterChildProcess(cleanup_);
    cleanup_ = -1;
    pid_ = -1;
    return status;
  }

 private:
  pid_t pid_ = -1;
  int cleanup_ = -1;
};

// The pipe the child writes its messages into; the read end stays, closed when this goes.
struct OutputPipe {
  explicit OutputPipe(const std::string& what) {
    if (::pipe2(fd, O_CLOEXEC) != 0) throw Error(what + ": cannot run gnuplot: " + std::strerror(errno));
  }
  ~OutputPipe() {
    for (int f : fd) {
      if (f >= 0) ::close(f);
    }
  }
  void CloseWriteEnd() { ::close(std::exchange(fd[1], -1)); }
  int fd[2] = {-1, -1};
};

}  // namespace

PlotFolder::PlotFolder(std::string dir)
    : dir_(std::move(dir)), existed_(dir_.empty() || ::access(dir_.c_str(), F_OK) == 0) {}

PlotFolder::~PlotFolder() {
  if (!existed_) ::rmdir(dir_.c_str());  // only when empty
}

void PlotFolder::Make() const {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec) throw Error(dir_ + ": cannot create the folder: " + ec.message());
}

void GnuplotRun::Set(const std::string& variable, const std::string& file) {
  const std::size_t slash = file.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : file.substr(0, slash == 0 ? 1 : slash);
  struct stat in_dir {};
  struct stat in_folder {};
  if (::stat(dir.c_str(), &in_dir) == 0 && ::stat(folder.c_str(), &in_folder) == 0 &&
      in_dir.st_dev == in_folder.st_dev && in_dir.st_ino == in_folder.st_ino) {
    variables.emplace_back(variable, file.substr(slash + 1));  // npos + 1: the whole name
    return;
  }
  std::error_code ec;
  const std::filesystem::path absolute = std::filesystem::absolute(file, ec);
  if (ec) throw Error(file + ": " + ec.message());
  variables.emplace_back(variable, absolute.string());
}

void GnuplotRun::Draw(const std::string& variable, const std::string& path, OutputFiles& files) {
  const std::string file = files.StageProduced(path);
  Set(variable, file);
  images.emplace_back(path, file);
}

void RunGnuplot(const GnuplotRun& run, const std::string& what) {
  const ScriptFile script(run.folder, run.script, what);
  std::string settings;
  for (const auto& [name, value] : run.variables) settings += name + " = " + GnuplotQuoted(value) + "; ";
  std::vector<std::string> args = {run.program};
  if (!settings.empty()) args.insert(args.end(), {"-e", settings});
  args.push_back(script.name());
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(run.timeout_s));
  OutputPipe pipe(what);
  Child child(argv, run.folder, pipe.fd[1], what);
  pipe.CloseWriteEnd();
  std::string output;
  if (!ReadUntilClosed(pipe.fd[0], deadline, output) || !AwaitExit(child.pid(), deadline)) {
    child.Kill();
    throw Error(what + ": gnuplot did not finish " + run.description + " within " + Format("%g", run.timeout_s) +
                " s and was stopped; give it longer with --plot-timeout-s" +
                (output.empty() ? std::string() : " (it printed: " + output + ")"));
  }
  const int status = child.Reap();
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (code == 127) {
    throw Error(what + ": cannot draw " + run.description + ": the program '" + run.program +
                "' was not found; install gnuplot (Debian: apt-get install gnuplot-nox)");
  }
  if (code == 126) throw Error(what + ": cannot enter the folder '" + run.folder + "' to draw " + run.description);
  if (code != 0) {
    throw Error(what + ": gnuplot failed (" +
                (code < 0 ? std::string("killed by a signal") : "exit " + std::to_string(code)) + ")" +
                (output.empty() ? std::string() : ": " + output));
  }
  for (const auto& [path, file] : run.images) {
    struct stat st {};
    if (::stat(file.c_str(), &st) != 0 || st.st_size == 0) {
      throw Error(path + ": gnuplot ended without drawing " + run.description + " into it (the image is empty)" +
                  (output.empty() ? std::string() : ": " + output));
    }
  }
}

}  // namespace sph::apps
