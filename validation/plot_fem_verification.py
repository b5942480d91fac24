"""Charts for the reference-FEM verification report (reads the CSVs beside report.md).

Usage: /usr/bin/python3 validation/plot_fem_verification.py REPORT_DIR
Needs Debian's python3-matplotlib and python3-numpy.
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from report_files import save_figure  # noqa: E402
import numpy as np  # noqa: E402


def load(path):
    data = np.genfromtxt(path, delimiter=",", names=True)
    return data


def save(fig, path):
    fig.tight_layout()
    save_figure(fig, path, dpi=90)
    plt.close(fig)


def main(out):
    e = load(os.path.join(out, "energy.csv"))
    names = e.dtype.names
    fig, ax = plt.subplots(figsize=(6.5, 3.2))
    ax.plot(e[names[0]], e[names[1]], label="Newmark (average acceleration)")
    ax.plot(e[names[0]], e[names[2]], label="generalized-alpha, rho_inf = 0.8")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("E = 1/2 v'Mv + 1/2 u'Ku (J)")
    ax.legend()
    save(fig, os.path.join(out, "energy.png"))

    d = load(os.path.join(out, "damping.csv"))
    fig, ax = plt.subplots(figsize=(6.5, 3.2))
    ax.plot(d["time_s"], d["tip_uz_normalized"])
    ax.set_xlabel("time (s)")
    ax.set_ylabel("tip displacement / initial")
    save(fig, os.path.join(out, "damping.png"))

    p = load(os.path.join(out, "prescribed.csv"))
    fig, ax1 = plt.subplots(figsize=(6.5, 3.2))
    ax1.plot(p["time_s"], p["probe_Fz_N"], label="F_z on the body (N)")
    ax1.set_xlabel("time (s)")
    ax1.set_ylabel("probe force F_z (N)")
    ax2 = ax1.twinx()
    ax2.plot(p["time_s"], 1e3 * p["probe_uz_m"], "k--", label="prescribed u_z (mm)")
    ax2.set_ylabel("prescribed u_z (mm)")
    save(fig, os.path.join(out, "prescribed.png"))

    b = load(os.path.join(out, "beam_convergence.csv"))
    fig, ax = plt.subplots(figsize=(5, 3.2))
    ax.loglog(np.atleast_1d(b["n_dofs"]), np.abs(np.atleast_1d(b["f1_rel_error_vs_euler_bernoulli"])), "o-",
              label="f1")
    ax.loglog(np.atleast_1d(b["n_dofs"]), np.abs(np.atleast_1d(b["tip_rel_error_vs_beam_theory"])), "s-",
              label="tip deflection")
    ax.set_xlabel("DoFs (P2)")
    ax.set_ylabel("|relative difference to beam theory|")
    ax.legend()
    save(fig, os.path.join(out, "beam_convergence.png"))

    h = load(os.path.join(out, "hertz.csv"))
    series = h["series_0coarse_1fine_2mesh_3penalty"]
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
    coarse = h[series == 0]
    v = np.geomspace(coarse["speed_m_s"].min(), coarse["speed_m_s"].max(), 50)
    # Hertz: F_max is proportional to v^(6/5); scaled through the first theory point.
    f0, v0 = coarse["hertz_peak_N"][0], coarse["speed_m_s"][0]
    ax[0].loglog(v, f0 * (v / v0) ** 1.2, "k-", label="Hertz")
    for code, name, mark in ((0, "FEM, pole h = 0.27 a", "o"), (1, "FEM, pole h = 0.135 a", "s")):
        s = h[series == code]
        if s.size == 0:
            continue
        s = np.atleast_1d(s)
        ax[0].loglog(s["speed_m_s"], s["fem_peak_N"], mark, mfc="none", label=name)
        ax[1].plot(s["hertz_contact_radius_over_R"],
                       100 * (s["fem_peak_N"] / s["hertz_peak_N"] - 1), mark + "-", mfc="none",
                       label=name)
    ax[1].plot(coarse["hertz_contact_radius_over_R"],
                   100 * (coarse["finite_ball_estimate_peak_N"] / coarse["hertz_peak_N"] - 1),
                   "k--", label="finite-ball estimate")
    ax[0].set_xlabel("impact speed (m/s)")
    ax[0].set_ylabel("peak contact force (N)")
    ax[0].legend()
    ax[1].axhline(0, color="k", lw=0.5)
    ax[1].set_xlim(left=0)  # Hertz is the limit a / R -> 0
    ax[1].set_xlabel("Hertz contact radius a / R")
    ax[1].set_ylabel("peak force / Hertz - 1 (%)")
    ax[1].legend()
    save(fig, os.path.join(out, "hertz.png"))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
