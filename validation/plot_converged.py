"""The probe force against time on the coarse and the converged cat (reports/converged/).

One panel per scene and probe: the force along the probe's direction (N) from the FEM and from
IRDM on each discretization, as written by `irdm validate-converged` to series.csv.
Usage: /usr/bin/python3 plot_converged.py series.csv out.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from report_files import save_figure  # noqa: E402


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    panels = []
    for r in rows:
        key = (r["scene"], r["probe"])
        if key not in panels:
            panels.append(key)
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 2.6 * len(panels)), squeeze=False)
    curves = [
        ("fem_coarse_N", "FEM, coarse cat P1", "tab:blue", "-"),
        ("irdm_coarse_N", "IRDM, coarse cat P1", "tab:cyan", "--"),
        ("fem_converged_N", "FEM, converged cat", "black", "-"),
        ("irdm_converged_N", "IRDM, converged cat", "tab:orange", "--"),
    ]
    for ax, (scene, probe) in zip(axes[:, 0], panels):
        sel = [r for r in rows if r["scene"] == scene and r["probe"] == probe]
        t = [float(r["t_s"]) for r in sel]
        for column, label, colour, style in curves:
            ax.plot(t, [float(r[column]) for r in sel], style, color=colour, label=label, lw=1.2)
        # The time axis up to a little past the last force (a tap lasts 20 ms of 0.6 s).
        active = [x for x, r in zip(t, sel) if any(abs(float(r[c])) > 1e-9 for c, *_ in curves)]
        if active:
            ax.set_xlim(0, min(t[-1], 1.25 * active[-1] + 0.01))
        ax.set_title(f"{scene}: probe {probe}", fontsize=10)
        ax.set_ylabel("force (N)")
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time (s)")
    axes[0, 0].legend(fontsize=8, loc="best")
    fig.tight_layout()
    save_figure(fig, sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
