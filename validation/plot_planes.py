"""Charts for reports/planes: error of IRDM plane contact (virtual DOFs, many-vertex contact)
against the nonlinear FEM, against press depth and impact speed.
Usage: /usr/bin/python3 plot_planes.py REPORT_DIR (reads planes.csv and cases.csv)"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

d = sys.argv[1]
cases = {x["case"]: x for x in csv.DictReader(open(d + "/cases.csv"))}
rows = list(csv.DictReader(open(d + "/planes.csv")))
methods = (("vdof_interpolated", "o--"), ("vertex_contact_modal", "s-"))
fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
for kind, colour in (("press_side", "C0"), ("press_between", "C2"), ("press_top", "C1"),
                     ("press_top_and_side", "C3")):
    for method, style in methods:
        r = [x for x in rows if cases[x["case"]]["kind"] == kind and x["method"] == method]
        depth = [1000 * float(cases[x["case"]]["depth_m"]) for x in r]
        ax[0].plot(depth, [100 * float(x["impulse_error"]) for x in r], style, color=colour,
                   label=f"{kind}, {method}")
ax[0].axhline(5, color="grey", lw=0.8, ls=":")
ax[0].set_yscale("log")
ax[0].set_xlabel("press depth (mm)")
ax[0].set_ylabel("impulse error (%)")
ax[0].set_title("Wall press: IRDM vs nonlinear FEM (goal 5 % dotted)")
ax[0].legend(fontsize=6)
for (method, style), colour in zip(methods, ("C0", "C1")):
    r = [x for x in rows if cases[x["case"]]["kind"] == "impact_side" and x["method"] == method]
    speed = [float(cases[x["case"]]["speed_m_s"]) for x in r]
    for key, marker in (("impulse_error", style), ("force_error", style[0] + ":")):
        ax[1].plot(speed, [100 * float(x[key]) for x in r], marker, color=colour,
                   label=f"{method}: {key.replace('_', ' ')}")
ax[1].set_xscale("log")
ax[1].set_yscale("log")
ax[1].set_xlabel("impact speed (m/s), 2 mm deep")
ax[1].set_ylabel("relative error (%)")
ax[1].set_title("Wall impact from the side")
ax[1].legend(fontsize=7)
fig.tight_layout()
fig.savefig(d + "/planes.png", dpi=110)
