// The kernel's receive-queue drop counter as CanSocket reads it: from SO_RXQ_OVFL with each frame
// and from SO_MEMINFO when the queue is empty, so every drop is counted exactly once.
#include <gtest/gtest.h>

#include <cstdint>

#include "sph/can/socket.hpp"

namespace sph::can {
namespace {

TEST(DropCounter, CountsIncreasesOnce) {
  std::uint32_t last = 0;
  EXPECT_EQ(AdvanceDropCounter(&last, 0), 0U);
  EXPECT_EQ(AdvanceDropCounter(&last, 5), 5U);
  EXPECT_EQ(last, 5U);
  EXPECT_EQ(AdvanceDropCounter(&last, 5), 0U);
  EXPECT_EQ(AdvanceDropCounter(&last, 12), 7U);
  EXPECT_EQ(last, 12U);
}

// Frames queued before the drops carry the older counter; the query after the queue ran empty
// has already counted those drops, so the stale readings add nothing.
TEST(DropCounter, OlderReadingAfterQueryCountsNothing) {
  std::uint32_t last = 0;
  EXPECT_EQ(AdvanceDropCounter(&last, 300), 300U);  // SO_MEMINFO after a flood
  EXPECT_EQ(AdvanceDropCounter(&last, 0), 0U);      // a frame queued before the flood
  EXPECT_EQ(AdvanceDropCounter(&last, 120), 0U);    // a frame queued during it
  EXPECT_EQ(last, 300U);
  EXPECT_EQ(AdvanceDropCounter(&last, 301), 1U);  // a later drop
}

TEST(DropCounter, WrapsAt32Bits) {
  std::uint32_t last = 0xfffffff0U;
  EXPECT_EQ(AdvanceDropCounter(&last, 0x10U), 0x20U);
  EXPECT_EQ(last, 0x10U);
  EXPECT_EQ(AdvanceDropCounter(&last, 0xfffffff8U), 0U);  // older, across the wrap
  EXPECT_EQ(last, 0x10U);
}

}  // namespace
}  // namespace sph::can
