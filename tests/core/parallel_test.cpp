// internal::ParallelFor, the library's one pool of threads.
#include "sph/internal/parallel.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace sph::internal {
namespace {

TEST(ParallelFor, RunsEveryIndexOnceWhateverTheNumberOfThreads) {
  for (const int threads : {0, 1, 2, 7, 64}) {
    std::vector<int> runs(1000, 0);
    ParallelFor(runs.size(), threads, [&] { return [&](std::size_t i) { ++runs[i]; }; });
    for (std::size_t i = 0; i < runs.size(); ++i) ASSERT_EQ(runs[i], 1) << "index " << i << ", threads " << threads;
  }
}

TEST(ParallelFor, GivesEachThreadItsOwnTaskAndNeverMoreThreadsThanIndices) {
  std::atomic<int> tasks{0};
  std::vector<std::thread::id> by(3);
  ParallelFor(by.size(), 16, [&] {
    ++tasks;
    return [&](std::size_t i) {
      by[i] = std::this_thread::get_id();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));  // so that every thread takes one
    };
  });
  EXPECT_LE(tasks.load(), 3);
  EXPECT_GE(tasks.load(), 1);
  for (const std::thread::id& id : by) EXPECT_NE(id, std::thread::id());
}

TEST(ParallelFor, RethrowsTheFirstFailureAfterEveryThreadHasJoinedAndStopsHandingOutIndices) {
  std::atomic<int> after{0};
  EXPECT_THROW(ParallelFor(100000, 4,
                           [&] {
                             return [&](std::size_t i) {
                               if (i == 10) throw std::runtime_error("index 10");
                               if (i > 1000) ++after;
                             };
                           }),
               std::runtime_error);
  // Each of the other threads finishes at most the index it holds once the failure is seen; far
  // fewer than the 99 000 indices left run.
  EXPECT_LT(after.load(), 99000);
  try {
    ParallelFor(5, 1, [] { return [](std::size_t i) { throw std::out_of_range(std::to_string(i)); }; });
    FAIL() << "no exception";
  } catch (const std::out_of_range& e) {
    EXPECT_STREQ(e.what(), "0");  // one thread: the first index's
  }
}

TEST(ParallelFor, DoesNothingForNoIndicesAndPassesAFailureToMakeTheTask) {
  bool made = false;
  ParallelFor(0, 4, [&] {
    made = true;
    return [](std::size_t) {};
  });
  EXPECT_FALSE(made);
  EXPECT_THROW(ParallelFor(3, 2, []() -> std::function<void(std::size_t)> { throw std::runtime_error("no scratch"); }),
               std::runtime_error);
}

TEST(ParallelFor, StopsWithCancelledWhenTheCallersCancellationIsRequested) {
  Cancellation cancellation;
  const CancellationScope scope(&cancellation);
  std::atomic<int> runs{0};
  std::atomic<int> tasks{0}, tasks_under_it{0};
  EXPECT_THROW(ParallelFor(100000, 4,
                           [&] {
                             // Each thread makes its task under the caller's cancellation.
                             ++tasks;
                             if (CurrentCancellation() == &cancellation) ++tasks_under_it;
                             return [&](std::size_t i) {
                               if (i == 100) cancellation.Request();
                               ++runs;
                             };
                           }),
               Cancelled);
  EXPECT_EQ(tasks_under_it.load(), tasks.load());
  EXPECT_LT(runs.load(), 1000);  // each thread stops at its next index
  EXPECT_EQ(CurrentCancellation(), &cancellation);
}

TEST(ParallelFor, RunsWithoutACancellationAndOutsideItsScope) {
  EXPECT_EQ(CurrentCancellation(), nullptr);
  Cancellation requested;
  requested.Request();
  {
    const CancellationScope scope(&requested);
    EXPECT_THROW(ThrowIfCancelled(), Cancelled);
    {
      const CancellationScope none(nullptr);  // a scope of its own wins until it ends
      EXPECT_NO_THROW(ThrowIfCancelled());
    }
    EXPECT_THROW(ParallelFor(3, 2, [] { return [](std::size_t) {}; }), Cancelled);
  }
  std::vector<int> runs(10, 0);
  ParallelFor(runs.size(), 2, [&] { return [&](std::size_t i) { ++runs[i]; }; });
  EXPECT_EQ(std::count(runs.begin(), runs.end(), 1), 10);
}

}  // namespace
}  // namespace sph::internal
