"""The Python module's memory over repeated calls: the growth of the process's resident set (RSS)
over N calls of each workflow, after a few calls that pay the first-use costs (the allocator's
arenas, Ceres' and the json module's first allocations). A result left behind by each call would
grow it by N times that result's size.

  PYTHONPATH=build/python /usr/bin/python3 bench/python_memory.py data/example/points.txt [CALLS]

calibrate: sph.calibrate(points) of the file's readings in memory (the whole workflow, trace and
budget); simulate: sph.simulate() (the paper's study, 288 readings, and its truth); monte_carlo:
sph.monte_carlo(trials=2, eccentricities_mm=[2], table3=False, threads=1) (two calibrations).
"""
import os
import sys
import time

import sph


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


points = sph.read_points(sys.argv[1])
calls = int(sys.argv[2]) if len(sys.argv) > 2 else 1000
workflows = {
    "calibrate": lambda: sph.calibrate(points),
    "simulate": lambda: sph.simulate(),
    "monte_carlo": lambda: sph.monte_carlo(trials=2, eccentricities_mm=[2], table3=False, threads=1),
}
for name, call in workflows.items():
    for _ in range(10):
        call()
    before = rss_bytes()
    start = time.perf_counter()
    quarter = []
    for i in range(calls):
        call()
        if (i + 1) % (calls // 4 or 1) == 0:
            quarter.append(rss_bytes() - before)
    seconds = time.perf_counter() - start
    grown = rss_bytes() - before
    steps = ", ".join(f"{g / 1e3:+.0f}" for g in quarter)
    print(f"{name}: RSS {before / 1e6:.1f} MB after 10 calls, grown by {grown / 1e3:+.0f} kB over {calls} calls "
          f"({grown / calls:+.0f} bytes a call; at each quarter {steps} kB; {seconds:.1f} s)")
