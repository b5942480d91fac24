#!/usr/bin/env bash
# Builds the deal.II-free libraries (common, mesh reader, IRDM runtime) and their robustness
# tests with AddressSanitizer and UndefinedBehaviorSanitizer in build-sanitize/, and runs them.
# The loader fuzz tests run IRDM_FUZZ_SECONDS (default 20) per loader under the sanitizers.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-sanitize -G Ninja -DCMAKE_BUILD_TYPE=Debug -DIRDM_RUNTIME_ONLY=ON \
  -DIRDM_SANITIZE=ON -DIRDM_WERROR=ON >/dev/null
ninja -C build-sanitize -j"$(nproc)"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export IRDM_FUZZ_SECONDS=${IRDM_FUZZ_SECONDS:-20}
cd build-sanitize && ctest --output-on-failure -j2
