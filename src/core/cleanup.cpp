#include "sph/core/cleanup.hpp"

#include <limits.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstring>

namespace sph {
namespace {

// A fixed table, so that the signal handler touches no heap: each slot is free (0), being
// filled (1) or holds a path (2). std::atomic<int> is lock-free, hence usable in a handler.
constexpr int kSlots = 64;
struct Slot {
  std::atomic<int> state{0};
  char path[PATH_MAX];
};
Slot g_slots[kSlots];

extern "C" void RemoveAndReraise(int sig) {
  RemoveRegisteredTempFiles();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

}  // namespace

int RegisterTempFile(const std::string& path) {
  if (path.size() >= PATH_MAX) return -1;
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;
    if (g_slots[i].state.compare_exchange_strong(expected, 1)) {
      std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
      g_slots[i].state.store(2);
      return i;
    }
  }
  return -1;
}

void UnregisterTempFile(int handle) {
  if (handle >= 0 && handle < kSlots) g_slots[handle].state.store(0);
}

void RemoveRegisteredTempFiles() noexcept {
  for (Slot& s : g_slots) {
    if (s.state.load() == 2) ::unlink(s.path);
  }
}

void RemoveTempFilesOnSignals() {
  struct sigaction sa {};
  sigemptyset(&sa.sa_mask);
  sa.sa_handler = RemoveAndReraise;
  for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) sigaction(sig, &sa, nullptr);
}

}  // namespace sph
