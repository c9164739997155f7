#!/usr/bin/env bash
# lip6_outdoor mapped into a PostgreSQL map and into a SQLite file: the per-frame logs must be
# equal in every column but the times, straight and when stopped at frame 500 and resumed
# (issue #24's acceptance check, which ctest runs on 300 frames in tests/cli/pg_cli_test.cpp).
# Prints the mean, p50 and p99 frame time and storage time of both.
# Usage: bench/storage/pg_vs_file.sh [BUILD_DIR] [DATASETS_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
data=${2:-$root/../shared/datasets}/lip6_outdoor
placedb="$build/tools/placedb"
work=$(mktemp -d /tmp/placedb-pg-vs-file.XXXXXX)
server="$work/server"
trap 'bash "$root/scripts/pg-server.sh" stop "$server" immediate >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
sed "s|^|$data/|" "$data/frames.txt" >"$work/frames.txt"
base=$(bash "$root/scripts/pg-server.sh" start "$server")
for db in straight resumed; do psql "$base" -XAtqc "CREATE DATABASE $db"; done
straight=${base/\/placedb\?//straight?}
resumed=${base/\/placedb\?//resumed?}

"$placedb" map "$work/file.placedb" "$work/frames.txt" --log "$work/file.csv" -q
"$placedb" map "$straight" "$work/frames.txt" --log "$work/pg.csv" -q
"$placedb" map "$resumed" "$work/frames.txt" --log "$work/pg_resumed.csv" --stop-after 500 -q
"$placedb" map "$resumed" "$work/frames.txt" --log "$work/pg_resumed.csv" -q

python3 - "$work" <<'PY'
import csv, sys
work = sys.argv[1]
def rows(name):
    with open(f"{work}/{name}") as f:
        table = list(csv.reader(f))
    keep = [i for i, h in enumerate(table[0]) if not h.endswith("_ms")]
    return [[r[i] for i in keep] for r in table], list(csv.DictReader(open(f"{work}/{name}")))
expected, file_rows = rows("file.csv")
status = 0
for name in ("pg.csv", "pg_resumed.csv"):
    got, _ = rows(name)
    differ = [i for i in range(max(len(got), len(expected))) if got[i:i + 1] != expected[i:i + 1]]
    print(f"{name}: {len(got) - 1} frames, {len(differ)} rows differ from the file's log")
    status |= bool(differ)
for name in ("file.csv", "pg.csv"):
    _, r = rows(name)
    t = sorted(float(x["time_ms"]) for x in r)
    s = sum(float(x["storage_ms"]) for x in r) / len(r)
    print(f"{name}: frame ms mean {sum(t) / len(t):.2f} p50 {t[len(t) // 2]:.2f} "
          f"p99 {t[int(len(t) * 0.99)]:.2f}; storage ms mean {s:.2f}")
sys.exit(status)
PY
