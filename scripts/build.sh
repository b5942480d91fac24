#!/usr/bin/env bash
# Configures and builds in build/ (Release; pass Debug as $1 for deal.II's internal checks).
set -euo pipefail
cd "$(dirname "$0")/.."
type=${1:-Release}
dir=build; [ "$type" = Debug ] && dir=build-debug
# IRDM_WERROR=ON (set by scripts/test.sh, so CI): a warning in our own code fails the build.
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE="$type" -DIRDM_WERROR="${IRDM_WERROR:-OFF}" >/dev/null
ninja -C "$dir" -j"$(nproc)"
