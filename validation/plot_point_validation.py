"""Charts for one point-validation scene: reads series.csv, truncation.csv, timestep.csv and
compression.csv in the folder given, writes force.png, error.png, truncation.png,
timestep.png, speed_accuracy.png and memory_accuracy.png. Run with Debian's /usr/bin/python3."""
import sys, os
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from report_files import save_figure  # noqa: E402
from plot_compression import compression_charts  # noqa: E402

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
path = os.path.join(d, "compression.csv")
if os.path.exists(path):
    compression_charts(path, os.path.join(d, "speed_accuracy.png"), os.path.join(d, "memory_accuracy.png"))
