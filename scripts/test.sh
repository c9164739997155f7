#!/usr/bin/env bash
# Builds placedb and runs its test suite. Installs missing Debian packages first (needs root).
# Usage: scripts/test.sh [extra cmake -D options...]   (PLACEDB_BUILD_DIR overrides ./build;
# PLACEDB_CTEST_ARGS adds ctest arguments, e.g. "-R storage")
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
build="${PLACEDB_BUILD_DIR:-build}"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$build" -j"$(nproc)"
# ctest's summary is the last thing printed: CI reads it.
read -ra ctest_args <<<"${PLACEDB_CTEST_ARGS:-}"
cd "$build" && ctest --output-on-failure -j"$(nproc)" --timeout 900 "${ctest_args[@]}"
