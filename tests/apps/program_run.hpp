// Running an installed-style program as a user would, for the bad-input matrices: in a folder
// of its own, with its standard output and error captured (or standard output sent to a file
// of the folder, such as a full device, or to a pipe nobody reads), and the folder's content
// compared before and after.
#ifndef SPH_TESTS_APPS_PROGRAM_RUN_HPP_
#define SPH_TESTS_APPS_PROGRAM_RUN_HPP_

#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.hpp"

namespace sph::testing {

struct ProgramResult {
  int code = -1;  ///< exit code, or 128 + signal
  std::string out;
  std::string err;
};

/// A standard output that is a pipe whose reader has gone, as after `| head -c 10`.
inline const std::string kClosedPipe = "|closed";

/// Starts `argv` in `folder`, as a shell would (SIGPIPE at its default); standard output goes to
/// `stdout_path` (a name in the folder, or kClosedPipe) when given, else to a file beside the
/// folder that FinishProgram() reads. Standard input is /dev/null. `env` holds "NAME=value"
/// settings for the program's environment.
inline pid_t StartProgram(const std::vector<std::string>& argv, const std::string& folder,
                          const std::string& stdout_path = "", const std::vector<std::string>& env = {}) {
  const std::string capture = folder + ".stdout", errors = folder + ".stderr";
  int closed[2] = {-1, -1};
  if (stdout_path == kClosedPipe && ::pipe(closed) != 0) return -1;
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (::chdir(folder.c_str()) != 0) ::_exit(125);
    ::signal(SIGPIPE, SIG_DFL);
    const int in = ::open("/dev/null", O_RDONLY);
    const int out = stdout_path == kClosedPipe ? closed[1]
                                               : ::open(stdout_path.empty() ? capture.c_str() : stdout_path.c_str(),
                                                        O_WRONLY | (stdout_path.empty() ? O_CREAT | O_TRUNC : 0), 0644);
    const int err = ::open(errors.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (in < 0 || out < 0 || err < 0) ::_exit(125);
    if (closed[0] >= 0) ::close(closed[0]);  // nobody reads
    ::dup2(in, 0);
    ::dup2(out, 1);
    ::dup2(err, 2);
    for (const std::string& e : env) ::putenv(const_cast<char*>(e.c_str()));
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    ::_exit(126);
  }
  for (int fd : closed) {
    if (fd >= 0) ::close(fd);
  }
  return pid;
}

/// Waits for a program StartProgram() started and collects what it printed.
inline ProgramResult FinishProgram(pid_t pid, const std::string& folder, const std::string& stdout_path = "") {
  const std::string capture = folder + ".stdout", errors = folder + ".stderr";
  ProgramResult r;
  int status = 0;
  if (pid > 0 && ::waitpid(pid, &status, 0) == pid) {
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  r.out = stdout_path.empty() ? ReadWholeFile(capture) : "";
  r.err = ReadWholeFile(errors);
  ::unlink(capture.c_str());
  ::unlink(errors.c_str());
  return r;
}

/// Runs `argv` in `folder` (StartProgram()) and waits for it.
inline ProgramResult RunProgram(const std::vector<std::string>& argv, const std::string& folder,
                                const std::string& stdout_path = "", const std::vector<std::string>& env = {}) {
  return FinishProgram(StartProgram(argv, folder, stdout_path, env), folder, stdout_path);
}

/// Installs `script` as the program `gnuplot` in a folder beside `folder` (outside it, so that the
/// folder's content stays as it was) and returns the PATH setting that finds it first.
inline std::string FakeGnuplot(const std::string& folder, const std::string& script) {
  const std::string bin = folder + ".bin";
  ::mkdir(bin.c_str(), 0755);
  std::ofstream(bin + "/gnuplot") << script;
  ::chmod((bin + "/gnuplot").c_str(), 0755);
  const char* path = std::getenv("PATH");
  return "PATH=" + bin + ":" + (path ? path : "/usr/bin:/bin");
}

/// True when a program named `name` is found on PATH.
inline bool OnPath(const std::string& name) {
  return std::system(("command -v " + name + " > /dev/null 2>&1").c_str()) == 0;
}

/// What a folder holds: every entry (not following links) with its type, and for a regular file
/// its content, for a device its numbers, for a link its target.
inline std::map<std::string, std::string> FolderState(const std::string& folder) {
  std::map<std::string, std::string> state;
  namespace fs = std::filesystem;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(folder, ec); it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    const std::string path = it->path().string();
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0) continue;
    std::string what;
    if (S_ISREG(st.st_mode)) {
      what = "file " + ReadWholeFile(path);
    } else if (S_ISDIR(st.st_mode)) {
      what = "dir";
    } else if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) {
      what = std::string(S_ISCHR(st.st_mode) ? "char " : "block ") + std::to_string(major(st.st_rdev)) + "," +
             std::to_string(minor(st.st_rdev));
    } else if (S_ISLNK(st.st_mode)) {
      what = "link " + fs::read_symlink(path, ec).string();
    } else if (S_ISFIFO(st.st_mode)) {
      what = "fifo";
    } else {
      what = "other";
    }
    state[path.substr(folder.size() + 1)] = what;
  }
  return state;
}

