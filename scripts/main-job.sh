#!/usr/bin/env bash
# The main job from a clean checkout: install what is missing, build, and run the paper's two
# experiments with their figures (written to output/paper/ unless a directory is given).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
scripts/paper-figures.sh "${1:-output/paper}"
