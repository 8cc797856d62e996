#!/usr/bin/env bash
# Fails when a tracked C++ file differs from what clang-format (the committed .clang-format) makes
# of it, listing those files. Usage: scripts/check-format.sh
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t files < <(git ls-files '*.cpp' '*.hpp' '*.hpp.in')
unformatted=()
for file in "${files[@]}"; do
  clang-format --dry-run --Werror "$file" >/dev/null 2>&1 || unformatted+=("$file")
done
if ((${#unformatted[@]} > 0)); then
  echo "check-format: not formatted with clang-format: ${unformatted[*]} (run clang-format -i)" >&2
  exit 1
fi
echo "check-format: ${#files[@]} files formatted"
