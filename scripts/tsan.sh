#!/usr/bin/env bash
# The two asynchronous loops (force thread, deformation thread; irdm/surface_exchange.h) under
# ThreadSanitizer: a runtime-only build (no deal.II, no MPI start-up) in build-tsan/ that runs
# tests/test_two_loops.cc. Any data race TSan reports fails the run.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=Release -DIRDM_RUNTIME_ONLY=ON \
  -DIRDM_TSAN=ON -DIRDM_WERROR=ON >/dev/null
ninja -C build-tsan -j"$(nproc)" two_loop_tests
TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1 build-tsan/tests/two_loop_tests
