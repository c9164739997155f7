#!/usr/bin/env bash
# Starts or stops a throwaway PostgreSQL server for placedb maps, all inside one folder.
#
#   scripts/pg-server.sh start DIR [DB]  # initdb into DIR/data, start it (unless it runs), create
#                                    # database DB (default placedb) and print the map URI:
#                                    # postgresql:///DB?host=DIR&user=postgres
#   scripts/pg-server.sh createdb DIR DB # a new, empty database DB on the server: print its URI
#                                    # (exit 1 when DB exists: a map is copied into a new one)
#   scripts/pg-server.sh stop DIR    # stop it (DIR stays; delete it to drop every map)
#   scripts/pg-server.sh stop DIR immediate   # without a shutdown checkpoint, for a DIR about
#                                    # to be deleted (a restart would recover it like a crash)
#   scripts/pg-server.sh uri DIR     # print the URI again
#   scripts/pg-server.sh standby PRIMARY_DIR DIR [DB]   # a hot standby of the server in
#                                    # PRIMARY_DIR: streaming replication from a pg_basebackup -R
#                                    # copy, in DIR, read-only; prints the URI of its database DB
#                                    # (default placedb; stop it with stop DIR)
#
# The server listens on a Unix socket inside DIR only (listen_addresses=''), so it never clashes
# with another server's TCP port. Its owner, postgres, connects without a password; any other
# role needs its password (a scratch server for trying a fleet map and for the tests, not a
# production setup: see schema/SCHEMA.md for roles).
# PostgreSQL refuses to run as root: run as root, the script runs the server as the `postgres`
# user of Debian's postgresql package (runuser) and gives it DIR. Without DIR, `start` makes one
# with mktemp under /tmp. Needs Debian's postgresql package (scripts/install-deps.sh).
set -euo pipefail

usage() {
  echo "usage: $0 start [DIR [DB]] | createdb DIR DB | stop DIR | uri DIR |" \
    "standby PRIMARY_DIR DIR [DB]" >&2
  exit 2
}

uri_of() {
  echo "postgresql:///$2?host=$(cd "$1" && pwd)&user=postgres"
}

# Debian keeps the server's programs in /usr/lib/postgresql/VERSION/bin, off PATH; PG_BIN
# overrides.
find_bin() {
  local dir
  for dir in ${PG_BIN:-} $(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V -r); do
    if [[ -x "$dir/pg_ctl" && -x "$dir/initdb" && -x "$dir/createdb" ]]; then
      echo "$dir"
      return
    fi
  done
  echo "pg-server: PostgreSQL's server binaries (initdb, pg_ctl) are not installed;" \
    "install Debian's postgresql package (scripts/install-deps.sh)" >&2
  exit 3
}

# Runs a command as the user that owns the server: postgres when we are root.
as_owner() {
  if [[ $(id -u) -eq 0 ]]; then
    runuser -u postgres -- "$@"
  else
    "$@"
  fi
}

# Makes DIR (absolute from here on) the server's: as root, postgres's, and reachable by it.
own_dir() {
  mkdir -p "$dir"
  dir=$(cd "$dir" && pwd)
  if [[ $(id -u) -eq 0 ]]; then
    if ! id postgres >/dev/null 2>&1; then
      echo "pg-server: running as root needs the postgres user (Debian's postgresql package)" >&2
      exit 3
    fi
    chown postgres: "$dir"
    chmod 0755 "$dir"
    # The server's user must reach DIR through every folder above it.
    parent=$(dirname "$dir")
    while [[ "$parent" != "/" ]]; do
      chmod o+x "$parent" 2>/dev/null || true
      parent=$(dirname "$parent")
    done
  fi
}

# Starts the server of DIR/data, listening on a socket in DIR only.
run_server() {
  as_owner "$bin/pg_ctl" -D "$dir/data" -l "$dir/server.log" -w -t 60 \
    -o "-c listen_addresses='' -c unix_socket_directories='$dir'" start \
    >/dev/null || {
    echo "pg-server: the server did not start; see $dir/server.log" >&2
    exit 1
  }
}

