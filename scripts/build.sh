#!/usr/bin/env bash
# Configures and builds in build/ (Release; pass Debug as $1 for deal.II's internal checks).
set -euo pipefail
cd "$(dirname "$0")/.."
type=${1:-Release}
dir=build; [ "$type" = Debug ] && dir=build-debug
# A warning in our own code fails the build (IRDM_WERROR=OFF to let it pass). The main job and
# the tests configure build/ alike, so running one after the other rebuilds nothing.
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE="$type" -DIRDM_WERROR="${IRDM_WERROR:-ON}" >/dev/null
ninja -C "$dir" -j"$(nproc)"
