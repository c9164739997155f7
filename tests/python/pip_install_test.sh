#!/usr/bin/env bash
# `python3 -m pip install ./python` as docs/python.md gives it, on a fresh copy of the sources
# (the files git tracks, or would: a clone's), in a fresh venv that sees the system's packages
# (numpy), with no package index (PIP_NO_INDEX: a download would fail, not hang); then
# `import placedb` from another folder finds the installed module. It builds the module from
# scratch: several minutes on 2 cores.
# usage: pip_install_test.sh SOURCE_DIR WORK_DIR PYTHON
set -euo pipefail
source_dir=$1 work=$2 python=$3

if ! "$python" -c "import venv, ensurepip" 2>/dev/null; then
  echo "skipped: $python has no venv/ensurepip (Debian's python3-venv)"
  exit 77
fi
if ! git -C "$source_dir" rev-parse --git-dir >/dev/null 2>&1; then
  echo "skipped: $source_dir is not a git checkout (the test copies the files git lists)"
  exit 77
fi
rm -rf "$work"
mkdir -p "$work/clone" "$work/elsewhere"
(cd "$source_dir" && git ls-files -co --exclude-standard -z) |
  (cd "$source_dir" && xargs -0 cp --parents -t "$work/clone")

"$python" -m venv --system-site-packages "$work/venv"
started=$SECONDS
PIP_NO_INDEX=1 "$work/venv/bin/python3" -m pip install --quiet "$work/clone/python" \
  --config-settings jobs=2
echo "pip install ./python: $((SECONDS - started)) s"

cd "$work/elsewhere"
"$work/venv/bin/python3" - "$work/venv" <<'PY'
import sys
import placedb

venv = sys.argv[1]
assert placedb.__file__.startswith(venv), placedb.__file__
keys = {s["key"] for s in placedb.settings()}
assert "t_loop" in keys, sorted(keys)[:5]
print("import placedb:", placedb.__file__)
PY
"$work/venv/bin/python3" -m pip show placedb