[[ $# -ge 1 ]] || usage
command=$1
dir=${2:-}

case "$command" in
  start)
    bin=$(find_bin)
    if [[ -z "$dir" ]]; then dir=$(mktemp -d /tmp/placedb-pg.XXXXXX); fi
    own_dir
    if [[ ! -f "$dir/data/PG_VERSION" ]]; then
      as_owner "$bin/initdb" -D "$dir/data" -A trust -E UTF8 --locale=C.UTF-8 >"$dir/initdb.log" 2>&1 ||
        {
          echo "pg-server: initdb failed; see $dir/initdb.log" >&2
          exit 1
        }
      # The socket only: the server's owner without a password (also for a standby's
      # replication connection), every other role (a robot's, made with CREATE ROLE ...
      # PASSWORD) with its password.
      printf '%s\n' "local all postgres trust" "local replication postgres trust" \
        "local all all scram-sha-256" | as_owner tee "$dir/data/pg_hba.conf" >/dev/null
    fi
    # A server already running in DIR is used as it is: start may be run again.
    if ! as_owner "$bin/pg_ctl" -D "$dir/data" status >/dev/null 2>&1; then
      run_server
    fi
    db=${3:-placedb}
    # createdb fails when the database exists (a restart): that is fine.
    as_owner "$bin/createdb" -h "$dir" "$db" 2>/dev/null || true
    # Any local user may connect as postgres (trust on the socket, which only this machine sees).
    uri_of "$dir" "$db"
    ;;
  createdb)
    [[ -n "$dir" && -n "${3:-}" ]] || usage
    bin=$(find_bin)
    as_owner "$bin/createdb" -h "$(cd "$dir" && pwd)" "$3" >&2 || {
      echo "pg-server: could not create database $3 on the server in $dir (it exists, or the" \
        "server is not running: start it first)" >&2
      exit 1
    }
    uri_of "$dir" "$3"
    ;;
  standby)
    # A hot standby: a base backup of the primary's running server with -R (standby.signal and
    # primary_conninfo), which then streams the primary's WAL and serves reads only.
    [[ $# -eq 3 || $# -eq 4 ]] || usage
    bin=$(find_bin)
    primary=$(cd "$2" && pwd)
    dir=$3
    if [[ ! -S "$primary/.s.PGSQL.5432" ]]; then
      echo "pg-server: no server runs in $primary (start it first: $0 start $primary)" >&2
      exit 3
    fi
    # A primary made before standbys were offered lacks the replication line: add it.
    if ! grep -q "^local replication postgres trust" "$primary/data/pg_hba.conf"; then
      sed -i '1i local replication postgres trust' "$primary/data/pg_hba.conf"
      as_owner "$bin/pg_ctl" -D "$primary/data" reload >/dev/null
    fi
    own_dir
    if [[ ! -f "$dir/data/PG_VERSION" ]]; then
      as_owner "$bin/pg_basebackup" -h "$primary" -U postgres -D "$dir/data" -R -X stream -c fast \
        >"$dir/basebackup.log" 2>&1 || {
        echo "pg-server: pg_basebackup from $primary failed; see $dir/basebackup.log" >&2
        exit 1
      }
    fi
    run_server
    uri_of "$dir" "${4:-placedb}"
    ;;
  stop)
    [[ -n "$dir" ]] || usage
    bin=$(find_bin)
    if [[ -f "$dir/data/postmaster.pid" ]]; then
      as_owner "$bin/pg_ctl" -D "$dir/data" -m "${3:-fast}" -w stop >/dev/null
    fi
    ;;
  uri)
    [[ -n "$dir" ]] || usage
    uri_of "$dir" placedb
    ;;
  *)
    usage
    ;;
esac
