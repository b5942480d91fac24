#!/usr/bin/python3
"""Charts of `irdm validate-free`: our Fig. 6 and frames of the rolling cat.

Usage: /usr/bin/python3 validation/plot_free.py REPORT_DIR

REPORT_DIR (reports/free) holds series.csv (case, material, method, time_s, fem_force_N,
irdm_force_N, ..., fem_deformation_rms_m, deformation_difference_rms_m; on the rows of a linear
FEM's method the irdm_ columns hold that FEM's path, which the charts leave out), frames.csv (case, material, method, time_s, vertex, x_m, y_m, z_m) and
triangles.csv (a, b, c: surface triangles, vertex indices). Writes:
  fig6.png    the floor force along its normal against time for the rolling cat (spin_roll),
              the FEM and both IRDM routes, one panel per material (N, s);
  frames.png  the rolling cat at six times, FEM and both routes side by side, the firmest
              material (m in the files, mm on the axes);
  impact.png  with impact.csv (the impact study: case, material, speed_m_s,
              speed_over_wave_speed, method, reference, ..., first_deformation_error, ...): the
              first contact's deformation error against the impact speed over the wave speed,
              log-log, one line per material and comparison;
  stability.png with stability.csv (material, method, time_s, energy_gain, ...): the long
              rolls' energy gain over the energy brought in against time, one panel per
              material (symlog: the soft runs grow by orders).
"""
import csv
import sys
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from report_files import save_figure  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

CASE = "spin_roll"
LABELS = {"fem": "nonlinear FEM", "route1_rigid_fit": "IRDM route 1 (rigid fit)",
          "route2_modal": "IRDM route 2 (modal)", "vdof_rigid_fit": "IRDM virtual DOFs (seed 001)"}


def save(fig, path, dpi):
    save_figure(fig, path, dpi=dpi)


def material_key(name):
    return float(name.replace("kPa", ""))


