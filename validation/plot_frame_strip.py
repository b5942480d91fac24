#!/usr/bin/python3
"""Frame strip of an `irdm play` run: a few VTU frames of the deformed surface side by side.

Usage: /usr/bin/python3 validation/plot_frame_strip.py SURFACE_DIR OUT.png [N_FRAMES]

SURFACE_DIR holds surface.pvd and the ASCII VTU frames `irdm play` writes (deformed points,
triangles, displacement_m per vertex). The strip shows N_FRAMES (default 6) frames: the one
with the largest displacement and frames evenly spaced in time around it, each coloured by
|u| in mm on one colour scale, viewed from the same camera. Units: m in the files, mm on the
colour bar; times from surface.pvd (s).
"""
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from report_files import save_figure  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402


def read_vtu(path):
    piece = ET.parse(path).getroot().find("UnstructuredGrid/Piece")
    points = np.array(piece.find("Points/DataArray").text.split(), float).reshape(-1, 3)
    cells = piece.find("Cells")
    connectivity = None
    for array in cells.findall("DataArray"):
        if array.get("Name") == "connectivity":
            connectivity = np.array(array.text.split(), int).reshape(-1, 3)
    displacement = None
    for array in piece.find("PointData").findall("DataArray"):
        if array.get("Name") == "displacement_m":
            displacement = np.array(array.text.split(), float).reshape(-1, 3)
    if connectivity is None or displacement is None:
        raise ValueError(f"{path}: no triangle connectivity or displacement_m")
    return points, connectivity, displacement


def main():
    if len(sys.argv) not in (3, 4):
        print(__doc__, file=sys.stderr)
        return 2
    folder, out = Path(sys.argv[1]), Path(sys.argv[2])
    n_frames = int(sys.argv[3]) if len(sys.argv) == 4 else 6
    pvd = ET.parse(folder / "surface.pvd").getroot()
    entries = [(float(d.get("timestep")), folder / d.get("file"))
               for d in pvd.iter("DataSet")]
    if not entries:
        raise SystemExit(f"{folder}/surface.pvd lists no frames")
    frames = [(t, *read_vtu(f)) for t, f in entries]
    peak = [np.linalg.norm(u, axis=1).max() for _, _, _, u in frames]
    k_peak = int(np.argmax(peak))
    # Evenly spaced frames that include the peak one.
    picks = sorted(set(np.linspace(0, len(frames) - 1, n_frames).round().astype(int)) | {k_peak})
    if len(picks) > n_frames:
        picks.remove(min((p for p in picks if p != k_peak), key=lambda p: abs(p - k_peak)))
    scale = 1e3 * max(peak) or 1.0
    fig = plt.figure(figsize=(2.2 * len(picks), 2.8))
    cmap = plt.get_cmap("viridis")
    lo = np.min([f[1].min(axis=0) for f in frames], axis=0)
    hi = np.max([f[1].max(axis=0) for f in frames], axis=0)
    for i, k in enumerate(picks):
        t, x, tri, u = frames[k]
        ax = fig.add_subplot(1, len(picks), i + 1, projection="3d")
        mag = 1e3 * np.linalg.norm(u, axis=1)
        colour = cmap(mag[tri].mean(axis=1) / scale)
        ax.add_collection3d(Poly3DCollection(x[tri], facecolors=colour, edgecolor="none"))
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        ax.set_box_aspect(hi - lo)
        ax.view_init(elev=15, azim=-60)
        ax.set_axis_off()
        ax.set_title(f"t = {t:.3f} s\nmax |u| = {mag.max():.2f} mm", fontsize=8)
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(0, scale))
    fig.colorbar(sm, ax=fig.axes, shrink=0.6, label="|u| (mm)")
    save_figure(fig, out, dpi=110, bbox_inches="tight")
    return 0


if __name__ == "__main__":
    sys.exit(main())
