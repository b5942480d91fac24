#!/usr/bin/env bash
# The main job: install, build, run the default validation suites, write the reports.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
build/apps/irdm validate --scenes validation/scenes --out reports --models out/models
scripts/benchmark.sh
build/apps/irdm verify-fem --meshes meshes --out reports/fem-verification
echo "reports: reports/validation.md, reports/<scene>/report.md, reports/benchmarks.md, reports/fem-verification/report.md"
