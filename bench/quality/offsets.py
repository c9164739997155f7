#!/usr/bin/env python3
"""How far accepted loop closures land from the right frame, on a synthetic walk written by
placedb_walk_sequence (gt_nearest.txt: the best-overlapping frame of each earlier pass;
poses.txt: headings, to tell ahead from behind).

Usage: bench/quality/offsets.py LOG.csv SEQUENCE_DIR [--scorer PATH]
Prints, for the accepted closures, the signed offset of the covered frame nearest the right
frame (negative: behind the camera, along the earlier pass as the camera drives it), and
R@100P and accepted true/false at windows 0, 2 and 5 against gt_nearest.txt.
"""
import argparse
import collections
import csv
import json
import math
import os
import subprocess
import sys


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('log')
    p.add_argument('sequence')
    p.add_argument('--scorer', default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                     '..', '..', '..', 'shared', 'tools',
                                                     'score_loops.py'))
    a = p.parse_args()
    nearest = collections.defaultdict(list)
    with open(os.path.join(a.sequence, 'gt_nearest.txt')) as f:
        for line in f:
            if line.strip() and not line.startswith('#'):
                q, r = map(int, line.split())
                nearest[q].append(r)
    heading = {}
    with open(os.path.join(a.sequence, 'poses.txt')) as f:
        for line in f:
            frame, _, _, h = line.split()
            heading[int(frame)] = float(h)
    offsets, unrelated = collections.Counter(), 0
    with open(a.log) as f:
        for row in csv.DictReader(f):
            if row['accepted'] != '1':
                continue
            q = int(row['frame'])
            covered = [int(c) for c in row['candidate_frames'].split()]
            if not nearest[q]:
                unrelated += 1
                continue
            c, r = min(((c, r) for r in nearest[q] for c in covered),
                       key=lambda cr: abs(cr[0] - cr[1]))
            turn = abs((heading[q] - heading[r] + math.pi) % (2 * math.pi) - math.pi)
            offsets[(c - r) if turn < math.pi / 2 else (r - c)] += 1
    print('offset (frames, negative = behind): ' +
          ' '.join(f'{k:+d}:{offsets[k]}' for k in sorted(offsets)) +
          f'; accepted where no earlier pass is in view: {unrelated}')
    gt = os.path.join(a.sequence, 'gt_nearest.txt')
    for window in (0, 2, 5):
        out = subprocess.run([sys.executable, a.scorer, a.log, gt, '--window', str(window),
                              '--json'], check=True, capture_output=True, text=True).stdout
        s = json.loads(out)
        print(f"window {window}: R@100P {s['recall_at_100_precision']:.2f}, accepted "
              f"{s['accepted_true']}/{s['accepted_false']}")
    return 0


if __name__ == '__main__':
    sys.exit(main())
