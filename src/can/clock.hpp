// The clocks of the live and paced runs (internal).
#ifndef SPH_CAN_CLOCK_HPP_
#define SPH_CAN_CLOCK_HPP_

#include <time.h>

#include <cstdint>

namespace sph::can {

/// Time since the epoch [ns] (CLOCK_REALTIME: the frames' receive times are on it).
inline std::int64_t RealtimeNs() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

/// Time on the monotonic clock [ns] (for waits and paces).
inline std::int64_t MonotonicNs() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

}  // namespace sph::can

#endif  // SPH_CAN_CLOCK_HPP_
