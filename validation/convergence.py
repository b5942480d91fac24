"""Mesh convergence of the grounded cat (scripts/convergence.sh): observed rates, extrapolated
values, convergence.md and convergence.png from convergence.csv.

For a quantity q on three meshes of one element degree with sizes h1 > h2 > h3, the model
q(h) = q_inf + C h^p is fitted exactly: p solves (q1 - q2) / (q2 - q3) = (h1^p - h2^p) /
(h2^p - h3^p) (bisection; the meshes are not uniformly refined, so the size ratios differ), then
q_inf = q3 - (q2 - q3) h3^p / (h2^p - h3^p) (Richardson). h is the cell size (V / cells)^(1/3).
The fit needs the differences to shrink monotonically (same sign, |q2 - q3| < |q1 - q2| after
scaling); otherwise the quantity is reported as not in the asymptotic range.
Usage: convergence.py convergence.csv out.md out.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from report_files import save_figure, stamp, write_text  # noqa: E402

QUANTITIES = [
    ("f1_Hz", "first frequency (Hz)"),
    ("f2_Hz", "second frequency (Hz)"),
    ("f3_Hz", "third frequency (Hz)"),
    ("stiffness_radius_N_m", "radius-probe stiffness (N/m)"),
]  # the point probe's stiffness is shown, not fitted: it has no limit (a point load)


def fit(h, q):
    """(p, q_inf) of q = q_inf + C h^p through three points, or None if not monotone."""
    d12, d23 = q[0] - q[1], q[1] - q[2]
    if d12 == 0 or d23 == 0 or (d12 > 0) != (d23 > 0):
        return None
    ratio = d12 / d23
    g = lambda p: (h[0] ** p - h[1] ** p) / (h[1] ** p - h[2] ** p) - ratio
    lo, hi = 1e-3, 8.0
    if g(lo) * g(hi) > 0:
        return None
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if g(lo) * g(mid) <= 0:
            hi = mid
        else:
            lo = mid
    p = 0.5 * (lo + hi)
    q_inf = q[2] - d23 * h[2] ** p / (h[1] ** p - h[2] ** p)
    return p, q_inf


def by_size(rows, deg):
    return sorted((r for r in rows if r["fe_degree"] == deg), key=lambda r: -float(r["cell_size_m"]))


def main():
    rows = list(csv.DictReader(open(sys.argv[1])))
    out_md, out_png = sys.argv[2], sys.argv[3]
    degrees = sorted({r["fe_degree"] for r in rows})
    # Fits on the three finest meshes of each degree.
    limits = {key: {} for key, _ in QUANTITIES}
    for key, _ in QUANTITIES:
        for deg in degrees:
            sel = by_size(rows, deg)[-3:]
            if len(sel) == 3:
                limits[key][deg] = fit([float(r["cell_size_m"]) for r in sel],
                                       [float(r[key]) for r in sel])
    # The reference of each quantity: the extrapolation of the highest degree that has one.
    reference = {}
    for key, _ in QUANTITIES:
        for deg in reversed(degrees):
            if limits[key].get(deg):
                reference[key] = limits[key][deg][1]
                break

    lines = ["# Mesh convergence of the grounded cat", "", stamp(), "",
             "Made by `scripts/convergence.sh` (rerun it to refresh every number here). The "
             "press scene's body (`validation/scenes/press.json`: E = 2 kPa, nu = 0.4, rho = "
             "1100 kg/m^3, fixed base) on five meshes from `meshes/cat.geo` (P1) and the first "
             "three (P2). Frequencies: `irdm modes` (undamped, fixed base). Stiffness: `irdm "
             "probe-stiffness`, the static driving-point stiffness d^T S^-1 d of the press "
             "probe at (-0.035, 0, 0.123) m along d = (0.747, 0, -0.665), as a probe with a "
             "2 cm contact radius (smooth weights over the vertices within it; "
             "docs/scene-format.md) and as the seeds' point probe (its contact triangle's 3 "
             "vertices). The relative columns compare with the extrapolated value of the "
             "highest degree that has a fit.", "",
             "![convergence](convergence.png)", "",
             "## Every run", "",
             "| mesh | P | free DoFs | cell size (mm) | radius patch vertices | f1 (Hz) | f2 (Hz) | "
             "f3 (Hz) | radius-probe stiffness (N/m) | point-probe stiffness (N/m) | "
             "f1 vs extrapolated | radius stiffness vs extrapolated |",
             "|---" * 12 + "|"]
    for deg in degrees:
        for r in by_size(rows, deg):
            rel = []
            for key in ("f1_Hz", "stiffness_radius_N_m"):
                ref = reference.get(key)
                rel.append("%+.1f %%" % (100 * (float(r[key]) - ref) / ref) if ref else "")
            lines.append(
                f"| {r['mesh']} | {deg} | {r['free_dofs']} | {1000 * float(r['cell_size_m']):.2f} | "
                f"{r['patch_vertices']} | {float(r['f1_Hz']):.5g} | {float(r['f2_Hz']):.5g} | "
                f"{float(r['f3_Hz']):.5g} | {float(r['stiffness_radius_N_m']):.4g} | "
                f"{float(r['stiffness_point_N_m']):.4g} | {rel[0]} | {rel[1]} |")
    lines += ["", "## Observed rates and extrapolated values", "",
              "Fitted on the three finest meshes of each degree: q(h) = q_inf + C h^p.", "",
              "| quantity | P | meshes fitted | observed rate p | extrapolated q_inf | finest mesh vs q_inf |",
              "|---" * 6 + "|"]
    for key, label in QUANTITIES:
        for deg in degrees:
            sel = by_size(rows, deg)[-3:]
            names = ", ".join(r["mesh"] for r in sel)
            f = limits[key].get(deg)
            if f is None:
                lines.append(f"| {label} | {deg} | {names} | not monotone: no fit | | |")
            else:
                p, q_inf = f
                err = (float(sel[-1][key]) - q_inf) / abs(q_inf)
                lines.append(f"| {label} | {deg} | {names} | {p:.2f} | {q_inf:.5g} | {100 * err:+.1f} % |")
    write_text(out_md, "\n".join(lines) + "\n")

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for ax, keys in ((axes[0], ["f1_Hz", "f2_Hz", "f3_Hz"]), (axes[1], ["stiffness_radius_N_m"])):
        for key in keys:
            ref = reference.get(key)
            if ref is None:
                continue
            for deg, marker in zip(degrees, "os"):
                sel = by_size(rows, deg)
                ax.loglog([float(r["cell_size_m"]) for r in sel],
                          [abs(float(r[key]) - ref) / abs(ref) for r in sel], marker + "-",
                          label=f"{dict(QUANTITIES)[key]}, P{deg}")
        ax.set(xlabel="cell size (V / cells)^(1/3) (m)",
               ylabel="relative difference from the extrapolated value")
    for deg, marker in zip(degrees, "os"):
        sel = by_size(rows, deg)
        h = [float(r["cell_size_m"]) for r in sel]
        axes[2].semilogx(h, [float(r["stiffness_radius_N_m"]) for r in sel], marker + "-",
                         label=f"radius 2 cm, P{deg}")
        axes[2].semilogx(h, [float(r["stiffness_point_N_m"]) for r in sel], marker + "--",
                         label=f"point probe, P{deg}")
    if "stiffness_radius_N_m" in reference:
        axes[2].axhline(reference["stiffness_radius_N_m"], color="gray", ls=":",
                        label="extrapolated (radius)")
    axes[2].set(xlabel="cell size (V / cells)^(1/3) (m)", ylabel="probe stiffness (N/m)")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Grounded cat (E = 2 kPa, nu = 0.4): mesh convergence")
    fig.tight_layout()
    save_figure(fig, out_png, dpi=110)


if __name__ == "__main__":
    main()
