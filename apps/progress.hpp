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
  kAuto,    ///< on a terminal, once the run has taken longer than a second
  kAlways,  ///< from the start, on a terminal or not (a line per update when not)
  kNever,
};

/// --progress (kAlways) and --no-progress (kNever); neither: kAuto.
void AddProgressOptions(CLI::App& app, ProgressMode& mode);

/// Progress on `err`, as "<program>: <stage> 45% (90/200)". On a terminal the line is redrawn in
/// place; elsewhere (kAlways only) each update is a line of its own. Updates come at most ten
/// times a second, except the last of a stage. Not thread-safe: callers serialise the updates.
class Progress {
 public:
  Progress(std::string program, std::ostream& err, ProgressMode mode);
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
  Clock::time_point start_ = Clock::now();
  Clock::time_point last_{};
  std::string last_stage_;
  bool shown_ = false;  ///< a line is on the terminal, not ended
};

}  // namespace sph::apps

#endif  // SPH_APPS_PROGRESS_HPP_
