#!/usr/bin/env bash
# Regenerates every .msh in this folder from its .geo source (gmsh 4.8, MSH 2.2 ASCII,
# linear tetrahedra). Usage: meshes/generate.sh   (from anywhere)
#        meshes/generate.sh --study DIR: only the two cats finer than cat_xfine that
#        scripts/convergence.sh uses (lc 3.4 and 2.4 mm; 8 and 22 MB, so not kept here), into DIR
#        meshes/generate.sh --converged DIR: only the lc 3.4 mm cat (scripts/converged.sh)
#        meshes/generate.sh --scaling DIR: only the lc 5 mm cat (scripts/scaling.sh: P2 has
#        210867 free DoFs, just above the 200k of its goal; cat_xfine P2 has 235842)
set -euo pipefail
study_dir= only_converged=0 only_scaling=0
if [ "${1:-}" = "--study" ] || [ "${1:-}" = "--converged" ] || [ "${1:-}" = "--scaling" ]; then
  [ -d "${2:-}" ] || { echo "usage: $0 $1 EXISTING_DIR" >&2; exit 2; }
  study_dir=$(cd "$2" && pwd)
  [ "$1" = "--converged" ] && only_converged=1
  [ "$1" = "--scaling" ] && only_scaling=1
fi
cd "$(dirname "$0")"
command -v gmsh >/dev/null || { echo "gmsh not found: apt-get install gmsh" >&2; exit 1; }
mesh() { # geo output [name value]...
  local geo=$1 out=$2; shift 2
  local args=()
  while [ $# -gt 0 ]; do args+=(-setnumber "$1" "$2"); shift 2; done
  gmsh -3 "${args[@]}" "$geo" -format msh22 -o "$out" -v 2 >/dev/null
  echo "$out: $(awk '/^\$Nodes/{getline; print $1 " nodes"}' "$out"), $(awk '/^\$Elements/{n=1; next} n==1{n=2; next} n==2 && /^\$End/{exit} n==2 && $2==4{c++} END{print c " tetrahedra"}' "$out")"
}
if [ "$only_scaling" -eq 1 ]; then
  mesh cat.geo "$study_dir/cat_lc5mm.msh" lc 0.005
  exit 0
fi
if [ -n "$study_dir" ]; then
  mesh cat.geo "$study_dir/cat_lc3.4mm.msh" lc 0.0034
  [ "$only_converged" -eq 1 ] && exit 0
  mesh cat.geo "$study_dir/cat_lc2.4mm.msh" lc 0.0024
  exit 0
fi
mesh cat.geo  cat.msh       lc 0.015
mesh cat.geo  cat_fine.msh  lc 0.0068
mesh cat.geo  cat_xfine.msh lc 0.0048
for n in 2 4 8; do mesh beam.geo "beam_$n.msh" n $n; done
mesh ball.geo ball.msh      lc 0.01
# Balls refined at the pole that touches the floor (Hertz impact, mesh convergence).
mesh ball_pole.geo ball_pole_4.msh lc 0.01 lc_pole 0.004
mesh ball_pole.geo ball_pole_2.msh lc 0.01 lc_pole 0.002
mesh ball_pole.geo ball_pole_1.msh lc 0.01 lc_pole 0.001
# The Hertz speed sweep: at each impact speed v (mm/s) a ball whose pole mesh scales with
# Hertz's contact radius a(v) (ball R 5 cm, E 20 kPa, nu 0.4, rho 1100: validation's HertzBall),
# so that the sweep compares like with like: coarse h = 0.27 a, fine h = 0.135 a, refined out to
# 1.6 a. At 20 mm/s these are ball_pole_2 and ball_pole_1 (a = 7.4 mm).
contact_radius() { # v in mm/s -> a in m: a = sqrt(R delta), delta = (15 m v^2 / (16 E* sqrt R))^(2/5)
  awk -v v="$1" 'BEGIN { R = 0.05; E = 2e4; nu = 0.4; rho = 1100; pi = atan2(0, -1);
    m = rho * 4 / 3 * pi * R^3; Es = E / (1 - nu^2); s = v / 1000;
    d = (15 * m * s^2 / (16 * Es * sqrt(R)))^0.4; printf "%.6g", sqrt(R * d) }'
}
for v in 1.25 2.5 5 10 50 100 200; do
  a=$(contact_radius $v)
  sizes=(coarse 0.27)
  case $v in 1.25|2.5|5|10) sizes+=(fine 0.135);; esac
  for ((i = 0; i < ${#sizes[@]}; i += 2)); do
    mesh ball_pole.geo "ball_hertz_${v}mms_${sizes[i]}.msh" lc 0.01 \
      lc_pole "$(awk -v a="$a" -v r="${sizes[i+1]}" 'BEGIN { printf "%.6g", r * a }')" \
      dist_min "$(awk -v a="$a" 'BEGIN { printf "%.6g", 1.6 * a }')"
  done
done
