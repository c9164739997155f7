#!/usr/bin/env bash
# The ctest fixture of the PostgreSQL tests: `setup STATE` starts a throwaway server
# (scripts/pg-server.sh, in a mktemp folder under /tmp) and writes its URI to the file STATE;
# `cleanup STATE` stops it and deletes its folder. Where the server binaries are not installed,
# STATE holds "skip: <why>" instead and the tests skip with that message; any other failure to
# start fails the setup, and ctest then does not run the tests that need it.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
script="$here/../../scripts/pg-server.sh"
action=${1:?usage: pg_fixture.sh setup|cleanup STATE}
state=${2:?usage: pg_fixture.sh setup|cleanup STATE}

case "$action" in
  setup)
    if ! ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 && [[ -z "${PG_BIN:-}" ]]; then
      echo "skip: PostgreSQL's server binaries are not installed (Debian package postgresql;" \
        "scripts/install-deps.sh installs it)" >"$state"
      exit 0
    fi
    if [[ -f "$state.dir" ]]; then  # a previous run that was not cleaned up
      bash "$script" stop "$(cat "$state.dir")" || true
      rm -rf "$(cat "$state.dir")"
    fi
    dir=$(mktemp -d /tmp/placedb-pg-test.XXXXXX)
    echo "$dir" >"$state.dir"
    bash "$script" start "$dir" >"$state"
    cat "$state"
    ;;
  cleanup)
    if [[ -f "$state.dir" ]]; then
      dir=$(cat "$state.dir")
      bash "$script" stop "$dir" immediate || true
      rm -rf "$dir" "$state.dir"
    fi
    rm -f "$state"
    ;;
  *)
    echo "usage: pg_fixture.sh setup|cleanup STATE" >&2
    exit 2
    ;;
esac
