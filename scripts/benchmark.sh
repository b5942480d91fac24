#!/usr/bin/env bash
# Runtime kernel benchmarks: a model like the full cat's (T = 500, float) restricted to the
# press scene's inputs, then Google Benchmark with ratios to the direct convolution.
# Usage: scripts/benchmark.sh [report file]   (default reports/benchmarks.md)
set -euo pipefail
cd "$(dirname "$0")/.."
report=${1:-reports/benchmarks.md}
mkdir -p out/models "$(dirname "$report")"
build/apps/irdm precompute validation/scenes/press.json --out out/models/bench.h5 \
  --length 500 --storage float --restart --quiet
build/benchmarks/irdm_kernels out/models/bench.h5 "$report" --benchmark_min_time=0.2 --benchmark_color=false
rm -f out/models/bench.h5
