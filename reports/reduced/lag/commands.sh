#!/bin/bash
# reports/reduced/lag (issue 50): the two loops' split with its force loop behind, the force loop
# answering for the window between its state and the present (irdm/reduced_force_loop.h). From
# the work tree's root, after scripts/build.sh, with the models of
# reports/reduced/step_kernels/commands.txt in out/models/reduced/. The "before" figures are
# reports/reduced/tangent_steps/lag/*/lag.csv (the same commands, a233cae's binaries).
set -euo pipefail
here=reports/reduced/lag
IRDM=build/apps/irdm
# Deterministic: the offline split 1 to 8 deformation steps behind for the whole run, against
# the coupling solved in the step (lag.csv); the press of the head at 50 N/m.
for case in "cat_top_r222 1e-8" "cat_top_r222 1e-6" "cat_top_r222_c05 1e-6"; do
  set -- $case
  out=$here/${1}_tol$2
  rm -rf "$out"
  $IRDM play out/models/reduced/$1.h5 --trajectory examples/trajectories/press_head.csv \
    --coupling-stiffness 50 --coupling-damping 0.05 --rate-hz 500 --quiet \
    --newton-tolerance $2 --lag-steps 1 2 3 4 8 --out "$out" > /dev/null || true
  rm -f "$out/forces.csv" "$out/deformation.csv"
done
# The force loop's cost with the answer (real time, nothing else of ours running): three runs
# of the looser cubature's model at 1e-6, 500 Hz and 1 kHz; summary.csv kept.
for round in 1 2 3; do
  for rate in 500 1000; do
    out=$here/play/cat_top_r222_c05_tol1e-6_${rate}hz_$round
    rm -rf "$out"
    $IRDM play out/models/reduced/cat_top_r222_c05.h5 --trajectory examples/trajectories/press_head.csv \
      --coupling-stiffness 50 --coupling-damping 0.05 --rate-hz $rate --quiet \
      --newton-tolerance 1e-6 --no-check --out "$out" > /dev/null || true
    rm -f "$out/forces.csv" "$out/deformation.csv"
  done
done
