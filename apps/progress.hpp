// One line on stderr that tells what a long run is doing (the stage, and how far when it counts).
#ifndef SPH_APPS_PROGRESS_HPP_
#define SPH_APPS_PROGRESS_HPP_

#include <chrono>
#include <ostream>
#include <string>

#include "cli_fwd.hpp"

namespace sph::apps {

/// When a program shows its progress (--progress / --no-progress).
enum class ProgressMode {
  /// On a terminal, once the run has taken longer than a second; elsewhere (a log), once it has
  /// taken longer than ten seconds, a line per stage and at most one every ten seconds
  kAuto,
  kAlways,  ///< from the start, on a terminal or not (a line per update when not)
  kNever,
};

/// --progress (kAlways) and --no-progress (kNever); neither: kAuto.
void AddProgressOptions(CLI::App& app, ProgressMode& mode);

/// Progress on `err`, as "<program>: <stage> 45% (90/200)". On a terminal the line is redrawn in
/// place; elsewhere each update is a line of its own (kAuto: only in runs longer than ten seconds,
/// a line per stage and one every ten seconds). Updates come at most ten times a second, except
/// the last of a stage. Not thread-safe: callers serialise the updates.
class Progress {
 public:
  /// `log_after`: how long a run must take before kAuto writes into a log (ten seconds).
  Progress(std::string program, std::ostream& err, ProgressMode mode,
           std::chrono::milliseconds log_after = std::chrono::seconds(10));
  ~Progress();  ///< ends the line (Finish())
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  /// A stage without a count ("reading points.txt").
  void Stage(const std::string& what) { Update(what, 0, 0); }
  /// `done` of `total` of a stage (total 0: no count).
  void Update(const std::string& what, long done, long total);
  /// Ends the progress line, if one was shown, so that what follows starts on a line of its own.
  void Finish();

 private:
  using Clock = std::chrono::steady_clock;
  std::string program_;
  std::ostream& err_;
  bool enabled_;
  bool terminal_;
  bool delayed_;  ///< shown only once a second has passed since the start
  bool log_;      ///< kAuto into a log: after log_after_, a line per stage and at most one every ten seconds
  std::chrono::milliseconds log_after_;
  Clock::time_point start_ = Clock::now();
  Clock::time_point last_{};
  std::string last_stage_;
  bool shown_ = false;  ///< a line is on the terminal, not ended
};

}  // namespace sph::apps

#endif  // SPH_APPS_PROGRESS_HPP_
