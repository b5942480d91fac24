#!/usr/bin/env bash
# Precompute time and peak memory against free DoFs (reports/scaling/): the grounded cat on
# cat, cat_fine, cat_lc5mm (meshes/generate.sh --scaling: P2 210867 free DoFs, the goal's
# 200k) and cat_xfine, P1 and P2, with 1 and 2 MPI ranks. Every model: the press
# scene's body and material (validation/scenes/press.json), inputs within 1 cm of the press
# point, every surface vertex an output, T = 200 samples in float (the H file stays small on
# the finest mesh). Dense route up to 12000 free DoFs, sparse route (200 lowest modes +
# residual modes) beyond. Its time on 2 cores: reports/scaling.
# Usage: scripts/scaling.sh [build dir]   (the project built, e.g. by scripts/build.sh)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
irdm=${1:-$root/build}/apps/irdm
out=$root/reports/scaling
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
[ -x "$irdm" ] || { echo "no $irdm: build the project first (scripts/build.sh)" >&2; exit 2; }
mkdir -p "$out"
csv=$work/scaling.csv
echo "mesh,fe_degree,free_dofs,route,modes,ranks,inputs,outputs,seconds_total,seconds_fem,seconds_modes,seconds_responses,seconds_write,peak_rss_MB" > "$csv"
echo "== generating cat_lc5mm (gmsh, lc 5 mm)" >&2
"$root/meshes/generate.sh" --scaling "$work" >&2
for mesh in cat cat_fine cat_lc5mm cat_xfine; do
  mesh_file=$root/meshes/$mesh.msh
  [ -f "$mesh_file" ] || mesh_file=$work/$mesh.msh
  for p in 1 2; do
    scene=$work/scene_${mesh}_p$p.json
    sed -e "s|\"file\": \"../../meshes/cat.msh\"|\"file\": \"$mesh_file\"|" \
        -e "s|\"fe_degree\": 1|\"fe_degree\": $p|" \
        -e 's|"length": 1000, "storage": "double"|"length": 200, "storage": "float"|' \
        -e 's|"radius_m": 0.02|"radius_m": 0.01|' \
        "$root/validation/scenes/press.json" > "$scene"
    for ranks in 1 2; do
      launcher=()
      # --bind-to none: Open MPI binds each of up to 2 ranks to one core by default, and the
      # modes run on rank 0 alone (its BLAS and MUMPS threads then get one core).
      [ "$ranks" -gt 1 ] && launcher=(mpirun --allow-run-as-root --oversubscribe --bind-to none -np "$ranks")
      echo "== $mesh P$p, $ranks rank(s)" >&2
      /usr/bin/time -f "%M" -o "$work/rss" "${launcher[@]}" "$irdm" precompute "$scene" \
        --out "$work/model.h5" --restart --quiet > "$work/stdout"
      cat "$work/stdout" >&2
      /usr/bin/python3 - "$mesh" "$p" "$ranks" "$(tail -1 "$work/rss")" "$work/stdout" >> "$csv" <<'PY'
import re, sys
mesh, p, ranks, rss_kb, path = sys.argv[1:]
text = open(path).read()
io = re.search(r"(\d+) outputs x (\d+) inputs", text)
r = re.search(r"(\d+) free DoFs, (\w+) route, (\d+) modes", text)
t = re.search(r"total ([\d.]+) s = FEM ([\d.]+) \+ modes ([\d.]+) \+ responses ([\d.]+) \+ write ([\d.]+)", text)
print(",".join([mesh, p, r[1], r[2], r[3], ranks, io[2], io[1], *t.groups(), "%.0f" % (int(rss_kb) / 1024)]))
PY
      rm -f "$work/model.h5"
    done
  done
done
{ head -1 "$csv"; tail -n +2 "$csv" | sort -t, -k3,3n -k6,6n; } > "$work/sorted.csv"
cp "$work/sorted.csv" "$out/scaling.csv.part" && mv "$out/scaling.csv.part" "$out/scaling.csv"
/usr/bin/python3 "$root/validation/plot_scaling.py" "$out/scaling.csv" "$out/scaling.png"
echo "wrote $out/scaling.csv and scaling.png" >&2
