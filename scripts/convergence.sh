#!/usr/bin/env bash
# Mesh convergence of the grounded cat (reports/convergence/): the lowest three natural
# frequencies and the static driving-point stiffness of the press scene's probe, as a probe
# with a 2 cm contact radius (converges) and as a point probe (does not), on cat, cat_fine,
# cat_xfine (P1 and P2) and two finer cats (P1 only; meshes/generate.sh --study makes them in
# a temporary folder). Observed rates and extrapolated values: validation/convergence.py.
# Takes about 10 minutes and 7 GB on 2 cores.
# Usage: scripts/convergence.sh [build dir]   (the project built, e.g. by scripts/build.sh)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
irdm=${1:-$root/build}/apps/irdm
out=$root/reports/convergence
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
[ -x "$irdm" ] || { echo "no $irdm: build the project first (scripts/build.sh)" >&2; exit 2; }
mkdir -p "$out"
echo "== generating the two finer cats (gmsh)" >&2
"$root/meshes/generate.sh" --study "$work" >&2
csv=$work/convergence.csv
echo "mesh,lc_m,fe_degree,free_dofs,cells,cell_size_m,patch_vertices,f1_Hz,f2_Hz,f3_Hz,stiffness_radius_N_m,stiffness_point_N_m,seconds_stiffness,seconds_modes" > "$csv"
run() { # mesh-name mesh-file lc degree
  local name=$1 file=$2 lc=$3 p=$4 scene=$work/scene.json
  echo "== $name P$p" >&2
  # The press scene's body and probe point; 'finger' with a 2 cm contact radius, 'point' the
  # seeds' point probe at the same place.
  /usr/bin/python3 - "$root/validation/scenes/press.json" "$file" "$p" "$scene" <<'PY'
import json, sys
src, mesh, p, dst = sys.argv[1:]
s = json.load(open(src))
s["mesh"]["file"] = mesh
s["fe_degree"] = int(p)
finger = s["probes"][0]
finger["radius_m"] = 0.02
point = dict(finger, name="point")
del point["radius_m"]
s["probes"] = [finger, point]
json.dump(s, open(dst, "w"), indent=1)
PY
  "$irdm" probe-stiffness "$scene" > "$work/stiffness.txt"
  local t0=$SECONDS
  "$irdm" modes "$scene" --count 3 > "$work/modes.txt"
  local modes_seconds=$((SECONDS - t0))
  cat "$work/stiffness.txt" "$work/modes.txt" >&2
  /usr/bin/python3 - "$name" "$lc" "$p" "$work/stiffness.txt" "$work/modes.txt" "$modes_seconds" >> "$csv" <<'PY'
import re, sys
name, lc, p, stiffness, modes, modes_seconds = sys.argv[1:]
s = open(stiffness).read()
head = re.search(r"P\d, (\d+) free DoFs, (\d+) cells, cell size \(V/cells\)\^\(1/3\) ([\d.e+-]+) m", s)
finger = re.search(r"probe finger: radius [\d.e+-]+ m, (\d+) vertices, stiffness ([\d.e+-]+) N/m", s)
point = re.search(r"probe point: radius 0 m, \d+ vertices, stiffness ([\d.e+-]+) N/m", s)
seconds = re.search(r"time: ([\d.]+) s", s)
f = re.findall(r"mode \d+: ([\d.e+-]+) Hz", open(modes).read())
print(",".join([name, lc, p, head[1], head[2], head[3], finger[1], *f[:3], finger[2], point[1],
                seconds[1], modes_seconds]))
PY
}
for p in 1 2; do
  run cat "$root/meshes/cat.msh" 0.015 $p
  run cat_fine "$root/meshes/cat_fine.msh" 0.0068 $p
  run cat_xfine "$root/meshes/cat_xfine.msh" 0.0048 $p
done
# P2 on the finer cats would be 0.6 and 1.6 million DoFs: beyond this machine's direct solver.
run cat_lc3.4mm "$work/cat_lc3.4mm.msh" 0.0034 1
run cat_lc2.4mm "$work/cat_lc2.4mm.msh" 0.0024 1
cp "$csv" "$out/convergence.csv.part" && mv "$out/convergence.csv.part" "$out/convergence.csv"
/usr/bin/python3 "$root/validation/convergence.py" "$out/convergence.csv" "$out/convergence.md" \
  "$out/convergence.png"
echo "wrote $out/convergence.{csv,md,png}" >&2
