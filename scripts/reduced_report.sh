#!/usr/bin/env bash
# The reduced nonlinear model's haptic figures (reports/reduced; docs/reduced-model.md): the
# models, the deformation step's benchmark (Newton beside the kept tangent), the two loops of
# `irdm play` on a press of the head, the map's grounded family with the reduced models
# against the P1 neo-Hookean truth, two walls and a sliding wall, the side presses with a model
# of the side's reach, the free cat at 50 kPa, and the cubature trained on the FEM beside the
# reduced model's own. Run on a quiet machine: the timings are the point.
# Usage: scripts/reduced_report.sh [report dir]   (default reports/reduced)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-reports/reduced}
models=out/models/reduced
mkdir -p "$models" "$out" out/models/quick
irdm=build/apps/irdm
# The models (each made once): r = 82, the first basis; r = 222, more modes with their
# derivatives. Both with the default cubature (1 % training residual).
[ -f $models/cat_top.h5 ] ||
  $irdm precompute validation/scenes/reduced/cat_top.json --reduced --basis 82 --out $models/cat_top.h5
[ -f $models/cat_top_r222.h5 ] ||
  $irdm precompute validation/scenes/reduced/cat_top.json --reduced --modes 100 --derivative-modes 60 \
    --basis 222 --out $models/cat_top_r222.h5
for m in cat_top cat_top_r222; do
  # The deformation step on one core: a top press going between 0 and 5 mm.
  build/benchmarks/irdm_reduced_kernels $models/$m.h5 0.005 --benchmark_min_time=2 \
    --benchmark_repetitions=3 --benchmark_color=false > "$out/kernels_$m.txt"
  # The two loops in real time, the force loop at the model's rate and at 1 kHz.
  for rate in 500 1000; do
    $irdm play $models/$m.h5 --trajectory examples/trajectories/press_head.csv \
      --coupling-stiffness 50 --coupling-damping 0.05 --rate-hz $rate --quiet \
      --out "$out/play_${m}_${rate}hz" > /dev/null || [ $? -eq 3 ] # 3: deadlines missed, reported
  done
done
# The map's grounded family (presses and side impacts) with the reduced models, against the
# P1 truth (the P2 truth is the map's own: reports/nonlinear).
$irdm validate-nonlinear --families planes --model out/models/quick/cat_vdof.h5 --subdivisions 1 \
  --vertex-model out/models/quick/cat_vertex.h5 --converged-cases none \
  --reduced-model $models/cat_top.h5 $models/cat_top_r222.h5 --out "$out"
# Two walls at once and a sliding wall (validate-planes' press_top_and_side and slide_side
# cases): models whose inputs are the skin those walls can reach (scene files made by
# scripts/contact_region_scene.py), every element, against the P1 truth.
for s in cat_top_and_side cat_slide; do
  n=$(grep -c center_m validation/scenes/reduced/$s.json)
  [ -f $models/$s.h5 ] ||
    $irdm precompute validation/scenes/reduced/$s.json --reduced --modes 100 --derivative-modes 60 \
      --basis $((100 + 3 * n + 80)) --cubature-tolerance 0 --out $models/$s.h5
done
$irdm validate-planes --cases press_top_and_side slide_side --model out/models/quick/cat_vdof.h5 \
  --subdivisions 1 --vertex-model out/models/quick/cat_vertex.h5 --no-direct --no-corotational \
  --converged-degree 0 --perturbations 0 --stiffness-sweep 0 \
  --reduced-model $models/cat_top_and_side.h5 $models/cat_slide.h5 --out "$out"
/usr/bin/python3 scripts/force_chatter.py "$out/planes/forces.csv" > "$out/planes/chatter.csv.part"
mv "$out/planes/chatter.csv.part" "$out/planes/chatter.csv"
# The side presses to 10 mm (the map's; past 3 mm the wall also reaches a second part of the
# body) with a model whose inputs are the skin the side wall can reach, every element.
n=$(grep -c center_m validation/scenes/reduced/cat_side.json)
[ -f $models/cat_side.h5 ] ||
  $irdm precompute validation/scenes/reduced/cat_side.json --reduced --modes 100 --derivative-modes 60 \
    --basis $((100 + 3 * n + 80)) --cubature-tolerance 0 --out $models/cat_side.h5
$irdm validate-nonlinear --families planes --model out/models/quick/cat_vdof.h5 --subdivisions 1 \
  --vertex-model out/models/quick/cat_vertex.h5 --press-directions side \
  --press-depths 0.0005 0.002 0.005 0.01 --impact-speeds none --converged-cases none --no-direct \
  --reduced-model $models/cat_side.h5 --out "$out/side"
# A free body at 50 kPa (validate-free's floor and wall cases): a model whose inputs are the
# skin and base the floor (upright and tilted) and the wall can reach, with the six uniform
# strain fields (in their own folder: a model made before them is refused), every element and
# with a cubature trained on FEM snapshots, against the neo-Hookean truth, in the floating
# frame; and the cubature model in one frame beside it.
n=$(grep -c center_m validation/scenes/reduced/free_cat_floor_and_wall.json)
basis=$((6 + 100 + 3 * n + 6 + 80))
free_models=out/models/reduced_v3
mkdir -p $free_models
[ -f $free_models/free_cat_50kPa.h5 ] ||
  $irdm precompute validation/scenes/reduced/free_cat_floor_and_wall.json --reduced --modes 100 \
    --derivative-modes 60 --basis $basis --cubature-tolerance 0 --out $free_models/free_cat_50kPa.h5
