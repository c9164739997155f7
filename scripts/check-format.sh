#!/usr/bin/env bash
# Fails when a tracked C++ file differs from what clang-format (.clang-format) makes of it, and
# names each such file. Nothing is rewritten: `clang-format -i FILE` fixes one.
# Usage: scripts/check-format.sh [clang-format binary]   (CLANG_FORMAT overrides it too)
set -euo pipefail
cd "$(dirname "$0")/.."
clang_format="${1:-${CLANG_FORMAT:-clang-format}}"
mapfile -t files < <(git ls-files -- '*.cpp' '*.cc' '*.h' '*.hpp')
drifting=()
for file in "${files[@]}"; do
  if ! "$clang_format" --dry-run -Werror "$file" >/dev/null 2>&1; then drifting+=("$file"); fi
done
if ((${#drifting[@]})); then
  printf 'clang-format: %d of %d C++ files differ from .clang-format:\n' "${#drifting[@]}" \
    "${#files[@]}"
  printf '  %s\n' "${drifting[@]}"
  exit 1
fi
printf 'clang-format: all %d C++ files conform\n' "${#files[@]}"
