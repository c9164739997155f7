#!/usr/bin/env bash
# Where a robot's frames spend the server's CPU: robot A (lip6_outdoor frames 0-539) mapped into a
# file and copied to a scratch server with pg_stat_statements, then robot B (frames 540 to END-1)
# mapped on it alone. Prints the server's CPU per frame (its processes, from /proc, as run.py),
# and the statements by execution time per frame (nested ones too: a foreign key's lookup shows
# as `SELECT 1 FROM ONLY ... FOR KEY SHARE`).
# Usage: bench/fleet/statements.sh [BUILD_DIR] [END (default 1063)] [DATASETS_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
end=${2:-1063}
data=${3:-$root/../shared/datasets}/lip6_outdoor
placedb="$build/tools/placedb"
work=$(mktemp -d /tmp/placedb-statements.XXXXXX)
chmod 755 "$work"
server="$work/server"
trap 'bash "$root/scripts/pg-server.sh" stop "$server" immediate >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
sed -n "1,540p" "$data/frames.txt" | sed "s|^|$data/|" >"$work/A.txt"
sed -n "541,${end}p" "$data/frames.txt" | sed "s|^|$data/|" >"$work/B.txt"
"$placedb" map "$work/a.placedb" "$work/A.txt" -q
base=$(bash "$root/scripts/pg-server.sh" start "$server")
# The extension is loaded at the server's start: a restart with it (pg_ctl keeps the options).
owner() { if [[ $(id -u) -eq 0 ]]; then runuser -u postgres -- "$@"; else "$@"; fi; }
printf "shared_preload_libraries = 'pg_stat_statements'\npg_stat_statements.track = all\n" |
  owner tee -a "$server/data/postgresql.conf" >/dev/null
bin=${PG_BIN:-$(ls -d /usr/lib/postgresql/*/bin | sort -V -r | head -1)}
owner "$bin/pg_ctl" -D "$server/data" -l "$server/server.log" -w restart >/dev/null
psql "$base" -XAtqc "CREATE DATABASE m"
map=${base/\/placedb\?//m?}
"$placedb" copy "$work/a.placedb" "$map" >/dev/null
psql "$map" -XAtqc "CREATE EXTENSION pg_stat_statements; SELECT pg_stat_statements_reset()" >/dev/null
cpu() { python3 -c "import sys; sys.path.insert(0, '$root/bench/fleet'); import scenario; print(scenario.server_cpu_seconds('$server'))"; }
before=$(cpu)
"$placedb" map "$map" "$work/B.txt" --log "$work/B.csv" -q
after=$(cpu)
frames=$(($(wc -l <"$work/B.csv") - 1))
python3 -c "print(f'{$frames} frames of robot B: server CPU {1000 * ($after - $before) / $frames:.2f} ms a frame')"
echo "ms a frame | calls | rows | statement"
psql "$map" -XAtF ' | ' -c "SELECT round((total_exec_time / $frames)::numeric, 3), calls, rows,
  left(regexp_replace(query, '\s+', ' ', 'g'), 110) FROM pg_stat_statements
  ORDER BY total_exec_time DESC LIMIT ${TOP:-20}"
