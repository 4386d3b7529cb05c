// Stopping long work from outside it: a host (the Python module on Ctrl-C, a program's stop
// button) requests it from any thread; the library's long computations check for it between units
// of work and stop by throwing sph::Cancelled. The one mechanism of every workflow.
#ifndef SPH_CORE_CANCELLATION_HPP_
#define SPH_CORE_CANCELLATION_HPP_

#include <atomic>
#include <exception>

namespace sph {

/// Thrown by a computation asked to stop (Cancellation::Request()). Not an sph::Error: nothing
/// was wrong with the input, and a caller that handles bad input must not take it for that.
class Cancelled : public std::exception {
 public:
  const char* what() const noexcept override { return "cancelled"; }
};

/// A request to stop: any thread may make it, the computations it is installed for
/// (CancellationScope) see it at their next check.
class Cancellation {
 public:
  void Request() noexcept { requested_.store(true, std::memory_order_relaxed); }
  bool Requested() const noexcept { return requested_.load(std::memory_order_relaxed); }

 private:
  std::atomic<bool> requested_{false};
};

/// Installs `cancellation` for the computations this thread runs while the scope lives, and for
/// the threads they start (the library's pools carry it over); the scope a thread made last
/// wins until it ends. nullptr installs none. `cancellation` must outlive the scope.
class CancellationScope {
 public:
  explicit CancellationScope(const Cancellation* cancellation) noexcept;
  ~CancellationScope();
  CancellationScope(const CancellationScope&) = delete;
  CancellationScope& operator=(const CancellationScope&) = delete;

 private:
  const Cancellation* previous_;
};

/// The cancellation installed on this thread, or nullptr.
const Cancellation* CurrentCancellation() noexcept;

/// Throws sph::Cancelled when the cancellation installed on this thread was requested. The
/// library calls it between units of work: before each fit's solve and at each of the solver's
/// iterations, before each index of its parallel loops (a trace's candidates, the Monte Carlo
/// trials, a measurement's draws) and at each progress step of the measurement.
void ThrowIfCancelled();

}  // namespace sph

#endif  // SPH_CORE_CANCELLATION_HPP_
