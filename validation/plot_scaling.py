"""Precompute time and peak memory against free DoFs (scripts/scaling.sh): scaling.png."""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from report_files import save_figure, stamp, write_text  # noqa: E402

rows = list(csv.DictReader(open(sys.argv[1])))
fig, (ax_t, ax_m) = plt.subplots(1, 2, figsize=(10, 4))
for ranks, marker in (("1", "o"), ("2", "s")):
    for route, color in (("dense", "tab:blue"), ("sparse", "tab:red")):
        sel = [r for r in rows if r["ranks"] == ranks and r["route"] == route]
        if not sel:
            continue
        x = [int(r["free_dofs"]) for r in sel]
        label = f"{route} route, {ranks} rank(s)"
        ax_t.loglog(x, [float(r["seconds_total"]) for r in sel], marker, color=color,
                    fillstyle="full" if ranks == "1" else "none", label=label)
        ax_m.loglog(x, [float(r["peak_rss_MB"]) for r in sel], marker, color=color,
                    fillstyle="full" if ranks == "1" else "none", label=label)
ax_t.axhline(120, color="gray", ls=":", label="goal: 2 min")
ax_t.axvline(200000, color="gray", ls="--")
ax_t.set(xlabel="free DoFs", ylabel="precompute wall time (s)")
ax_m.set(xlabel="free DoFs", ylabel="peak resident memory, largest process (MB)")
for ax in (ax_t, ax_m):
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
fig.tight_layout()
save_figure(fig, sys.argv[2], dpi=110)

# The report: the table as measured, and what it says.
md = [
    "# Precompute cost against free DoFs",
    "",
    stamp(),
    "",
    "Made by `scripts/scaling.sh` (the numbers below are that run's; rerun it to refresh them).",
    "The grounded cat of `validation/scenes/press.json` (E = 2 kPa, nu = 0.4, rho = 1100, "
    "generalized-alpha, dt = 2 ms) on `cat`, `cat_fine`, `cat_lc5mm` (lc 5 mm, "
    "`meshes/generate.sh --scaling`: its P2 model is the goal's 200k-DoF point) and `cat_xfine` "
    "(meshes/generate.sh), "
    "P1 and P2; inputs are the skin vertices within 1 cm of the press point, outputs every "
    "surface vertex, T = 200 samples in float. Dense route: all modes by LAPACK (exact). Sparse "
    "route: the lowest 200 modes by shift-invert block Lanczos plus two residual modes per input DoF, from the "
    "static and the one-step responses (docs/model-format.md). Time is the wall time "
    "`irdm precompute` reports; memory is the peak resident set of the largest process (GNU "
    "time). Machine: 2 cores, 24 GiB. Measured by hand beside this run, with their commands: "
    "where the sparse route's time goes, stage by stage (`sparse_route.md`), and the full-cat "
    "direct set (`direct_set.md`).",
    "",
    "![time and memory](scaling.png)",
    "",
    "| mesh | P | free DoFs | route | modes | ranks | inputs | outputs | total (s) | FEM (s) | modes (s) | responses (s) | write (s) | peak (MB) |",
    "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
]
for r in rows:
    md.append("| " + " | ".join(r[k] for k in ("mesh", "fe_degree", "free_dofs", "route", "modes",
                                                  "ranks", "inputs", "outputs", "seconds_total",
                                                  "seconds_fem", "seconds_modes",
                                                  "seconds_responses", "seconds_write",
                                                  "peak_rss_MB")) + " |")
md += [
    "",
    "Where the time goes: on the sparse route almost all of it is the eigensolver (`modes`): "
    "the two Cholesky factorizations (K, then K + sigma M for the one-step responses), the "
    "block solves of the shift-invert Lanczos and the orthogonalization of its basis "
    "(`sparse_route.md`). That stage runs on rank 0 alone while the other ranks wait asleep "
    "(2 ranks run with `mpirun --bind-to none`, so that rank 0's BLAS and MUMPS threads may use "
    "both cores), so a second rank helps only the responses and the write, which are small "
    "here, and shares the machine's memory bandwidth with rank 0 during its own FEM set-up.",
]
report = os.path.join(os.path.dirname(sys.argv[2]), "scaling.md")
write_text(report, "\n".join(md) + "\n")
