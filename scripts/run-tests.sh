#!/usr/bin/env bash
# The whole test suite from a clean checkout: install what is missing, check the formatting,
# build, run ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/check-format.sh
scripts/build.sh
ctest --preset release -j "$(nproc)"
# The unit tests once more under the address and undefined-behaviour sanitizers.
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$(nproc)" --target bondem_unit_tests
ctest --preset asan -L unit -j "$(nproc)"
