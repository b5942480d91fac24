#!/usr/bin/env bash
# Configures and builds in build/ (Release; pass Debug as $1 for deal.II's internal checks).
set -euo pipefail
cd "$(dirname "$0")/.."
type=${1:-Release}
dir=build; [ "$type" = Debug ] && dir=build-debug
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE="$type" >/dev/null
ninja -C "$dir" -j"$(nproc)"
