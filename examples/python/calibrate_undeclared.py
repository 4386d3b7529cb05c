"""Calibrate the undeclared example, print the comparison before/after and plot the residual map.

Usage: python3 calibrate_undeclared.py [DATA_DIR] [PNG]
  DATA_DIR  the example's folder (default: data/example/undeclared)
  PNG       the residual map to write (default: residual_map.png)
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt
import numpy as np

import sph

data_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.join("data", "example", "undeclared")
png = sys.argv[2] if len(sys.argv) > 2 else "residual_map.png"

points = sph.read_points(os.path.join(data_dir, "points.txt"))
result = sph.calibrate(points, validate=os.path.join(data_dir, "validate.txt"))
report = result.report

print(f"{len(points)} readings, R0 = {report['sphere_radius_mm']} mm, d = {report['probe_offset_mm']} mm")
print(f"residual rms {report['before']['rms_um']:.4f} -> {report['after']['rms_um']:.4f} um")
print("effects added:", ", ".join(report["effects_added"]) or "none")
v = report["validation"]
print(f"validation rms {v['before_rms_um']:.4f} -> {v['after_rms_um']:.4f} um")
for name in ("alpha", "d_prime"):
    p = result.parameters[name]
    print(f"{name:8s} {p['value']:+.6f} {p['unit']}  U {p['U']:.6f} {p['unit']}")
print("usable" if result.usable else "not usable")

# One row a setup (each placement of the sphere measures the same grid of angles), before and after.
setups = np.unique(points.setup)
fig, axes = plt.subplots(len(setups), 2, figsize=(10, 3.5 * len(setups)), sharex=True, sharey=True,
                         squeeze=False, constrained_layout=True)
limit = np.max(np.abs(result.residuals_seven_um))
for row, setup in zip(axes, setups):
    mine = points.setup == setup
    for ax, residuals_um, title in ((row[0], result.residuals_seven_um, "seven errors"),
                                    (row[1], result.residuals_um, "with the effects added")):
        dots = ax.scatter(points.theta_deg[mine], points.phi_deg[mine], c=residuals_um[mine], cmap="coolwarm",
                          vmin=-limit, vmax=limit, s=18)
        rms_um = np.sqrt(np.mean(residuals_um[mine] ** 2))
        ax.set_title(f"setup {setup}, {title}: rms {rms_um:.4f} um")
    row[0].set_ylabel("phi_deg")
for ax in axes[-1]:
    ax.set_xlabel("theta_deg")
fig.colorbar(dots, ax=axes, label="residual_um")
fig.savefig(png, dpi=80)
print("wrote", png)
