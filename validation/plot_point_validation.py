"""Charts for one point-validation scene: reads series.csv and truncation.csv in the folder
given, writes force.png, error.png, truncation.png. Run with Debian's /usr/bin/python3."""
import sys, os
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from report_files import save_figure  # noqa: E402

d = sys.argv[1]
s = np.genfromtxt(os.path.join(d, "series.csv"), delimiter=",", names=True)
names = s.dtype.names
t = s["time_s"]
probes = sorted({n.split("_fem_F")[0] for n in names if "_fem_F" in n})

fig, ax = plt.subplots(figsize=(7, 3.6))
for p in probes:
    f = np.sqrt(sum(s[f"{p}_fem_F{c}_N"] ** 2 for c in "xyz"))
    g = np.sqrt(sum(s[f"{p}_irdm_F{c}_N"] ** 2 for c in "xyz"))
    ax.plot(t, f, "-", lw=2.5, alpha=0.5, label=f"{p}: FEM")
    ax.plot(t, g, "k--", lw=1, label=f"{p}: IRDM")
ax.set_xlabel("time (s)"); ax.set_ylabel("|contact force| (N)"); ax.legend(fontsize=8)
ax.grid(alpha=0.3); fig.tight_layout(); save_figure(fig, os.path.join(d, "force.png"), dpi=80)

fig, ax = plt.subplots(figsize=(7, 3.6))
eps = 1e-18
ax.semilogy(t, s["force_error_rel"] + eps, label="force, double, untruncated")
ax.semilogy(t, s["disp_rms_error_rel"] + eps, label="surface RMS, double, untruncated")
ax.semilogy(t, s["disp_rms_error_rel_float"] + eps, label="surface RMS, float")
ax.semilogy(t, s["force_error_rel_T500"] + eps, label="force, T = 500")
ax.set_xlabel("time (s)"); ax.set_ylabel("error / peak"); ax.legend(fontsize=8)
ax.grid(alpha=0.3); fig.tight_layout(); save_figure(fig, os.path.join(d, "error.png"), dpi=80)

tr = np.genfromtxt(os.path.join(d, "truncation.csv"), delimiter=",", names=True)
fig, ax = plt.subplots(figsize=(5, 3.6))
ax.loglog(tr["T_steps"], tr["force_rel_l2"] + eps, "o-", label="force rel. L2")
ax.loglog(tr["T_steps"], tr["disp_rms_rel"] + eps, "s-", label="surface RMS / peak")
ax.loglog(tr["T_steps"], tr["disp_max_rel"] + eps, "^-", label="surface max / peak")
ax.set_xlabel("T (steps of 2 ms)"); ax.set_ylabel("error"); ax.legend(fontsize=8)
ax.grid(alpha=0.3, which="both"); fig.tight_layout(); save_figure(fig, os.path.join(d, "truncation.png"), dpi=80)

ts = np.genfromtxt(os.path.join(d, "timestep.csv"), delimiter=",", names=True)
fig, ax = plt.subplots(figsize=(7, 3.6))
for p in probes:
    ax.plot(ts["time_s"], ts[f"{p}_fem_fine_force_N"], "-", lw=2.5, alpha=0.5, label=f"{p}: FEM, tau/10")
    ax.plot(ts["time_s"], ts[f"{p}_irdm_force_N"], "k--", lw=1, label=f"{p}: IRDM, tau")
ax.set_xlabel("time (s)"); ax.set_ylabel("|contact force| (N)"); ax.legend(fontsize=8)
ax.set_title("contact phase, bilateral probes"); ax.grid(alpha=0.3); fig.tight_layout()
save_figure(fig, os.path.join(d, "timestep.png"), dpi=80)

# Compression study (section (e)): speed against accuracy and memory against accuracy.
import csv
path = os.path.join(d, "compression.csv")
if os.path.exists(path):
    rows = list(csv.DictReader(open(path)))
    style = {"IRDM direct": ("k", "s"), "representatives": ("C0", "o"),
             "interpolated": ("C2", "^"), "modal": ("C3", "D"), "era": ("C4", "v"),
             "balanced": ("C5", "P")}
    floor = 1e-16
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, xkey, ykey, xlabel, ylabel in (
            (axes[0], "force_loop_us", "force_rel_l2", "force loop (us/step)", "force rel. L2 error"),
            (axes[1], "surface_update_us", "disp_rms_rel", "full surface update (us/step)",
             "surface RMS error / peak")):
        for method, (color, marker) in style.items():
            rs = [r for r in rows if r["method"] == method]
            if not rs:
                continue
            x = [float(r[xkey]) for r in rs]
            y = [max(float(r[ykey]), floor) for r in rs]
            ax.loglog(x, y, marker=marker, color=color, ls="-" if method != "IRDM direct" else "",
                      label=method)
            for r, xi, yi in zip(rs, x, y):
                ax.annotate(r["setting"].replace("theta ", "").replace(", blend 3", "")
                            .split(" (")[0].split(",")[0], (xi, yi), fontsize=6,
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
    fig.tight_layout(); save_figure(fig, os.path.join(d, "speed_accuracy.png"), dpi=80)

    fig, ax = plt.subplots(figsize=(7, 4.2))
    for method, (color, marker) in style.items():
        rs = [r for r in rows if r["method"] == method]
        if not rs:
            continue
        x = [float(r["percent_of_float_H"]) for r in rs]
        ax.loglog(x, [max(float(r["disp_rms_rel"]), floor) for r in rs], marker=marker,
                  color=color, ls="-" if method != "IRDM direct" else "", label=method + ": surface RMS")
        ax.loglog(x, [max(float(r["force_rel_l2"]), floor) for r in rs], marker=marker,
                  color=color, ls=":", mfc="none", label=method + ": force L2")
        for r in rs:
            if r["stable"] == "0":
                ax.plot([float(r["percent_of_float_H"])], [max(float(r["disp_rms_rel"]), floor)], "rx", ms=12, mew=2)
    ax.axvline(2, color="gray", ls="--", lw=1, label="goal: 2 % of size")
    ax.axhline(0.01, color="gray", ls=":", lw=1)
    ax.set_xlabel("memory (% of the model's H as float)"); ax.set_ylabel("error")
    ax.legend(fontsize=6); ax.grid(alpha=0.3, which="both"); fig.tight_layout()
    save_figure(fig, os.path.join(d, "memory_accuracy.png"), dpi=80)