[ -f $free_models/free_cat_50kPa_cubature.h5 ] ||
  $irdm precompute validation/scenes/reduced/free_cat_floor_and_wall.json --reduced --modes 100 \
    --derivative-modes 60 --basis $basis --training-source fem --out $free_models/free_cat_50kPa_cubature.h5 \
    > "$out/precompute_free_cat_50kPa_cubature.txt"
free_cases="--materials 50000 --fem-divisions 1 --cases drop_2cm,drop_5cm,drop_10cm,tilted_5cm,wall_throw,probe_push,spin_roll
  --vdof-subdivisions -1 --force-modes 0 --stability 0.002 --converged-degree 0 --no-corotational"
$irdm validate-free $free_cases \
  --reduced-model $free_models/free_cat_50kPa.h5 $free_models/free_cat_50kPa_cubature.h5 \
  --out "$out/free_frame" --model-dir out/models/free
$irdm validate-free $free_cases --reduced-model $free_models/free_cat_50kPa_cubature.h5 \
  --reduced-one-frame --out "$out/free_one_frame" --model-dir out/models/free
# The same scene with the inputs' band widened to 12 + 3 mm, so that the residual modes cover
# the contact patch at its largest (every element), on the cases the narrow band missed and
# the drops.
n=$(grep -c center_m validation/scenes/reduced/free_cat_floor_and_wall_12mm.json)
[ -f $free_models/free_cat_50kPa_wide.h5 ] ||
  $irdm precompute validation/scenes/reduced/free_cat_floor_and_wall_12mm.json --reduced --modes 100 \
    --derivative-modes 60 --basis $((6 + 100 + 3 * n + 6 + 80)) --cubature-tolerance 0 \
    --out $free_models/free_cat_50kPa_wide.h5
$irdm validate-free --materials 50000 --fem-divisions 1 --cases tilted_5cm,wall_throw \
  --vdof-subdivisions -1 --force-modes 0 --stability 0.002 --converged-degree 0 --no-corotational \
  --reduced-model $free_models/free_cat_50kPa_wide.h5 --out "$out/free_inputs" --model-dir out/models/free
$irdm validate-free --materials 50000 --fem-divisions 1 --cases drop_2cm,drop_5cm,spin_roll \
  --vdof-subdivisions -1 --force-modes 0 --stability 0.002 --converged-degree 0 --no-corotational \
  --reduced-model $free_models/free_cat_50kPa_wide.h5 --out "$out/free_inputs_drops" --model-dir out/models/free
# The wide model with a cubature trained on FEM snapshots, on the five cases, the forces' true
# torques (the default) beside the projection's own; and the 60 s roll of the r = 387 cubature
# model with the true torques.
[ -f $free_models/free_cat_50kPa_wide_cubature.h5 ] ||
  $irdm precompute validation/scenes/reduced/free_cat_floor_and_wall_12mm.json --reduced --modes 100 \
    --derivative-modes 60 --basis $((6 + 100 + 3 * n + 6 + 80)) --training-source fem \
    --out $free_models/free_cat_50kPa_wide_cubature.h5
$irdm validate-free --materials 50000 --fem-divisions 1 --cases tilted_5cm,wall_throw,spin_roll,drop_2cm,drop_5cm \
  --vdof-subdivisions -1 --force-modes 0 --stability 0.002 --converged-degree 0 --no-corotational \
  --reduced-model $free_models/free_cat_50kPa_wide_cubature.h5 --reduced-projected-torque \
  --out "$out/free_true_torques" --model-dir out/models/free
$irdm validate-free --materials 50000 --fem-divisions 1 --cases spin_roll --vdof-subdivisions -1 \
  --force-modes 0 --stability 60 --converged-degree 0 --no-corotational \
  --reduced-model $free_models/free_cat_50kPa_cubature.h5 --out "$out/free_roll60_true" --model-dir out/models/free
for d in free_frame free_one_frame free_inputs free_inputs_drops free_true_torques free_roll60_true; do # validate-free writes into <out>/free
  mv "$out/$d/free/"* "$out/$d/" && rmdir "$out/$d/free"
done
# The cubature trained on the reduced model's own presses beside one trained on the FEM's
# (the same presses, each snapshot projected on the basis), both bases, the top presses.
for m in cat_top cat_top_r222; do
  [ -f $models/${m}_fem_trained.h5 ] || {
    args="--basis 82"
    [ $m = cat_top ] || args="--modes 100 --derivative-modes 60 --basis 222"
    $irdm precompute validation/scenes/reduced/cat_top.json --reduced $args --training-source fem \
      --out $models/${m}_fem_trained.h5 > "$out/precompute_${m}_fem_trained.txt"
  }
done
$irdm validate-nonlinear --families planes --model out/models/quick/cat_vdof.h5 --subdivisions 1 \
  --vertex-model out/models/quick/cat_vertex.h5 --press-directions top \
  --press-depths 0.0005 0.002 0.005 0.01 --impact-speeds none --converged-cases none --no-direct \
  --reduced-model $models/cat_top.h5 $models/cat_top_fem_trained.h5 $models/cat_top_r222.h5 \
  $models/cat_top_r222_fem_trained.h5 --out "$out/cubature"
