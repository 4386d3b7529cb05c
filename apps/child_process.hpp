// The pieces of a run of gnuplot as a child process (RunGnuplot(), gnuplot.hpp): its script in a
// temporary file, the pipe of its messages, the child in a process group of its own, and the
// waits, each within a deadline. Each piece registers what it makes with the signal cleanup
// (sph/io/cleanup.hpp) and undoes it when it goes.
#ifndef SPH_APPS_CHILD_PROCESS_HPP_
#define SPH_APPS_CHILD_PROCESS_HPP_

#include <sys/types.h>

#include <chrono>
#include <string>
#include <vector>

namespace sph::apps {

using Clock = std::chrono::steady_clock;

/// The script in a temporary file of the folder, removed when this goes (or by the signal
/// cleanup); throws sph::Error naming `what` when it cannot be written.
class ScriptFile {
 public:
  ScriptFile(const std::string& folder, const std::string& script, const std::string& what);
  ~ScriptFile();
  ScriptFile(const ScriptFile&) = delete;
  ScriptFile& operator=(const ScriptFile&) = delete;
  /// The name gnuplot opens from within the folder.
  std::string name() const;

 private:
  void Remove();
  std::string path_;
  int cleanup_ = -1;
};

/// Appends what the child writes to `output` (up to 64 KiB) until it closes the pipe; false when
/// `deadline` comes first.
bool ReadUntilClosed(int fd, Clock::time_point deadline, std::string& output);

/// Waits for the child to end without reaping it (its pid stays its own until then); false when
/// `deadline` comes first.
bool AwaitExit(pid_t pid, Clock::time_point deadline);

/// The child running argv in `folder` with its output on `out_fd`, started in a process group of
/// its own with the signals the cleanup handles blocked, and registered with the cleanup before
/// they are unblocked; exit 126: the folder cannot be entered, 127: the program was not found.
class Child {
 public:
  Child(std::vector<char*>& argv, const std::string& folder, int out_fd, const std::string& what);
  ~Child();  ///< kills the child when it still runs
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  pid_t pid() const { return pid_; }
  /// Kills the child's process group and waits for the child.
  void Kill();
  /// Waits for the child (ended, or about to) and returns its wait status.
  int Reap();

 private:
  pid_t pid_ = -1;
  int cleanup_ = -1;
};

/// The pipe the child writes its messages into; the read end stays, closed when this goes.
struct OutputPipe {
  explicit OutputPipe(const std::string& what);
  ~OutputPipe();
  void CloseWriteEnd();
  int fd[2] = {-1, -1};
};

}  // namespace sph::apps

#endif  // SPH_APPS_CHILD_PROCESS_HPP_
