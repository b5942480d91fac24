#!/usr/bin/python3
"""The stable region of a device coupling as a picture, from a coupling sweep's CSV.

Usage: /usr/bin/python3 validation/plot_stable_region.py COUPLING.csv OUT.png [TITLE]

COUPLING.csv: the sweep `irdm validate` (tap_coupled scene, section (f)) or `irdm
validate-planes` (device-held plate) writes: one row per coupling stiffness (N/m, 0 = the rigid
contact), damping (N s/m), time step (s) and solver, with `bounded` (0: the run diverged) and
`passive` (1: the body never gave the device back more energy than it took) and
`device_returned_J`. One panel per solver and time step; each cell is passive (P), bounded but
active (B: energy returned, in J), or diverged (D).
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from report_files import save_figure  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    if not rows:
        sys.exit("plot_stable_region: no rows in " + sys.argv[1])
    panels = sorted({(r["solver"], float(r["time_step_s"])) for r in rows}, key=lambda p: (p[1], p[0]))
    ks = sorted({float(r["stiffness_N_m"]) for r in rows})
    bs = sorted({float(r["damping_N_s_m"]) for r in rows})
    fig, axes = plt.subplots(1, len(panels), figsize=(3.2 * len(panels) + 1, 2.6), squeeze=False)
    cmap = ListedColormap(["#d7301f", "#fdcc8a", "#74c476"])  # diverged, active, passive
    for ax, (solver, tau) in zip(axes[0], panels):
        grid = [[float("nan")] * len(ks) for _ in bs]
        for r in rows:
            if r["solver"] != solver or float(r["time_step_s"]) != tau:
                continue
            i, j = bs.index(float(r["damping_N_s_m"])), ks.index(float(r["stiffness_N_m"]))
            state = 0 if r["bounded"] == "0" else (2 if r["passive"] == "1" else 1)
            grid[i][j] = state
            label = {0: "D", 1: "B\n%.2g J" % float(r["device_returned_J"]), 2: "P"}[state]
            ax.text(j, i, label, ha="center", va="center", fontsize=7)
        ax.imshow(grid, cmap=cmap, vmin=0, vmax=2, origin="lower", aspect="auto")
        ax.set_xticks(range(len(ks)))
        ax.set_xticklabels(["rigid" if k == 0 else "%g" % k for k in ks], rotation=45, fontsize=7)
        ax.set_yticks(range(len(bs)))
        ax.set_yticklabels(["%g" % b for b in bs], fontsize=7)
        ax.set_xlabel("coupling stiffness (N/m)", fontsize=8)
        ax.set_title("%s, time step %g ms" % (solver, 1e3 * tau), fontsize=8)
    axes[0][0].set_ylabel("damping (N s/m)", fontsize=8)
    if len(sys.argv) == 4:
        fig.suptitle(sys.argv[3] + "  (P passive, B bounded but gives energy back, D diverged; blank: not run)", fontsize=9)
    fig.tight_layout()
    save_figure(fig, sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
