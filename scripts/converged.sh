#!/usr/bin/env bash
# The validation scenes on a converged discretization (reports/converged/): press, tap,
# tap_coupled, squeeze and trace with a 2 cm contact-radius probe, on the coarse P1 cat and on the
# P1 cat of lc 3.4 mm (81351 free DoFs; its probe stiffness within 5 % of the extrapolated
# value of reports/convergence/), through the FEM and IRDM on each: method error and
# discretization error apart (irdm validate-converged --help).
# Usage: scripts/converged.sh [build dir] [more validate-converged options]
#        (the project built, e.g. by scripts/build.sh; reports/convergence/convergence.csv
#        from scripts/convergence.sh, committed)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$root/build
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then build=$1; shift; fi
irdm=$build/apps/irdm
[ -x "$irdm" ] || { echo "no $irdm: build the project first (scripts/build.sh)" >&2; exit 2; }
csv=$root/reports/convergence/convergence.csv
[ -f "$csv" ] || { echo "no $csv: run scripts/convergence.sh first" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "== generating the converged cat (gmsh, lc 3.4 mm)" >&2
"$root/meshes/generate.sh" --converged "$work" >&2
# The extrapolated radius-probe stiffness: the P1 fit on the three finest meshes
# (validation/convergence.py, the same fit as reports/convergence/convergence.md).
k_inf=$(/usr/bin/python3 - "$root/validation" "$csv" <<'PY'
import csv, sys
sys.path.insert(0, sys.argv[1])
from convergence import fit, by_size
rows = by_size(list(csv.DictReader(open(sys.argv[2]))), "1")[-3:]
r = fit([float(x["cell_size_m"]) for x in rows], [float(x["stiffness_radius_N_m"]) for x in rows])
if r is None:
    sys.exit("the P1 radius-probe stiffness is not in the asymptotic range: no extrapolated value")
print(f"{r[1]:.6g}")
PY
)
echo "== extrapolated radius-probe stiffness: $k_inf N/m" >&2
"$irdm" validate-converged --converged-mesh "$work/cat_lc3.4mm.msh" \
  --extrapolated-stiffness "$k_inf" --models "$work/models" --out "$root/reports" "$@"
/usr/bin/python3 "$root/validation/plot_converged.py" "$root/reports/converged/series.csv" \
  "$root/reports/converged/converged.png"
