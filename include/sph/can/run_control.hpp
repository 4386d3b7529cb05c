// How the caller of a long run (an acquisition, a simulated bus) stops it and asks for its summary.
#ifndef SPH_CAN_RUN_CONTROL_HPP_
#define SPH_CAN_RUN_CONTROL_HPP_

#include <atomic>
#include <vector>

namespace sph::can {

/// Flags set from a signal handler or another thread, looked at between the run's steps (at
/// least every 0.2 s).
struct RunControl {
  /// Nonzero: stop now (a live acquisition closes its outputs cleanly, a replay ends, a simulated
  /// log is cut short and removed). A signal handler puts the signal's number, which the messages
  /// name.
  std::atomic<int> stop{0};
  /// Nonzero: report the summary now (the run calls its summary hook and clears the flag).
  std::atomic<int> summary{0};
  /// The signals whose handlers set the flags (sph_acquired: SIGTERM, SIGINT, SIGUSR1): a live
  /// acquisition blocks them but in its waits, so that one arriving just before a wait ends it.
  std::vector<int> wake_signals;
};

}  // namespace sph::can

#endif  // SPH_CAN_RUN_CONTROL_HPP_
