"""sph.Points from large arrays: the time it takes, the peak memory it adds to the process against the
arrays it is given, and whether other Python threads run meanwhile (the GIL released).

  PYTHONPATH=build/python /usr/bin/python3 bench/python_points.py [READINGS]

READINGS (default 10000000) readings of theta_deg, phi_deg and r_mm as float64 arrays; the peak is the
process's maximum resident set (getrusage), before and after the call; the ticks are those of a thread
that sleeps 1 ms at a time while the call runs; the CPU time is the process's (both threads).
"""
import resource
import sys
import threading
import time

import numpy as np

import sph


def peak_bytes():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


n = int(float(sys.argv[1])) if len(sys.argv) > 1 else 10_000_000
theta = np.tile(np.arange(0.0, 360.0, 15.0), n // 24 + 1)[:n]
phi = np.linspace(7.5, 172.5, n)
r = np.linspace(4.8, 5.2, n)
arrays = theta.nbytes + phi.nbytes + r.nbytes
ticks = []
running = True


def tick():
    while running:
        ticks.append(time.monotonic())
        time.sleep(0.001)


before = peak_bytes()
ticker = threading.Thread(target=tick)
ticker.start()
start, cpu_start = time.perf_counter(), time.process_time()
points = sph.Points(theta, phi, r, header={"sphere_radius_mm": 20, "probe_offset_mm": 25})
seconds, cpu_seconds = time.perf_counter() - start, time.process_time() - cpu_start
running = False
ticker.join()
added = peak_bytes() - before
print(f"{len(points)} readings: sph.Points {seconds:.2f} s ({cpu_seconds:.2f} s of CPU); peak memory +{added / 1e6:.0f} MB "
      f"({added / arrays:.2f} x the arrays' {arrays / 1e6:.0f} MB), the process's peak {peak_bytes() / 1e6:.0f} MB; "
      f"{len(ticks)} ticks of another thread meanwhile")
