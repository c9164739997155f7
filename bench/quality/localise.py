#!/usr/bin/env python3
"""Localisation against a map whose working memory is bounded: every tier must answer.

Maps lip6_outdoor's even frames (frames_half.txt) with the given settings, then queries every odd
frame with `placedb query MAP ... --top 1 --json`. A query is right when its best match covers a
frame within 2 frames of the query, or of a frame the ground truth (gt_pairs.txt) pairs it with.
Images of another data set (rtabmap_samples) show places the map never saw: they should be
answered "unknown".

    bench/quality/localise.py --placedb build/tools/placedb [--set wm_max=150] [--out DIR]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path


def read_list(path):
    return [l.strip() for l in open(path) if l.strip() and not l.startswith("#")]


def query(placedb, map_path, images):
    out = []
    for start in range(0, len(images), 100):  # keeps the command line short
        run = subprocess.run([placedb, "query", map_path, *images[start:start + 100], "--top", "1",
                              "--json"], capture_output=True, text=True)
        if run.returncode not in (0, 3):
            sys.exit(f"query failed ({run.returncode}): {run.stderr.strip()}")
        out += json.loads(run.stdout)
    return out


def main():
    here = Path(__file__).resolve().parent
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--placedb", default=str(here.parents[1] / "build/tools/placedb"))
    parser.add_argument("--datasets", default=str(here.parents[2] / "shared/datasets"))
    parser.add_argument("--out", default="/tmp/placedb-localise")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--misses", action="store_true", help="print every wrong answer")
    parser.add_argument("--map", help="query this map instead of mapping anew")
    args = parser.parse_args()

    lip6 = Path(args.datasets) / "lip6_outdoor"
    frames = read_list(lip6 / "frames.txt")
    truth = {}
    for line in read_list(lip6 / "gt_pairs.txt"):
        q, r = map(int, line.split())
        truth.setdefault(q, set()).add(r)  # either way: the same place
        truth.setdefault(r, set()).add(q)
    os.makedirs(args.out, exist_ok=True)
    map_path = args.map or os.path.join(args.out, "half.placedb")
    if not args.map:
        for suffix in ("", "-wal", "-shm"):
            if os.path.exists(map_path + suffix):
                os.remove(map_path + suffix)
        settings = [x for s in args.set for x in ("--set", s)]
        subprocess.run([args.placedb, "map", map_path, str(lip6 / "frames_half.txt"), "-q",
                        *settings], check=True)
    info = json.loads(subprocess.run([args.placedb, "info", map_path, "--json"], check=True,
                                     capture_output=True, text=True).stdout)

    odd = list(range(1, len(frames), 2))
    answers = query(args.placedb, map_path, [str(lip6 / frames[i]) for i in odd])
    right = known = 0
    times, searched, checked = [], [], []
    for q, answer in zip(odd, answers):
        times.append(answer.get("time_ms", 0.0))
        searched.append(answer.get("searched", 0))
        checked.append(answer.get("checked", 0))
        known += answer.get("verdict") == "known"
        if not answer.get("matches"):
            continue
        covered = [2 * f["source_index"] for f in answer["matches"][0]["frames"]]
        targets = {q} | truth.get(q, set())
        hit = any(abs(c - t) <= 2 for c in covered for t in targets)
        right += hit
        if not hit and args.misses:
            m = answer["matches"][0]
            print(f"miss: frame {q} -> frames {covered} ({m['tier']}, {m['inliers']} inliers, "
                  f"code {m['code_similarity']:.3f}), truth {sorted(targets)[:6]}")

    samples = Path(args.datasets) / "rtabmap_samples"
    foreign = query(args.placedb, map_path,
                    [str(samples / f) for f in read_list(samples / "frames.txt")])
    unknown = sum(a.get("verdict") == "unknown" for a in foreign)

    print(f"map: {args.set or 'defaults'}; locations per tier {json.dumps(info.get('locations_per_tier'))}")
    print(f"odd frames queried: {len(odd)}; top-1 right: {right} ({100.0 * right / len(odd):.1f} %); "
          f"verdict known: {known}")
    print(f"query time p50 {statistics.median(times):.1f} ms, max {max(times):.1f} ms; "
          f"locations searched p50 {statistics.median(searched):.0f}, checked p50 "
          f"{statistics.median(checked):.0f}")
    print(f"rtabmap_samples images (never seen): {unknown} of {len(foreign)} answered unknown")


if __name__ == "__main__":
    main()
