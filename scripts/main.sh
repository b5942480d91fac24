#!/usr/bin/env bash
# The main job: install, build, run the validation suites, write the reports.
#
#   scripts/main.sh          every report section, on restricted models (below), and the
#                            index of every report (reports/README.md); reports in
#                            reports/quick/ (its time and memory: README.md)
#   scripts/main.sh --full   the full study (the full cat model with the seed's Table 1 on all
#                            1554 surface DoFs as inputs, the finest verification meshes, the
#                            162-orientation virtual-DOF model, and the probe scenes on
#                            the converged cat, scripts/converged.sh); reports in reports/
#
# What the default job restricts, and what that changes:
# - each scene's model is as long as its scene (validate --length 1: T = the scene's steps,
#   300 to 750, instead of 1000), so no run is truncated and exactness is unchanged; the
#   truncation table stops at the scene's length, and compressed sizes are relative to the
#   shorter model (the errors are the same);
# - the full model's inputs are sampled (every 16th surface vertex plus the touched region):
#   compression is per input, so Table 1's ratios are the full model's to 0.6 % points
#   (11.3 / 15.2 / 21.8 / 35.1 % against 10.9 / 14.7 / 21.2 / 34.6 %); its sizes and times
#   are the sample's;
# - verify-fem --quick: the coarser beam and ball meshes, fewer impact speeds (the report
#   says which; every check is still made);
# - virtual DOFs on the 42-orientation dome (S = 1): the side, top and impact cases are the
#   same orientations and give the same figures; the oblique and between cases are defined
#   by the dome's triangles, so they are other directions and give other figures;
# - validate-planes --quick: 15 of the 22 cases, every kind and the sweep's cases (no 20 mm
#   press, one two-wall and one sliding depth, no 0.2 m/s impact);
# - validate-nonlinear: the grounded family alone, 5 of its 23 cases, against the P1 truth
#   (the full map of both families takes hours; reports/nonlinear holds one).
# The scene sections (exactness, truncation, time step, compression) run on every scene.
set -euo pipefail
cd "$(dirname "$0")/.."
full=0
case "${1:-}" in
  --full) full=1 ;;
  "") ;;
  -h|--help) awk 'NR > 1 && /^set -e/ {exit} NR > 1' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  *) echo "main.sh: unknown option '$1' (use --full or nothing; --help)" >&2; exit 2 ;;
esac
if [ "$full" -eq 1 ]; then
  out=reports models=out/models subdivisions=2
  validate_opts=() verify_opts=() planes_opts=()
else
  out=reports/quick models=out/models/quick subdivisions=1
  validate_opts=(--full-model-stride 16 --length 1) verify_opts=(--quick) planes_opts=(--quick)
fi
scripts/install-deps.sh
scripts/build.sh
mkdir -p "$out" "$models"
start=$SECONDS
# Each stage's wall time, so that the budget above can be checked and trimmed.
stage_start=$SECONDS
stage_done() { echo "main.sh: $1 took $(( SECONDS - stage_start )) s"; stage_start=$SECONDS; }
build/apps/irdm validate --scenes validation/scenes --out "$out" --models "$models" "${validate_opts[@]}"
stage_done "validate"
scripts/benchmark.sh "$out/benchmarks.md"
stage_done "benchmarks"
# A failed check is a finding, written in the report (exit code 3); the job goes on.
rc=0
build/apps/irdm verify-fem --meshes meshes --out "$out/fem-verification" "${verify_opts[@]}" || rc=$?
if [ "$rc" -eq 3 ]; then
  echo "verify-fem: some checks failed, see $out/fem-verification/report.md"
elif [ "$rc" -ne 0 ]; then
  exit "$rc"
fi
stage_done "verify-fem"
# Virtual DOFs: the model in parallel over orientations, then the plane scenes against the
# nonlinear FEM, by virtual DOFs and by many-vertex contact (validate-planes reuses the models
# made from the same scene and spec; the every-surface-vertex model is 2.9 GB of float H).
mpirun --allow-run-as-root --oversubscribe -np 2 build/apps/irdm precompute-vdof \
  validation/scenes/press.json --out "$models/cat_vdof.h5" --length 300 --storage float \
  --subdivisions "$subdivisions"
stage_done "precompute-vdof"
build/apps/irdm validate-planes --model "$models/cat_vdof.h5" --length 300 \
  --vertex-model "$models/cat_vertex.h5" --subdivisions "$subdivisions" --out "$out" "${planes_opts[@]}"
stage_done "validate-planes"
# Where each method holds, against the size of the load (reports/nonlinear). The quick job:
# the grounded cat's top and side presses at 2 and 10 mm and one side impact, against the P1
# truth, on the plane stage's models. The full study: every sweep of both families (hours), the
# P2 truth on every top and side press.
if [ "$full" -eq 1 ]; then
  converged=()
  for side in top side; do for d in 0.5 1 2 5 10 20; do converged+=("press_${side}_${d}mm"); done; done
  build/apps/irdm validate-nonlinear --model "$models/cat_vdof.h5" --vertex-model "$models/cat_vertex.h5" \
    --subdivisions "$subdivisions" --converged-cases "${converged[@]}" --out "$out"
else
  build/apps/irdm validate-nonlinear --families planes --model "$models/cat_vdof.h5" \
    --vertex-model "$models/cat_vertex.h5" --subdivisions "$subdivisions" --press-directions top side \
    --press-depths 0.002 0.01 --impact-speeds 0.1 --converged-cases none --out "$out"
fi
stage_done "validate-nonlinear"
# The plane contact step at 25 to 200 candidates (Google Benchmark; 2 to 3 minutes, full study
# only: scripts/benchmark.sh REPORT VERTEX_MODEL runs it on the quick model).
if [ "$full" -eq 1 ]; then
  build/benchmarks/irdm_plane_kernels "$models/cat_vertex.h5" "$out/planes/kernels.md" \
    --benchmark_min_time=0.2 --benchmark_color=false
  stage_done "plane kernels"
  # The probe scenes on the converged cat (81351 free DoFs; reports/converged/, full study
  # only: its models take minutes each).
  scripts/converged.sh build
  stage_done "converged"
fi
# Every study in one line, with its date and commit, stale ones flagged (reports/README.md).
/usr/bin/python3 validation/reports_index.py reports
echo "reports ($(( (SECONDS - start) / 60 )) min): $out/validation.md, $out/<scene>/report.md, $out/benchmarks.md, $out/fem-verification/report.md, $out/planes/planes.md, $out/nonlinear/nonlinear.md; the index: reports/README.md"
