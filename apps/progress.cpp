#include "progress.hpp"

#include <unistd.h>

#include <utility>

#include <CLI/CLI.hpp>

namespace sph::apps {

void AddProgressOptions(CLI::App& app, ProgressMode& mode) {
  auto* always = app.add_flag_callback(
      "--progress", [&mode] { mode = ProgressMode::kAlways; },
      "Show progress on stderr from the start, even when it is not a terminal (default: on a terminal once "
      "the run takes longer than a second; into a log once it takes longer than ten seconds, a line per stage "
      "and one every ten seconds)");
  app.add_flag_callback(
         "--no-progress", [&mode] { mode = ProgressMode::kNever; }, "No progress on stderr")
      ->excludes(always);
}

Progress::Progress(std::string program, std::ostream& err, ProgressMode mode, std::chrono::milliseconds log_after)
    : program_(std::move(program)),
      err_(err),
      enabled_(mode != ProgressMode::kNever),
      terminal_(::isatty(STDERR_FILENO) == 1),
      delayed_(mode == ProgressMode::kAuto),
      log_(mode == ProgressMode::kAuto && !terminal_),
      log_after_(log_after) {}

Progress::~Progress() { Finish(); }

void Progress::Update(const std::string& what, long done, long total) {
  if (!enabled_) return;
  const Clock::time_point now = Clock::now();
  if (delayed_ && now - start_ < (log_ ? log_after_ : std::chrono::seconds(1))) return;
  const bool last_of_stage = total > 0 && done >= total;
  if (log_ && what == last_stage_ && now - last_ < std::chrono::seconds(10)) return;
  if (what == last_stage_ && !last_of_stage && now - last_ < std::chrono::milliseconds(100)) return;
  last_ = now;
  last_stage_ = what;
  std::string line = program_ + ": " + what;
  if (total > 0) {
    line += " " + std::to_string(100 * done / total) + "% (" + std::to_string(done) + "/" + std::to_string(total) + ")";
  }
  if (terminal_) {
    err_ << "\r" << line << "\x1b[K" << std::flush;  // erase what is left of a longer line
    shown_ = true;
  } else {
    err_ << line << "\n" << std::flush;
  }
}

void Progress::Finish() {
  if (!shown_) return;
  err_ << "\r\x1b[K" << std::flush;  // the line goes: the report follows on a clean terminal
  shown_ = false;
}

}  // namespace sph::apps
