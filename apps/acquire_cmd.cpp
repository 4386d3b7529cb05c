#include "acquire_cmd.hpp"

#include <atomic>
#include <csignal>
#include <iostream>

#include "app_common.hpp"

namespace sph::apps {
namespace {

can::RunControl g_control;
static_assert(std::atomic<int>::is_always_lock_free, "the signal handlers store into RunControl's flags");

extern "C" void OnStopSignal(int sig) { g_control.stop.store(sig); }
extern "C" void OnSummarySignal(int) { g_control.summary.store(1); }

can::LogLevel ParseLevel(const std::string& text, int verbose) {
  int level = text == "error" ? 0 : text == "warning" ? 1 : text == "info" ? 2 : 3;
  level += verbose;  // a verbose of false (-1) takes one level off
  return static_cast<can::LogLevel>(level > 3 ? 3 : level < 0 ? 0 : level);
}

int ExitCodeOf(can::AcquisitionStatus status) {
  switch (status) {
    case can::AcquisitionStatus::kOk:
      return kExitOk;
    case can::AcquisitionStatus::kSamplesLost:
      return kExitSamplesLost;
    case can::AcquisitionStatus::kBadInput:
      return kExitBadInput;
    case can::AcquisitionStatus::kOutputError:
      return kExitOutputError;
    case can::AcquisitionStatus::kInterfaceError:
      return kExitInterfaceError;
    case can::AcquisitionStatus::kStartRefused:
      return kExitDeviceError;
    case can::AcquisitionStatus::kNodeLost:
      return kExitNodeLost;
  }
  return kExitBadInput;
}

}  // namespace

can::RunControl& ProcessControl() { return g_control; }

void InstallSignalHandlers() {
  g_control.wake_signals = {SIGTERM, SIGINT, SIGUSR1};
  struct sigaction sa {};
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: a blocking call returns EINTR and the loop sees the flag
  sa.sa_handler = OnStopSignal;
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  sa.sa_handler = OnSummarySignal;
  sigaction(SIGUSR1, &sa, nullptr);
}

int RunAcquire(const AcquireOptions& o, std::ostream& err) {
  can::AcquisitionOptions options = o.acq;
  if (!o.config_path.empty()) options.option_files.emplace_back("--config", o.config_path);
  const can::LogLevel shown = ParseLevel(o.log_level, o.verbose);
  can::AcquisitionHooks hooks;
  hooks.log = [&err, shown](can::LogLevel level, const std::string& text) {
    if (level <= shown) err << "sph_acquired: " << can::ToString(level) << ": " << text << "\n" << std::flush;
  };
  hooks.summary = [&err](const can::AcquisitionResult& r) {
    for (const std::string& line : can::SummaryLines(r)) err << "sph_acquired: summary: " << line << "\n";
    err << std::flush;
  };
  const auto acquire = options.iface.empty() ? can::ReplayAcquisition : can::LiveAcquisition;
  return ExitCodeOf(acquire(options, ProcessControl(), hooks).status);
}

}  // namespace sph::apps
