"""The Python module's call overhead: sph.calibrate(path) against the same workflow in C++
(calibrate_bench's BM_CalibrateWorkflowFile), medians of repeated calls on one points file.

  PYTHONPATH=build/python /usr/bin/python3 bench/python_overhead.py build/bench/calibrate_bench \\
      data/example/points.txt [REPETITIONS]
"""
import json
import os
import statistics
import subprocess
import sys
import time

import sph

bench, points = sys.argv[1], sys.argv[2]
repetitions = int(sys.argv[3]) if len(sys.argv) > 3 else 30

for _ in range(3):  # first-use costs: the import of json, the allocator
    sph.calibrate(points)
times_ms = []
for _ in range(repetitions):
    start = time.perf_counter()
    sph.calibrate(points)
    times_ms.append((time.perf_counter() - start) * 1e3)
python_ms = statistics.median(times_ms)

out = subprocess.run([bench, "--benchmark_filter=^BM_CalibrateWorkflowFile$", "--benchmark_format=json",
                      f"--benchmark_repetitions={repetitions}", "--benchmark_report_aggregates_only=true"],
                     env=dict(os.environ, SPH_BENCH_POINTS=points), check=True, capture_output=True, text=True).stdout
runs = json.loads(out)["benchmarks"]
cpp_ms = next(b["real_time"] for b in runs if b.get("aggregate_name") == "median")

print(f"{points}: sph.calibrate median {python_ms:.2f} ms, C++ workflow median {cpp_ms:.2f} ms "
      f"({repetitions} calls each), ratio {python_ms / cpp_ms:.3f}")
