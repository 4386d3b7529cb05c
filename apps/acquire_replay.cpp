// sph_acquired --replay: the pipeline offline, from a candump log.
#include <time.h>

#include <cerrno>

#include "acquire_internal.hpp"
#include "app_common.hpp"
#include "sph/can/candump_log.hpp"

namespace sph::apps {
namespace {

std::int64_t MonotonicNs() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

void SleepUntil(std::int64_t mono_ns) {
  timespec ts{static_cast<time_t>(mono_ns / 1000000000), static_cast<long>(mono_ns % 1000000000)};
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    if (ProcessSignals().stop) return;
  }
}

}  // namespace

std::string CheckReplayLog(const std::string& path) {
  try {
    can::CandumpReader reader(path);
    std::string first_problem;
    for (;;) {
      const can::CandumpReader::Result r = reader.Next();
      if (r.status == can::CandumpReader::Status::kFrame) return "";
      if (r.status == can::CandumpReader::Status::kMalformed && first_problem.empty()) first_problem = r.error;
      if (r.status == can::CandumpReader::Status::kEnd) break;
    }
    const std::int64_t lines = reader.line_number();
    if (lines == 0) return path + ": empty: no CAN frame to replay";
    if (first_problem.empty()) return path + ": no CAN frame to replay, only blank lines";
    return path + ": no CAN frame in its " + std::to_string(lines) + (lines == 1 ? " line" : " lines") +
           ": not a candump log (first: " + first_problem + ")";
  } catch (const std::exception& e) {
    return e.what();
  }
}

int RunReplay(AcquireContext& ctx) {
  std::unique_ptr<can::CandumpReader> reader;
  try {
    reader = std::make_unique<can::CandumpReader>(ctx.options.replay_path);
  } catch (const std::exception& e) {
    ctx.log(can::LogLevel::kError, e.what());
    return kExitBadInput;
  }
  ctx.log(can::LogLevel::kInfo, "replaying " + ctx.options.replay_path);
  const double speed = ctx.options.replay_speed;
  std::int64_t first_frame_ns = 0, start_mono_ns = 0;
  std::uint64_t n = 0;
  for (;;) {
    if (ctx.signals.stop) {
      ctx.log(can::LogLevel::kInfo, "stop requested: ending the replay");
      break;
    }
    if (ctx.signals.summary) {
      ctx.signals.summary = 0;
      ctx.print_summary();
    }
    can::CandumpReader::Result r;
    try {
      r = reader->Next();
    } catch (const std::exception& e) {
      ctx.log(can::LogLevel::kError, e.what());
      return kExitBadInput;
    }
    if (r.status == can::CandumpReader::Status::kEnd) break;
    if (r.status == can::CandumpReader::Status::kMalformed) {
      ctx.pipeline.OnMalformedInput(r.error);
      continue;
    }
    if (speed > 0.0) {
      if (n == 0) {
        first_frame_ns = r.frame.t_ns;
        start_mono_ns = MonotonicNs();
      } else {
        const auto due = start_mono_ns + static_cast<std::int64_t>(static_cast<double>(r.frame.t_ns - first_frame_ns) / speed);
        if (due > MonotonicNs()) {
          ctx.FlushOutputs();  // idle anyway: make what we have visible
          SleepUntil(due);
        }
      }
    }
    ctx.LogFrame(r.frame);
    ctx.pipeline.OnFrame(r.frame);
    if ((++n & 0xFFF) == 0) ctx.FlushOutputs();
  }
  ctx.FlushOutputs();
  return kExitOk;
}

}  // namespace sph::apps