/// Makes the device nodes a case may write to in `folder`, never those of /dev: a full device
/// (full), a null device (null) and a block device (disk). False when they cannot be made here
/// (without CAP_MKNOD).
inline bool MakeDeviceNodes(const std::string& folder) {
  return ::mknod((folder + "/full").c_str(), S_IFCHR | 0666, makedev(1, 7)) == 0 &&
         ::mknod((folder + "/null").c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0 &&
         ::mknod((folder + "/disk").c_str(), S_IFBLK | 0600, makedev(7, 0)) == 0;
}

/// A Ceres or glog log line ("W20261201 19:45:19.725777  9080 residual_block.cc:129]") or
/// glog's warning about its initialisation: what a user must never see.
inline bool HasSolverLog(const std::string& text) {
  if (text.find("Logging before InitGoogleLogging") != std::string::npos) return true;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.size() > 9 && std::string("IWEF").find(line[0]) != std::string::npos &&
        line.find_first_not_of("0123456789", 1) == 9 && line.find(".cc:") != std::string::npos) {
      return true;
    }
  }
  return false;
}

/// One case of a bad-input matrix: a program's arguments, run in a folder of its own.
struct MatrixCase {
  std::string name;
  std::vector<std::string> args;  ///< after the program; run in the case's folder
  int exit = 2;
  std::string message;                            ///< expected in stderr ("" when none is)
  std::map<std::string, std::string> files = {};  ///< written into the folder before the run
  std::vector<std::string> writes = {};           ///< outputs a successful run makes or continues
  std::string stdout_to = "";                     ///< a name in the folder that takes standard output, or kClosedPipe
  /// A script run as gnuplot (FakeGnuplot()); "" runs the gnuplot installed, when a case draws.
  std::string gnuplot = "";
  std::map<std::string, std::string> links = {};  ///< symbolic links made in the folder: name, target
  /// Expected in what the run wrote, by where: "-" standard output, else a file of the folder.
  std::map<std::string, std::string> shows = {};
  std::vector<std::string> read_only = {};  ///< files of the folder made read-only (mode 0444) before the run
};

/// The first byte of `text` that a terminal would act on rather than show (a control character
/// but tab and line feed, DEL, a C1 control U+0080..U+009F, or a byte that is not UTF-8), or npos.
inline std::size_t RawControlAt(const std::string& text) {
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if ((c < 0x20 && c != '\n' && c != '\t') || c == 0x7F) return i;
    if (c < 0x80) continue;
    const std::size_t n = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : c >= 0xC2 ? 2 : 0;
    if (n == 0 || i + n > text.size() || c > 0xF4) return i;
    for (std::size_t k = 1; k < n; ++k) {
      if ((static_cast<unsigned char>(text[i + k]) & 0xC0) != 0x80) return i;
    }
    if (c == 0xC2 && static_cast<unsigned char>(text[i + 1]) < 0xA0) return i;
    i += n - 1;
  }
  return std::string::npos;
}

inline std::ostream& operator<<(std::ostream& os, const MatrixCase& c) { return os << c.name; }

/// The case's name as the parameterised test's name.
inline std::string CaseName(const ::testing::TestParamInfo<MatrixCase>& info) { return info.param.name; }

/// True when the case draws a plot with the gnuplot installed.
inline bool UsesRealGnuplot(const MatrixCase& c) {
  bool draws = false;
  for (const std::string& a : c.args) draws |= a == "--plot-dir" || a == "--plot";
  return draws && c.gnuplot.empty();
}

/// True when the case names one of the folder's device nodes (MakeDeviceNodes()).
inline bool UsesDeviceNodes(const MatrixCase& c) {
  bool uses = c.stdout_to == "full";
  for (const std::string& a : c.args) uses |= a == "full" || a == "null" || a == "disk";
  return uses;
}

/// Runs `program` with the case's arguments in `dir` (which holds the case's files) and checks the
/// exit code, the message, what it shows, that no control character reaches standard output or
/// error raw, and that the folder is byte for byte as before, apart from the case's outputs, each
/// of which must be written (made, or changed).
inline ProgramResult RunMatrixCase(const char* program, const MatrixCase& c, const std::string& dir) {
  for (const auto& [name, target] : c.links)
    EXPECT_EQ(::symlink(target.c_str(), (dir + "/" + name).c_str()), 0) << name;
  for (const std::string& name : c.read_only) EXPECT_EQ(::chmod((dir + "/" + name).c_str(), 0444), 0) << name;
  std::vector<std::string> env;
  if (!c.gnuplot.empty()) env.push_back(FakeGnuplot(dir, c.gnuplot));
  const auto before = FolderState(dir);
  std::vector<std::string> argv = {program};
  argv.insert(argv.end(), c.args.begin(), c.args.end());
  const ProgramResult r = RunProgram(argv, dir, c.stdout_to, env);
  EXPECT_EQ(r.code, c.exit) << r.err;
  if (!c.message.empty()) {
    EXPECT_THAT(r.err, ::testing::HasSubstr(c.message));
  }
  for (const auto& [where, text] : c.shows) {
    EXPECT_THAT(where == "-" ? r.out : ReadWholeFile(dir + "/" + where), ::testing::HasSubstr(text)) << where;
  }
  // Whatever a file held, nothing reaches the user's terminal raw.
  EXPECT_EQ(RawControlAt(r.out), std::string::npos) << "standard output: " << r.out.substr(0, 2000);
  EXPECT_EQ(RawControlAt(r.err), std::string::npos) << "standard error: " << r.err.substr(0, 2000);
  auto after = FolderState(dir);
  auto unchanged = before;
  for (const std::string& made : c.writes) {
    EXPECT_TRUE(after.count(made)) << made << " was not written";
    EXPECT_NE(after[made], before.count(made) ? before.at(made) : "") << made << " was not written";
    after.erase(made);
    unchanged.erase(made);
  }
  EXPECT_EQ(after, unchanged) << "the folder changed";
  return r;
}

}  // namespace sph::testing

#endif  // SPH_TESTS_APPS_PROGRAM_RUN_HPP_
