#!/usr/bin/python3
"""The calibration as a user would write it with SciPy: least_squares(method='lm') on a vectorised
NumPy model of the paper's Eq. (1), timed on the same points file the project calibrates.

    /usr/bin/python3 bench/peer_scipy.py POINTS_FILE [--repetitions N]

Prints one line per quantity as `key value`; bench/peer_scipy.sh runs it beside the project.
Parameters: alpha [rad], a [mm], beta [rad], b [mm], epsilon [rad], c [mm], d' [mm], centre x y z [mm].
"""
import argparse
import statistics
import sys
import time

import numpy as np
from scipy.optimize import least_squares


def read_points(path):
    """theta_deg, phi_deg, r_mm (first three columns or by the columns header), R0, d."""
    header = {}
    rows = []
    with open(path, encoding="utf-8") as f:
        for line in f:
            s = line.strip()
            if not s:
                continue
            if s.startswith("#"):
                if not rows and ":" in s:
                    key, value = s[1:].split(":", 1)
                    header[key.strip()] = value.strip()
                continue
            rows.append(s.split())
    cols = header.get("columns", "theta_deg phi_deg r_mm").split()
    data = np.array(rows, dtype=float)
    pick = [cols.index(c) for c in ("theta_deg", "phi_deg", "r_mm")]
    if "setup" in cols and len(np.unique(data[:, cols.index("setup")])) > 1:
        sys.exit(f"{path}: the peer fits one setup (one sphere centre)")
    return (data[:, pick[0]], data[:, pick[1]], data[:, pick[2]], float(header["sphere_radius_mm"]),
            float(header["probe_offset_mm"]))


def make_residual(theta_deg, phi_deg, r_mm, r0_mm, d_mm):
    st, ct = np.sin(np.radians(theta_deg)), np.cos(np.radians(theta_deg))
    sp, cp = np.sin(np.radians(phi_deg)), np.cos(np.radians(phi_deg))

    def residual(x):
        alpha, a, beta, b, eps, c, dp, ox, oy, oz = x
        rho = r_mm - (d_mm + dp)
        sa, ca = np.cos(alpha), -np.sin(alpha)   # sin, cos of pi/2 + alpha
        sc, cc = np.cos(eps), -np.sin(eps)       # sin, cos of pi/2 + epsilon
        sb, cb = np.sin(beta), np.cos(beta)
        # DH(beta, b, c, pi/2 + epsilon) [0, 0, rho, 1]
        q1x = rho * sb * sc + c * cb
        q1y = -rho * cb * sc + c * sb
        q1z = rho * cc + b
        # Rz(-phi)
        q2x = cp * q1x + sp * q1y
        q2y = -sp * q1x + cp * q1y
        q2z = q1z
        # DH(theta, 0, a, pi/2 + alpha)
        px = ct * q2x - st * ca * q2y + st * sa * q2z + a * ct
        py = st * q2x + ct * ca * q2y - ct * sa * q2z + a * st
        pz = sa * q2y + ca * q2z
        return np.sqrt((px - ox) ** 2 + (py - oy) ** 2 + (pz - oz) ** 2) - r0_mm

    # Start: the seven errors zero, the centre of an algebraic sphere fit of the nominal points.
    rho0 = d_mm - r_mm
    p = np.column_stack((rho0 * sp * ct, rho0 * sp * st, rho0 * cp))
    m = np.column_stack((2 * p, np.ones(len(p))))
    sol = np.linalg.lstsq(m, (p ** 2).sum(axis=1), rcond=None)[0]
    start = np.concatenate((np.zeros(7), sol[:3]))
    return residual, start


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("points")
    ap.add_argument("--repetitions", type=int, default=200)
    args = ap.parse_args()
    residual, start = make_residual(*read_points(args.points))
    times, cpu = [], []
    for _ in range(args.repetitions):
        t0, c0 = time.perf_counter(), time.process_time()
        fit = least_squares(residual, start, method="lm")
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    g = fit.x
    print("scipy_median_ms", 1e3 * statistics.median(times))
    print("scipy_cpu_median_ms", 1e3 * statistics.median(cpu))
    print("scipy_nfev", fit.nfev)
    print("scipy_status", fit.status)
    print("scipy_alpha_deg", np.degrees(g[0]))
    print("scipy_a_mm", g[1])
    print("scipy_beta_deg", np.degrees(g[2]))
    print("scipy_b_mm", g[3])
    print("scipy_epsilon_deg", np.degrees(g[4]))
    print("scipy_c_mm", g[5])
    print("scipy_d_prime_mm", g[6])
    print("scipy_rms_um", 1e3 * np.sqrt(np.mean(fit.fun ** 2)))
    # Which BLAS numpy runs: the shared objects loaded into this process.
    libs = set()
    with open("/proc/self/maps") as maps:
        for line in maps:
            name = line.split()[-1]
            if any(k in name for k in ("blas", "lapack", "mkl", "atlas")):
                libs.add(name)
    print("numpy_version", np.__version__)
    print("numpy_blas", ",".join(sorted(libs)) or "none loaded")


if __name__ == "__main__":
    main()