def fig6(folder):
    series = defaultdict(lambda: defaultdict(list))  # material -> column -> values
    with open(folder / "series.csv") as f:
        for row in csv.DictReader(f):
            if row["case"] != CASE:
                continue
            s = series[row["material"]]
            s[row["method"] + ":t"].append(float(row["time_s"]))
            s[row["method"] + ":irdm"].append(float(row["irdm_force_N"]))
            if row["method"] == "route2_modal":
                s["fem:t"].append(float(row["time_s"]))
                s["fem:irdm"].append(float(row["fem_force_N"]))
    if not series:
        print(f"plot_free: series.csv holds no {CASE} rows (the case was not run): no fig6.png",
              file=sys.stderr)
        return True
    materials = sorted(series, key=material_key)
    fig, axes = plt.subplots(len(materials), 1, figsize=(8, 3.2 * len(materials)), squeeze=False)
    for ax, material in zip(axes[:, 0], materials):
        s = series[material]
        for method, style in (("fem", "k-"), ("route1_rigid_fit", "C1--"), ("route2_modal", "C0-"),
                              ("vdof_rigid_fit", "C2:")):
            if s[method + ":t"]:
                ax.plot(s[method + ":t"], s[method + ":irdm"], style, lw=1.2 if method == "fem" else 1,
                        label=LABELS[method])
        ax.set_title(f"{CASE}, E = {material}: floor force")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("force along the floor normal (N)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, folder / "fig6.png", 110)
    return True


def frames(folder):
    tris = np.loadtxt(folder / "triangles.csv", delimiter=",", skiprows=1, dtype=int, ndmin=2)
    data = defaultdict(dict)  # (material, method) -> time -> points
    with open(folder / "frames.csv") as f:
        for row in csv.DictReader(f):
            if row["case"] != CASE:
                continue
            pts = data[(row["material"], row["method"])].setdefault(float(row["time_s"]), [])
            pts.append((int(row["vertex"]), float(row["x_m"]), float(row["y_m"]), float(row["z_m"])))
    if not data:
        print(f"plot_free: frames.csv holds no {CASE} frames (the case was not run): no frames.png",
              file=sys.stderr)
        return True
    material = max({m for m, _ in data}, key=material_key)
    methods = [m for m in ("fem", "route1_rigid_fit", "route2_modal", "vdof_rigid_fit")
               if (material, m) in data]
    times = sorted(data[(material, "fem")])
    fig = plt.figure(figsize=(2.4 * len(times), 2.6 * len(methods)))
    # The view is framed on the FEM (the truth); a method that strays far from it leaves the
    # frame (its panel says so) rather than shrinking every other panel.
    all_pts = np.array([[p[1], p[2], p[3]] for t in times for p in data[(material, "fem")].get(t, [])])
    lo, hi = all_pts.min(axis=0) * 1e3, all_pts.max(axis=0) * 1e3
    half = 0.6 * (hi - lo).max()
    mid = 0.5 * (hi + lo)
    for r, method in enumerate(methods):
        for c, t in enumerate(times):
            ax = fig.add_subplot(len(methods), len(times), r * len(times) + c + 1, projection="3d")
            pts = sorted(data[(material, method)].get(t, []))
            if not pts:
                ax.set_axis_off()
                continue
            x = np.array([[p[1], p[2], p[3]] for p in pts]) * 1e3
            if np.any(np.abs(x - mid).max(axis=0) > half):
                ax.text2D(0.5, 0.5, "out of the frame", transform=ax.transAxes, ha="center",
                          fontsize=7)
            else:
                poly = Poly3DCollection(x[tris], facecolor="C0" if method != "fem" else "0.6",
                                        edgecolor="k", linewidth=0.05, alpha=0.9)
                ax.add_collection3d(poly)
            for i, axis in enumerate((ax.set_xlim, ax.set_ylim, ax.set_zlim)):
                axis(mid[i] - half, mid[i] + half)
            ax.view_init(elev=10, azim=-90)  # from -y: the spin is about y
            ax.set_box_aspect((1, 1, 1))
            ax.tick_params(labelsize=5)
            if r == 0:
                ax.set_title(f"t = {t:.2f} s", fontsize=8)
            if c == 0:
                ax.text2D(-0.15, 0.5, LABELS[method], transform=ax.transAxes, rotation=90,
                          va="center", fontsize=7)
    fig.suptitle(f"{CASE}, E = {material} (mm; viewed along +y)", fontsize=9)
    fig.tight_layout()
    save(fig, folder / "frames.png", 100)
    return True


def impact(folder):
    path = folder / "impact.csv"
    if not path.exists():
        return True  # the study was not run: nothing to draw
    lines = defaultdict(list)  # (material, method, reference) -> [(v / c, error)]
    with open(path) as f:
        for row in csv.DictReader(f):
            key = (row["material"], row["method"], row["reference"])
            lines[key].append((float(row["speed_over_wave_speed"]),
                               float(row["first_deformation_error"])))
    # The linear FEM is the body-frame one (fem_linear_body_frame) or, with
    # --linear-law linear, the plain small-strain one (fem_small_strain).
    linear = "fem_small_strain" if any(r == "fem_small_strain" for _, _, r in lines) else "fem_linear_body_frame"
    name = {"fem_small_strain": "small-strain FEM", "fem_linear_body_frame": "linear FEM (body frame)"}[linear]
    styles = {("route2_modal", "fem_neo_hookean"): ("o-", "IRDM route 2 against the nonlinear FEM"),
              ("route1_rigid_fit", "fem_neo_hookean"): ("s--", "IRDM route 1 against the nonlinear FEM"),
              (linear, "fem_neo_hookean"): ("^-", f"{name} against the nonlinear FEM"),
              ("route2_modal", linear): ("x:", f"IRDM route 2 against the {name}"),
              ("route2_modal_s100", linear): ("+-.", f"IRDM route 2, 100 surface modes, against the {name}")}
    materials = sorted({m for m, _, _ in lines}, key=material_key)
    fig, ax = plt.subplots(figsize=(8, 6.5))
    for i, material in enumerate(materials):
        for (method, reference), (marker, label) in styles.items():
            pts = sorted(lines.get((material, method, reference), []))
            if pts:
                ax.loglog([p[0] for p in pts], [p[1] for p in pts], marker, color=f"C{i}",
                          label=f"{material}: {label}", lw=1, ms=4)
    ax.set_xlabel("impact speed / wave speed sqrt(E / rho)")
    ax.set_ylabel("deformation error over the first contact (rel. RMS)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2)
    fig.tight_layout()
    save(fig, folder / "impact.png", 110)
    return True


def stability(folder):
    path = folder / "stability.csv"
    if not path.exists():
        return True  # the long rolls were not run
    runs = defaultdict(list)  # (material, method) -> [(t, gain)]
    with open(path) as f:
        for row in csv.DictReader(f):
            runs[(row["material"], row["method"])].append((float(row["time_s"]),
                                                           float(row["energy_gain"])))
    if not runs:
        return True
    materials = sorted({m for m, _ in runs}, key=material_key)
    fig, axes = plt.subplots(1, len(materials), figsize=(6 * len(materials), 4.2), squeeze=False)
    for ax, material in zip(axes[0], materials):
        for i, method in enumerate(sorted(m for mat, m in runs if mat == material)):
            pts = runs[(material, method)]
            ax.plot([p[0] for p in pts], [p[1] for p in pts], color=f"C{i}", lw=1, label=method)
        ax.set_yscale("symlog", linthresh=1e-3)
        ax.set_title(material)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("energy gain / energy brought in")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    fig.tight_layout()
    save(fig, folder / "stability.png", 100)
    return True


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    folder = Path(sys.argv[1])
    ok = fig6(folder)
    ok = frames(folder) and ok
    ok = impact(folder) and ok
    ok = stability(folder) and ok
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
