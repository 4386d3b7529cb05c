#include "sph/io/cleanup.hpp"

#include <limits.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>

namespace sph {
namespace {

// Fixed tables, so that the signal handler touches no heap: each slot is free (0), being
// filled (1) or in use (2). std::atomic<int> is lock-free, hence usable in a handler.
constexpr int kSlots = 64;
struct Slot {
  std::atomic<int> state{0};
  char path[PATH_MAX];
};
Slot g_slots[kSlots];

constexpr int kChildSlots = 8;
struct ChildSlot {
  std::atomic<int> state{0};
  pid_t pid = 0;
};
ChildSlot g_children[kChildSlots];

// The first free slot of `table`, marked as being filled, or -1.
template <typename S, int N>
int Claim(S (&table)[N]) {
  for (int i = 0; i < N; ++i) {
    int expected = 0;
    if (table[i].state.compare_exchange_strong(expected, 1)) return i;
  }
  return -1;
}

extern "C" void RemoveAndReraise(int sig) {
  RemoveRegisteredTempFiles();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

}  // namespace

int RegisterTempFile(const std::string& path) {
  if (path.size() >= PATH_MAX) return -1;
  const int i = Claim(g_slots);
  if (i < 0) return -1;
  std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
  g_slots[i].state.store(2);
  return i;
}

void UnregisterTempFile(int handle) {
  if (handle >= 0 && handle < kSlots) g_slots[handle].state.store(0);
}

int RegisterChildProcess(pid_t pid) {
  const int i = Claim(g_children);
  if (i < 0) return -1;
  g_children[i].pid = pid;
  g_children[i].state.store(2);
  return i;
}

void UnregisterChildProcess(int handle) {
  if (handle >= 0 && handle < kChildSlots) g_children[handle].state.store(0);
}

void RemoveRegisteredTempFiles() noexcept {
  const int saved_errno = errno;
  for (ChildSlot& c : g_children) {
    if (c.state.load() != 2) continue;
    ::kill(-c.pid, SIGKILL);  // the group: what the child started too
    ::kill(c.pid, SIGKILL);   // the child, should it not lead its group yet
    while (::waitpid(c.pid, nullptr, 0) < 0 && errno == EINTR) {
    }
  }
  for (Slot& s : g_slots) {
    if (s.state.load() == 2) ::unlink(s.path);
  }
  errno = saved_errno;
}

void RemoveTempFilesOnSignals() {
  struct sigaction sa {};
  sigemptyset(&sa.sa_mask);
  sa.sa_handler = RemoveAndReraise;
  for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) sigaction(sig, &sa, nullptr);
}

}  // namespace sph
