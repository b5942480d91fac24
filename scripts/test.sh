#!/usr/bin/env bash
# Install, build (warnings are errors) and run all tests with ctest, then the robustness tests
# under the sanitizers.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
IRDM_WERROR=ON scripts/build.sh
(cd build && ctest --output-on-failure -j2)
# The loaders, writers and runtime again under AddressSanitizer and UBSan (build-sanitize/).
scripts/sanitize.sh
# The two asynchronous loops under ThreadSanitizer (build-tsan/).
scripts/tsan.sh
