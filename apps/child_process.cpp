#include "child_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <utility>

#include "sph/io/cleanup.hpp"
#include "sph/core/error.hpp"

namespace sph::apps {

// The script in a temporary file of the folder, removed when this goes (or by the signal cleanup).
ScriptFile::ScriptFile(const std::string& folder, const std::string& script, const std::string& what) {
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

ScriptFile::~ScriptFile() { Remove(); }

std::string ScriptFile::name() const { return path_.substr(path_.find_last_of('/') + 1); }

void ScriptFile::Remove() {
  if (!path_.empty()) ::unlink(path_.c_str());
  UnregisterTempFile(cleanup_);
  cleanup_ = -1;
}

namespace {

// Milliseconds left until `deadline`, at least 0.
int MsLeft(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return left <= 0 ? 0 : left > 1000000 ? 1000000 : static_cast<int>(left);
}

}  // namespace

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

Child::Child(std::vector<char*>& argv, const std::string& folder, int out_fd, const std::string& what) {
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
Child::~Child() {
  if (pid_ > 0) Kill();
}

void Child::Kill() {
  ::kill(-pid_, SIGKILL);
  ::kill(pid_, SIGKILL);
  Reap();
}

int Child::Reap() {
  int status = 0;
  while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  UnregisterChildProcess(cleanup_);
  cleanup_ = -1;
  pid_ = -1;
  return status;
}

OutputPipe::OutputPipe(const std::string& what) {
  if (::pipe2(fd, O_CLOEXEC) != 0) throw Error(what + ": cannot run gnuplot: " + std::strerror(errno));
}

OutputPipe::~OutputPipe() {
  for (int f : fd) {
    if (f >= 0) ::close(f);
  }
}

void OutputPipe::CloseWriteEnd() { ::close(std::exchange(fd[1], -1)); }

}  // namespace sph::apps
