#!/usr/bin/env bash
# The main job from a clean checkout: install what is missing, build, and run the powder-bed
# packing case (20 000 particles poured into a box) on every core. Results go to
# output/powder_bed_packing/ unless a directory is given.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
build/release/bondem run cases/powder_bed_packing.yaml ${1:+--output "$1"}
