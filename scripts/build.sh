#!/usr/bin/env bash
# Configure and build the Release preset (build/release). Usage: scripts/build.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)"
