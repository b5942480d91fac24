#!/usr/bin/env bash
# Builds the project with AddressSanitizer and UndefinedBehaviorSanitizer in build-sanitize/
# and runs the runtime's tests (tests/test_irdm.cc, test_compression.cc, test_planes.cc,
# test_free_body.cc: the runtime and its loaders) and the robustness tests (loaders against
# mutated files, writers against a full disk). The loader fuzz tests run IRDM_FUZZ_SECONDS
# (default 20) per loader.
# The FEM and validation libraries, which only make the tests' models, are linked from the
# Release build in build/ (IRDM_FEM_FROM) rather than compiled a second time with the
# sanitizers, and the two tests that call the irdm program run that build's program: the
# program's own code is tested by the main ctest run (tests/test_cli.cc), not under ASan.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh >/dev/null # nothing to do after scripts/test.sh's build
cmake -S . -B build-sanitize -G Ninja -DCMAKE_BUILD_TYPE=Release -DIRDM_SANITIZE=ON \
  -DIRDM_WERROR=ON -DIRDM_FEM_FROM="$PWD/build" >/dev/null
ninja -C build-sanitize -j"$(nproc)" robustness_tests two_loop_tests runtime_tests
# Leaks are checked in the deal.II-free tests only: MPI and PETSc keep allocations to exit.
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export IRDM_FUZZ_SECONDS=${IRDM_FUZZ_SECONDS:-20}
cd build-sanitize
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 ctest --output-on-failure -j2 -R '^(ModelLoader|CompressedLoader|VirtualDofLoader|MeshLoader|Writers|\*/EveryStorage)'
# alloc_dealloc_mismatch=0 for the deal.II-linked binaries only: FreeImage, which deal.II links,
# frees with free() at exit what it took with operator new(nothrow) (FreeImage_DeInitialise),
# in every such process, the irdm CLI included. Our own pairing is checked with the check on
# by the tests above.
# Not again here: the tests whose subject is the FEM's precompute (Precompute.*, FreeBody.*),
# which runs uninstrumented from build/; the main ctest run has them.
ASAN_OPTIONS=detect_leaks=0:alloc_dealloc_mismatch=0:abort_on_error=1 ctest --output-on-failure -j2 -E '^(ModelLoader|CompressedLoader|VirtualDofLoader|MeshLoader|Writers|\*/EveryStorage|Precompute\.|FreeBody\.)'
