"""Charts of a compression study (the rows of compression.csv, or of the full model's
full_model_compression.csv): speed against accuracy and memory against accuracy, every
compressor and setting a point, unstable runs crossed out, the goals dotted.

    /usr/bin/python3 validation/plot_compression.py CSV SPEED_PNG MEMORY_PNG

Run with Debian's /usr/bin/python3 (matplotlib)."""
import csv
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from report_files import save_figure  # noqa: E402

STYLE = {"IRDM direct": ("k", "s"), "representatives": ("C0", "o"),
         "interpolated": ("C2", "^"), "modal": ("C3", "D"), "era": ("C4", "v"),
         "balanced": ("C5", "P")}
FLOOR = 1e-16  # an exact row drawn at the floor of the log axis


def _label(setting):
    return setting.replace("theta ", "").replace(", blend 3", "").split(" (")[0].split(",")[0]


def speed_chart(rows, path):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, xkey, ykey, xlabel, ylabel in (
            (axes[0], "force_loop_us", "force_rel_l2", "force loop (us/step)", "force rel. L2 error"),
            (axes[1], "surface_update_us", "disp_rms_rel", "full surface update (us/step)",
             "surface RMS error / peak")):
        for method, (color, marker) in STYLE.items():
            rs = [r for r in rows if r["method"] == method]
            if not rs:
                continue
            x = [float(r[xkey]) for r in rs]
            y = [max(float(r[ykey]), FLOOR) for r in rs]
            ax.loglog(x, y, marker=marker, color=color, ls="-" if method != "IRDM direct" else "",
                      label=method)
            for r, xi, yi in zip(rs, x, y):
                ax.annotate(_label(r["setting"]), (xi, yi), fontsize=6,
                            textcoords="offset points", xytext=(3, 3))
                if r["stable"] == "0":
                    ax.plot([xi], [yi], "rx", ms=12, mew=2)
        fem = [r for r in rows if r["method"] == "FEM"]
        if fem:
            ax.axvline(float(fem[0]["force_loop_us"]), color="gray", ls="--",
                       label="reference FEM step (error 0 by definition)")
        ax.axhline(0.01 if ykey == "disp_rms_rel" else 0.02, color="gray", ls=":", lw=1)
        ax.set_xlabel(xlabel); ax.set_ylabel(ylabel); ax.grid(alpha=0.3, which="both")
    axes[0].legend(fontsize=7)
    fig.suptitle("speed against accuracy (red x: unstable in closed loop; dotted: goal)")
    fig.tight_layout(); save_figure(fig, path, dpi=80)


def memory_chart(rows, path):
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for method, (color, marker) in STYLE.items():
        rs = [r for r in rows if r["method"] == method]
        if not rs:
            continue
        x = [float(r["percent_of_float_H"]) for r in rs]
        ax.loglog(x, [max(float(r["disp_rms_rel"]), FLOOR) for r in rs], marker=marker,
                  color=color, ls="-" if method != "IRDM direct" else "", label=method + ": surface RMS")
        ax.loglog(x, [max(float(r["force_rel_l2"]), FLOOR) for r in rs], marker=marker,
                  color=color, ls=":", mfc="none", label=method + ": force L2")
        for r in rs:
            if r["stable"] == "0":
                ax.plot([float(r["percent_of_float_H"])], [max(float(r["disp_rms_rel"]), FLOOR)],
                        "rx", ms=12, mew=2)
    ax.axvline(2, color="gray", ls="--", lw=1, label="goal: 2 % of size")
    ax.axhline(0.01, color="gray", ls=":", lw=1)
    ax.set_xlabel("memory (% of the model's H as float)"); ax.set_ylabel("error")
    ax.legend(fontsize=6); ax.grid(alpha=0.3, which="both"); fig.tight_layout()
    save_figure(fig, path, dpi=80)


def compression_charts(csv_path, speed_png, memory_png):
    with open(csv_path) as fh:
        rows = list(csv.DictReader(fh))
    speed_chart(rows, speed_png)
    memory_chart(rows, memory_png)


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    compression_charts(*sys.argv[1:4])
