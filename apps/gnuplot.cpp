#include "gnuplot.hpp"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "sph/core/cleanup.hpp"
#include "sph/core/error.hpp"

namespace sph::apps {

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

// Everything the child writes, up to 64 KiB, until it closes the pipe.
std::string ReadAll(int fd) {
  std::string output;
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    if (output.size() < 64 * 1024) output.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return output;
}

}  // namespace

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

  int out_pipe[2];
  if (::pipe2(out_pipe, O_CLOEXEC) != 0) throw Error(what + ": cannot run gnuplot: " + std::strerror(errno));
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int err = errno;
    ::close(out_pipe[0]);
    ::close(out_pipe[1]);
    throw Error(what + ": cannot run gnuplot: " + std::strerror(err));
  }
  if (pid == 0) {
    const int null_in = ::open("/dev/null", O_RDONLY);
    if (null_in >= 0) ::dup2(null_in, STDIN_FILENO);
    ::dup2(out_pipe[1], STDOUT_FILENO);
    ::dup2(out_pipe[1], STDERR_FILENO);
    if (::chdir(run.folder.c_str()) != 0) ::_exit(126);
    ::execvp(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(out_pipe[1]);
  const std::string output = ReadAll(out_pipe[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
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
}

}  // namespace sph::apps
