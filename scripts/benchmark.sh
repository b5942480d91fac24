#!/usr/bin/env bash
# Runtime kernel benchmarks: a model like the full cat's (T = 500, float) restricted to the
# press scene's inputs, then Google Benchmark with ratios to the direct convolution. With a
# vertex-contact model (every free surface vertex in and out; irdm validate-planes makes it as
# --vertex-model), also the many-vertex plane contact step at 25 to 200 candidates.
# Usage: scripts/benchmark.sh [report file] [vertex model]
#   report file   default reports/benchmarks.md
#   vertex model  e.g. out/models/cat_vertex.h5; writes <report dir>/planes/kernels.md
set -euo pipefail
cd "$(dirname "$0")/.."
report=${1:-reports/benchmarks.md}
vertex_model=${2:-}
mkdir -p out/models "$(dirname "$report")"
build/apps/irdm precompute validation/scenes/press.json --out out/models/bench.h5 \
  --length 500 --storage float --restart --quiet
build/benchmarks/irdm_kernels out/models/bench.h5 "$report" --benchmark_min_time=0.2 --benchmark_color=false
rm -f out/models/bench.h5
if [ -n "$vertex_model" ]; then
  mkdir -p "$(dirname "$report")/planes"
  build/benchmarks/irdm_plane_kernels "$vertex_model" "$(dirname "$report")/planes/kernels.md" \
    --benchmark_min_time=0.2 --benchmark_color=false
fi
