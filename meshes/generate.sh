#!/usr/bin/env bash
# Regenerates every .msh in this folder from its .geo source (gmsh 4.8, MSH 2.2 ASCII,
# linear tetrahedra). Usage: meshes/generate.sh   (from anywhere)
set -euo pipefail
cd "$(dirname "$0")"
command -v gmsh >/dev/null || { echo "gmsh not found: apt-get install gmsh" >&2; exit 1; }
mesh() { # geo output [name value]...
  local geo=$1 out=$2; shift 2
  local args=()
  while [ $# -gt 0 ]; do args+=(-setnumber "$1" "$2"); shift 2; done
  gmsh -3 "${args[@]}" "$geo" -format msh22 -o "$out" -v 2 >/dev/null
  echo "$out: $(awk '/^\$Nodes/{getline; print $1 " nodes"}' "$out"), $(awk '/^\$Elements/{n=1; next} n==1{n=2; next} n==2 && /^\$End/{exit} n==2 && $2==4{c++} END{print c " tetrahedra"}' "$out")"
}
mesh cat.geo  cat.msh       lc 0.015
mesh cat.geo  cat_fine.msh  lc 0.0068
for n in 2 4 8; do mesh beam.geo "beam_$n.msh" n $n; done
mesh ball.geo ball.msh      lc 0.01
# Balls refined at the pole that touches the floor (Hertz impact, mesh convergence).
mesh ball_pole.geo ball_pole_4.msh lc 0.01 lc_pole 0.004
mesh ball_pole.geo ball_pole_2.msh lc 0.01 lc_pole 0.002
mesh ball_pole.geo ball_pole_1.msh lc 0.01 lc_pole 0.001
