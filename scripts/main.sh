#!/usr/bin/env bash
# The main job: install, build, run the default validation suite, write the report.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
build/apps/irdm verify-fem --meshes meshes --out reports/fem-verification
