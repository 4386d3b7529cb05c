// The library's one pool of threads: a loop whose iterations are independent, spread over
// threads. Not part of the public API.
#ifndef SPH_INTERNAL_PARALLEL_HPP_
#define SPH_INTERNAL_PARALLEL_HPP_

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

#include "sph/core/cancellation.hpp"

namespace sph::internal {

/// Runs task(i) for every i in [0, n) on up to `threads` threads (0: one per hardware thread,
/// never more than n), the calling thread one of them. Each thread first makes its own task with
/// make_task(), so that per-thread scratch (a solver's workspace, a moved calibration) lives in
/// the task and is shared by nothing; indices are handed out in increasing order, each once. The
/// result must not depend on which thread ran which index: each task writes only its own slots.
///
/// The first exception a task throws stops the loop (the other threads finish the index they are
/// on and take no more) and is rethrown here once every thread has joined. A caller that wants
/// every index run whatever fails catches inside its task. When the system gives no more
/// threads, those already running (at least the caller's) do the rest. The caller's cancellation
/// (sph/core/cancellation.hpp) holds on every thread, and is checked before each index: a
/// requested one stops the loop as a failure does, with sph::Cancelled.
template <typename MakeTask>
void ParallelFor(std::size_t n, int threads, MakeTask make_task) {
  if (n == 0) return;
  std::atomic<std::size_t> next{0};
  std::mutex failure_mutex;
  std::exception_ptr failure;
  const Cancellation* cancellation = CurrentCancellation();
  auto run = [&] {
    const CancellationScope scope(cancellation);
    try {
      auto task = make_task();
      for (std::size_t i; (i = next++) < n;) {
        ThrowIfCancelled();
        task(i);
      }
    } catch (...) {
      const std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      next = n;  // the others stop after their current index
    }
  };
  const unsigned asked = threads > 0 ? static_cast<unsigned>(threads) : std::thread::hardware_concurrency();
  const std::size_t count = std::max<std::size_t>(1, std::min<std::size_t>(asked, n));
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < count; ++w) {
    try {
      pool.emplace_back(run);
    } catch (const std::system_error&) {
      break;  // no more threads to be had
    }
  }
  run();
  for (std::thread& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace sph::internal

#endif  // SPH_INTERNAL_PARALLEL_HPP_
