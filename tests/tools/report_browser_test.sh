#!/usr/bin/env bash
# `placedb report` as a person sees it: a headless Chromium opens the page of a small synthetic
# run (200 frames: the first loops come after 150), every picture on it must decode (the page's
# own script writes "loaded/total" into <body data-images-loaded>), and a screenshot of it must
# be taken.
# Usage: report_browser_test.sh PLACEDB SCRATCH_DIR. Exit 77 (a skip for ctest) without Chromium.
set -euo pipefail

placedb=$1
scratch=$2

browser=""
for name in chromium chromium-browser google-chrome; do
  if command -v "$name" >/dev/null 2>&1; then browser=$name; break; fi
done
if [[ -z "$browser" ]]; then
  echo "SKIP: no chromium on PATH (scripts/install-deps.sh installs the Debian package)"
  exit 77
fi

rm -rf "$scratch"
mkdir -p "$scratch"
"$placedb" demo --out "$scratch/demo" --frames 200 >"$scratch/demo.txt" 2>&1
"$placedb" report "$scratch/demo/demo.placedb" "$scratch/demo/run.csv" \
  "$scratch/demo/sequence/gt_pairs.txt" --out "$scratch/report" --max-right 8
page="$scratch/report/index.html"

# Chromium refuses its sandbox as root; the profile goes to the scratch folder, not $HOME. The
# virtual time budget lets the load event (and the page's count) run before the dump.
run_browser() {
  timeout 120 "$browser" --headless --no-sandbox --disable-gpu --hide-scrollbars \
    --user-data-dir="$scratch/profile" --virtual-time-budget=10000 "$@" \
    "file://$page" 2>>"$scratch/browser.log"
}

run_browser --dump-dom >"$scratch/dom.html"
loaded=$(grep -o 'data-images-loaded="[0-9]*/[0-9]*"' "$scratch/dom.html" | head -1 |
  sed 's/.*="\(.*\)"/\1/')
if [[ -z "$loaded" ]]; then
  echo "FAIL: the page's image count never ran (no data-images-loaded in the DOM dump)"
  exit 1
fi
shown=${loaded%/*}
total=${loaded#*/}
echo "images loaded: $shown of $total"
if [[ "$total" -lt 8 || "$shown" != "$total" ]]; then
  echo "FAIL: expected every image (figures and thumbnails, at least 8) to load"
  exit 1
fi

run_browser --screenshot="$scratch/report.png" --window-size=1100,3000 >/dev/null
if [[ "$(head -c 8 "$scratch/report.png" | od -An -tx1 | tr -d ' \n')" != "89504e470d0a1a0a" ]]; then
  echo "FAIL: no PNG screenshot at $scratch/report.png"
  exit 1
fi
echo "screenshot: $scratch/report.png"
