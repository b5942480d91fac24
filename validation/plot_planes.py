"""Charts for reports/planes: error of IRDM plane contact (virtual DOFs, many-vertex contact)
against the nonlinear FEM, against press depth and impact speed.
Usage: /usr/bin/python3 plot_planes.py REPORT_DIR (reads planes.csv and cases.csv, and
spread.csv when there: each error's range under the walls perturbed, drawn as error bars)"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from report_files import save_figure  # noqa: E402

d = sys.argv[1]
cases = {x["case"]: x for x in csv.DictReader(open(d + "/cases.csv"))}
rows = list(csv.DictReader(open(d + "/planes.csv")))
spread = {}
if os.path.exists(d + "/spread.csv"):
    spread = {(x["case"], x["method"]): x for x in csv.DictReader(open(d + "/spread.csv"))}


def plot_with_range(ax, x, r, key, style, **kw):
    """Percent errors r[key] against x, with their range under the perturbations as bars."""
    y = [100 * float(e[key]) for e in r]
    lo, hi = [], []
    for e, v in zip(r, y):
        s = spread.get((e["case"], e["method"]))
        lo.append(v - 100 * float(s[key + "_min"]) if s else 0)
        hi.append(100 * float(s[key + "_max"]) - v if s else 0)
    ax.errorbar(x, y, yerr=[lo, hi], fmt=style, capsize=2, **kw)

methods = (("vdof_interpolated", "o--"), ("vertex_contact_modal", "s-"))
fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
for kind, colour in (("press_side", "C0"), ("press_between", "C2"), ("press_top", "C1"),
                     ("press_top_and_side", "C3")):
    for method, style in methods:
        r = [x for x in rows if cases[x["case"]]["kind"] == kind and x["method"] == method]
        depth = [1000 * float(cases[x["case"]]["depth_m"]) for x in r]
        plot_with_range(ax[0], depth, r, "impulse_error", style, color=colour,
                        label=f"{kind}, {method}")


def empty(a, what, kinds):
    """A panel with nothing to draw (a run with --cases) says so; a log axis would fail."""
    if any(cases[x["case"]]["kind"] in kinds for x in rows):
        return False
    a.set_axis_off()
    a.text(0.5, 0.5, f"no {what} case in this run", ha="center", va="center")
    return True


ax[0].axhline(5, color="grey", lw=0.8, ls=":")
if not empty(ax[0], "press", ("press_side", "press_between", "press_top", "press_top_and_side")):
    ax[0].set_yscale("log")
ax[0].set_xlabel("press depth (mm)")
ax[0].set_ylabel("impulse error (%)")
ax[0].set_title("Wall press: IRDM vs nonlinear FEM (goal 5 % dotted; bars: range, spread.csv)",
                fontsize=9)
ax[0].legend(fontsize=6)
for (method, style), colour in zip(methods, ("C0", "C1")):
    r = [x for x in rows if cases[x["case"]]["kind"] == "impact_side" and x["method"] == method]
    speed = [float(cases[x["case"]]["speed_m_s"]) for x in r]
    for key, marker in (("impulse_error", style), ("force_error", style[0] + ":")):
        plot_with_range(ax[1], speed, r, key, marker, color=colour,
                        label=f"{method}: {key.replace('_', ' ')}")
if not empty(ax[1], "impact", ("impact_side",)):
    ax[1].set_xscale("log")
    ax[1].set_yscale("log")
ax[1].set_xlabel("impact speed (m/s), 2 mm deep")
ax[1].set_ylabel("relative error (%)")
ax[1].set_title("Wall impact from the side")
ax[1].legend(fontsize=7)
fig.tight_layout()
save_figure(fig, d + "/planes.png", dpi=110)

# Compliant walls: error against the wall stiffness (stiffness.csv), rigid at the right.
sweep = list(csv.DictReader(open(d + "/stiffness.csv"))) if os.path.exists(d + "/stiffness.csv") else []
if sweep:  # a run with --cases may hold no case of the sweep
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
    names = sorted({x["case"] for x in sweep})
    k_max = max(float(x["stiffness_N_m"]) for x in sweep)
    rigid_x = 10 * k_max
    for colour, name in zip(("C0", "C1", "C2", "C3", "C4", "C5"), names):
        for method, style in (("vertex_contact_modal", "s-"), ("vdof_nearest", "o--")):
            r = sorted((x for x in sweep if x["case"] == name and x["method"] == method),
                       key=lambda x: float(x["stiffness_N_m"]))
            rigid = [x for x in rows if x["case"] == name and x["method"] == method]
            for a, key in enumerate(("force_error", "impulse_error", "displacement_error")):
                k = [float(x["stiffness_N_m"]) for x in r] + [rigid_x] * len(rigid)
                e = [100 * float(x[key]) for x in r] + [100 * float(x[key]) for x in rigid]
                ax[a].plot(k, e, style, color=colour, ms=4, label=f"{name}, {method}")
                fem = [x for x in r if x["fem_equivalent"] == "1"]
                if fem:
                    ax[a].plot([float(fem[0]["stiffness_N_m"])], [100 * float(fem[0][key])],
                               "k*", ms=10)
    for a, key in enumerate(("force", "impulse", "displacement")):
        ax[a].set_xscale("log")
        ax[a].set_yscale("log")
        ax[a].set_xlabel(f"wall stiffness (N/m; rigid at {rigid_x:g}; star: FEM penalty equivalent)")
        ax[a].set_ylabel(f"{key} error (%)")
        ax[a].set_title(f"Compliant wall: {key} error vs nonlinear FEM")
    ax[0].legend(fontsize=6)
    fig.tight_layout()
    save_figure(fig, d + "/stiffness.png", dpi=110)
