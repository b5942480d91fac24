#!/usr/bin/env bash
# Install, build (warnings are errors) and run all tests with ctest, then the robustness tests
# under the sanitizers. Disk: the script prints what its three builds take; each test removes
# its scratch folder when it passes (tests/scratch.h), so the tests add only what two of them
# write at once.
set -euo pipefail
cd "$(dirname "$0")/.."
echo "test.sh: $(df -h --output=avail . | tail -1 | tr -d ' ') free on this disk at the start"
scripts/install-deps.sh --tests
scripts/build.sh # warnings are errors, as in the main job's build
# The loaders' random mutations run briefly here and at length under the sanitizers below,
# where a bad read shows.
(cd build && IRDM_FUZZ_SECONDS=${IRDM_FUZZ_SECONDS:-3} ctest --output-on-failure -j2)
# The loaders, writers and runtime again under AddressSanitizer and UBSan (build-sanitize/).
scripts/sanitize.sh
# The two asynchronous loops under ThreadSanitizer (build-tsan/).
scripts/tsan.sh
echo "test.sh: $(df -h --output=avail . | tail -1 | tr -d ' ') free at the end; builds: $(du -shc build build-sanitize build-tsan | tail -1 | cut -f1)"
