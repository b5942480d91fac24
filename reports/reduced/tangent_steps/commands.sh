#!/bin/bash
# reports/reduced/tangent_steps (issue 50): the reduced step with its tangent made inside the
# step that asks for it (--tangent-steps 0) and over 4 or 8 steps, a piece a step, run
# alternately, nothing else of ours running (the host's other load is not ours to stop). From
# the work tree's root, after scripts/build.sh, with the models of
# reports/reduced/step_kernels/commands.txt in out/models/reduced/. The runs here: the play runs
# with the binaries of f30658b (tangent_at_once_ratio 0.5 then, which fired in none of them: no
# tangent was made at once after the first), benchmarks.txt with those of 38feda3 (its default
# 1), benchmarks_at_once_ratio_0.5.txt with f30658b's, the lag runs with a233cae's.
set -euo pipefail
here=reports/reduced/tangent_steps
IRDM=build/apps/irdm
BENCH=build/benchmarks/irdm_reduced_kernels
# The two loops (irdm play), the press of the head as reports/reduced/step_kernels: per round,
# per model and Newton stop, each variant once. forces.csv (per tick) is not kept.
for round in 1 2 3 4 5 6; do
  for case in "cat_top_r222 1e-8" "cat_top_r222 1e-6" "cat_top_r222_c05 1e-6"; do
    set -- $case
    for steps in 0 4 8; do
      out=$here/play/${1}_tol$2_steps${steps}_$round
      rm -rf "$out"
      $IRDM play out/models/reduced/$1.h5 --trajectory examples/trajectories/press_head.csv \
        --coupling-stiffness 50 --coupling-damping 0.05 --rate-hz 500 --quiet \
        --newton-tolerance $2 --tangent-steps $steps --out "$out" > /dev/null || true
      rm -f "$out/forces.csv"
    done
  done
done
# The benchmark (a plane pressing 0 to 5 mm into the top, every step in contact): the kept
# tangent made at once and over 4 and 8 steps (Newton's stop 1e-8 both).
for round in 1 2; do
  for m in cat_top_r222 cat_top_r222_c05; do
    for steps in 4 8; do
      echo "== $m, round $round, tangent over $steps steps"
      $BENCH out/models/reduced/$m.h5 0.005 $steps --benchmark_filter='kept tangent(/|, made)' \
        --benchmark_color=false 2>&1
    done
  done
done > $here/benchmarks.txt
# How much lag the split holds (deterministic: the offline split with its force loop 1 to 8
# deformation steps behind, against the coupling solved in the step; lag.csv).
for case in "cat_top_r222 1e-8" "cat_top_r222 1e-6" "cat_top_r222_c05 1e-6"; do
  set -- $case
  out=$here/lag/${1}_tol$2
  rm -rf "$out"
  $IRDM play out/models/reduced/$1.h5 --trajectory examples/trajectories/press_head.csv \
    --coupling-stiffness 50 --coupling-damping 0.05 --rate-hz 500 --quiet \
    --newton-tolerance $2 --lag-steps 1 2 3 4 8 --out "$out" > /dev/null || true
  rm -f "$out/forces.csv" "$out/deformation.csv"
done
