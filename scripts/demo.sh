#!/usr/bin/env bash
# Builds placedb and runs its built-in example: a synthetic tour with loops, mapped and scored.
# Installs missing Debian packages first (needs root). Output goes to ./demo-output.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
build="${PLACEDB_BUILD_DIR:-build}"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j"$(nproc)" --target placedb
"$build/tools/placedb" demo --out demo-output "$@"
