// The process' peak resident set size, for benchmarks' counters.
#ifndef SPH_BENCH_PEAK_RSS_HPP_
#define SPH_BENCH_PEAK_RSS_HPP_

#include <sys/resource.h>

namespace sph::bench {

/// Peak resident set size of this process so far [MB] (getrusage; Linux reports kB). It covers
/// everything the process ran: run one benchmark per process (--benchmark_filter) to read it as
/// that benchmark's own.
inline double PeakRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

}  // namespace sph::bench

#endif  // SPH_BENCH_PEAK_RSS_HPP_
