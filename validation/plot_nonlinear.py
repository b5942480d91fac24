#!/usr/bin/python3
"""The nonlinear map's charts, from DIR/nonlinear.csv (irdm validate-nonlinear):
map.png and map_force.png (each method's error against the dimensionless load, one panel per
family and material, the 5 % and 10 % lines), map_p1.png (the shape error against the P1 truth
alone, from against_p1.csv), speed_accuracy.png (error against cost per step,
one panel per scene family: grounded and free)."""
import csv
import math
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LOAD = {
    "press_top": "depth / extent",
    "press_side": "depth / extent",
    "press_between": "depth / extent",
    "press_oblique": "depth / extent",
    "impact_side": "speed / wave speed",
    "free_impact": "speed / wave speed",
    "free_drop": "impact speed / wave speed",
}


def number(s):
    return float(s) if s != "" else math.nan


def shape(r):
    d = number(r["displacement_error"])
    return d if not math.isnan(d) else number(r["deformation_error"])


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def styles(methods):
    cmap = plt.get_cmap("tab20")
    return {m: cmap(i % 20) for i, m in enumerate(sorted(methods))}


def draw_map(rows, measure, out, title):
    panels = sorted({(r["family"], r["material"]) for r in rows})
    if not panels:
        return
    color = styles({r["method"] for r in rows})
    n = len(panels)
    cols = min(3, n)
    fig, axes = plt.subplots((n + cols - 1) // cols, cols, figsize=(5.2 * cols, 4.0 * ((n + cols - 1) // cols)),
                             squeeze=False)
    for ax, (family, material) in zip(axes.flat, panels):
        lines = defaultdict(list)
        for r in rows:
            if r["family"] == family and r["material"] == material:
                lines[r["method"]].append(r)
        for method, pts in sorted(lines.items()):
            pts.sort(key=lambda r: number(r["load"]))
            x = [number(r["load"]) for r in pts]
            y = [max(measure(r), 1e-6) for r in pts]
            ax.plot(x, y, "-", color=color[method], lw=1, label=method)
            for xi, yi, r in zip(x, y, pts):
                filled = r["truth"] == "fem_neo_hookean_p2"
                ax.plot(xi, yi, "o", ms=4, color=color[method],
                        mfc=color[method] if filled else "none")
        for level in (0.05, 0.10):
            ax.axhline(level, ls="--", color="grey", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(LOAD.get(family, "load"))
        ax.set_ylabel(title)
        ax.set_title(f"{family}, {material}", fontsize=9)
        ax.grid(True, which="both", alpha=0.2)
        ax.legend(fontsize=6)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def draw_speed(rows, out):
    groups = {"grounded cat": [r for r in rows if not r["family"].startswith("free_")],
              "free cat": [r for r in rows if r["family"].startswith("free_")]}
    groups = {k: v for k, v in groups.items() if v}
    if not groups:
        return
    color = styles({r["method"] for r in rows})
    fig, axes = plt.subplots(1, len(groups), figsize=(6.5 * len(groups), 4.8), squeeze=False)
    for ax, (name, pts) in zip(axes.flat, groups.items()):
        seen = set()
        for r in pts:
            x, y = number(r["us_per_step"]), shape(r)
            if math.isnan(x) or math.isnan(y) or x <= 0:
                continue
            m = r["method"]
            ax.plot(x, max(y, 1e-6), "o", ms=3, alpha=0.7, color=color[m],
                    label=None if m in seen else m)
            seen.add(m)
        for level in (0.05, 0.10):
            ax.axhline(level, ls="--", color="grey", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("cost per step (us)")
        ax.set_ylabel("shape error")
        ax.set_title(name, fontsize=9)
        ax.grid(True, which="both", alpha=0.2)
        ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main():
    if len(sys.argv) != 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        print("usage: plot_nonlinear.py DIR")
        return 0 if len(sys.argv) == 2 else 2
    d = sys.argv[1]
    rows = read(f"{d}/nonlinear.csv")
    draw_map(rows, shape, f"{d}/map.png", "shape error")
    # Every row against the P1 truth, the methods' own mesh: the map without the truth's
    # discretization error.
    draw_map(read(f"{d}/against_p1.csv"), shape, f"{d}/map_p1.png", "shape error (P1 truth)")
    draw_map(rows, lambda r: number(r["force_error"]), f"{d}/map_force.png", "force error")
    draw_speed(rows, f"{d}/speed_accuracy.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
