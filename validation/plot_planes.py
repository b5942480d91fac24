"""Charts for reports/planes: error of the virtual-DOF IRDM against the nonlinear FEM, against
press depth and against impact speed. Usage: /usr/bin/python3 plot_planes.py REPORT_DIR"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

d = sys.argv[1]
rows = list(csv.DictReader(open(d + "/planes.csv")))
fig, ax = plt.subplots(1, 2, figsize=(11, 4))
for kind, colour in (("press_side", "C0"), ("press_between", "C2"), ("press_top", "C1"),
                     ("press_oblique", "C3")):
    r = [x for x in rows if x["kind"] == kind]
    depth = [1000 * float(x["depth_m"]) for x in r]
    for key, style, label in (("force_error_interpolated", "o-", "force"),
                              ("displacement_error_interpolated", "s--", "surface"),
                              ("open_loop_displacement_error", "^:", "surface, FEM force")):
        ax[0].plot(depth, [100 * float(x[key]) for x in r], style, color=colour,
                   label=f"{kind}: {label}")
    if kind in ("press_between", "press_oblique"):
        ax[0].plot(depth, [100 * float(x["force_error_nearest"]) for x in r], "x-.",
                   color=colour, label=f"{kind}: force, nearest")
ax[0].set_xlabel("press depth (mm)")
ax[0].set_ylabel("relative L2 error (%)")
ax[0].set_title("Wall press: IRDM (virtual DOFs) vs nonlinear FEM")
ax[0].legend(fontsize=7)
r = [x for x in rows if x["kind"] == "impact_side"]
speed = [float(x["speed_m_s"]) for x in r]
for key, style, label in (("force_error_interpolated", "o-", "force (L2)"),
                          ("impulse_error_interpolated", "d-", "impulse"),
                          ("displacement_error_interpolated", "s--", "displacement"),
                          ("open_loop_displacement_error", "^:", "displacement, FEM force")):
    ax[1].plot(speed, [100 * float(x[key]) for x in r], style, label=label)
ax[1].set_xscale("log")
ax[1].set_xlabel("impact speed (m/s), 2 mm deep")
ax[1].set_ylabel("relative error (%)")
ax[1].set_title("Wall impact from the side")
ax[1].legend(fontsize=7)
fig.tight_layout()
fig.savefig(d + "/planes.png", dpi=110)
