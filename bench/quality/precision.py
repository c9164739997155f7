#!/usr/bin/env python3
"""Precision first: every dev set in full and cut before its first revisit, and synthetic walks
that never revisit a place but hold look-alikes (one poster at two places, doors and lockers along
a corridor; tools/synthetic), each with the defaults and with working memory capped. On the cuts and the walks
every accepted closure is false; the table lists them. The full runs are scored by the reference
scorer at window 10 (R@100P, accepted true/false).

Usage: bench/quality/precision.py [--build DIR] [--datasets DIR] [--scorer PATH] [--out DIR]
                                  [--caps 0,300] [--jobs N] [--set key=value]...
Needs placedb_quality_run and placedb_walk_sequence built in DIR (default build/). Settings given
with --set apply to every run; the same defaults hold on every set.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))

# name: (folder, frame list, ground truth)
SETS = {
    'lip6': ('lip6_outdoor', 'frames.txt', 'gt_pairs.txt'),
    'lip6_half': ('lip6_outdoor', 'frames_half.txt', 'gt_pairs_half.txt'),
    'lip6_160': ('lip6_outdoor_160x128', 'frames.txt', 'gt_pairs.txt'),
    'lip6_120': ('lip6_outdoor_120x96', 'frames.txt', 'gt_pairs.txt'),
    'samples': ('rtabmap_samples', 'frames.txt', 'gt_pairs.txt'),
}

# name: placedb_walk_sequence arguments. Walks that never come back: 200 frames past one poster
# at two places 48 frames apart (on the pavement of the ground world, on a facade of the street),
# and along a corridor whose doors and lockers repeat every 6 m; a small camera (160x120, a
# 95-degree lens in the canyon scenes) and a large one (960x540).
GROUND = ['--frames', '200', '--speed', '0.5', '--camera-height', '1.5', '--profile',
          'single_pass', '--lookalike', 'poster']
CANYON = ['--frames', '200']
SMALL = ['--width', '160', '--height', '120']
WALKS = {
    'poster_ground_960x540': GROUND + ['--width', '960', '--height', '540', '--pitch', '30'],
    'poster_ground_160x120': GROUND + SMALL + ['--pitch', '40'],
    'poster_street_960x540': CANYON + ['--scene', 'street', '--lookalike', 'poster'],
    'poster_street_160x120': CANYON + SMALL + ['--hfov', '95', '--scene', 'street', '--lookalike',
                                               'poster'],
    'corridor_960x540': CANYON + ['--scene', 'corridor', '--lookalike', 'corridor'],
    'corridor_160x120': CANYON + SMALL + ['--hfov', '95', '--scene', 'corridor', '--lookalike',
                                          'corridor'],
}


def first_revisit(gt_path):
    first = None
    with open(gt_path) as f:
        for line in f:
            fields = line.split('#', 1)[0].split()
            if len(fields) >= 2:
                q = int(fields[0])
                first = q if first is None else min(first, q)
    return first


def cut_list(folder, frames, gt, out_dir, name):
    """The frames before the first revisit, as a list beside the data set's images."""
    stop = first_revisit(os.path.join(folder, gt))
    path = os.path.join(out_dir, f'{name}_cut.txt')
    with open(os.path.join(folder, frames)) as f:
        lines = [line.strip() for line in f if line.strip() and not line.startswith('#')]
    with open(path, 'w') as f:
        f.writelines(os.path.join(folder, line) + '\n' for line in lines[:stop])
    return path, stop


def run(build, frame_list, log, settings):
    cmd = [os.path.join(build, 'bench', 'quality', 'placedb_quality_run'), frame_list, '--log', log]
    for s in settings:
        cmd += ['--set', s]
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f'precision.py: {" ".join(cmd)} failed:\n{out.stderr}')
    return json.loads(out.stdout.strip().splitlines()[-1])


def accepted(log):
    with open(log, newline='') as f:
        return [(int(r['frame']), r['candidate_frames']) for r in csv.DictReader(f)
                if r['accepted'] == '1']


def score(scorer, log, gt):
    out = subprocess.run([sys.executable, scorer, log, gt, '--window', '10', '--json'],
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out)


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--build', default=os.path.join(ROOT, 'build'))
    p.add_argument('--datasets', default=os.path.join(ROOT, '..', 'shared', 'datasets'))
    p.add_argument('--scorer', default=os.path.join(ROOT, '..', 'shared', 'tools', 'score_loops.py'))
    p.add_argument('--out', default='precision-out')
    p.add_argument('--caps', default='0,300', help='wm_max values, 0 = unbounded')
    p.add_argument('--jobs', type=int, default=2)
    p.add_argument('--set', action='append', default=[])
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)

    walker = os.path.join(a.build, 'bench', 'quality', 'placedb_walk_sequence')
    for name, args in WALKS.items():
        folder = os.path.join(a.out, 'walks', name)
        if not os.path.exists(os.path.join(folder, 'frames.txt')):
            subprocess.run([walker, folder] + args, check=True, capture_output=True)

    jobs = []  # (kind, name, cap, frame list, ground truth or None)
    for cap in a.caps.split(','):
        for name, (folder, frames, gt) in SETS.items():
            base = os.path.join(a.datasets, folder)
            if not os.path.exists(os.path.join(base, frames)):
                print(f'precision.py: no {base}/{frames}, skipped', file=sys.stderr)
                continue
            jobs.append(('full', name, cap, os.path.join(base, frames), os.path.join(base, gt)))
            cut, stop = cut_list(base, frames, gt, a.out, name)
            jobs.append((f'cut (frames 0-{stop - 1})', name, cap, cut, None))
        for name in WALKS:
            jobs.append(('walk', name, cap, os.path.join(a.out, 'walks', name, 'frames.txt'), None))

    def do(job):
        kind, name, cap, frame_list, gt = job
        settings = a.set + ([f'wm_max={cap}'] if cap != '0' else [])
        log = os.path.join(a.out, f'{kind.split()[0]}_{name}_wm{cap}.csv')
        summary = run(a.build, frame_list, log, settings)
        row = {'kind': kind, 'name': name, 'cap': cap, 'ms': summary['time_ms_mean']}
        if gt:
            s = score(a.scorer, log, gt)
            row.update(r100=s['recall_at_100_precision'], true=s['accepted_true'],
                       false=s['accepted_false'])
        else:
            row['accepted'] = accepted(log)
        return row

    with ThreadPoolExecutor(a.jobs) as pool:
        rows = list(pool.map(do, jobs))
    print('| run | wm_max | R@100P w10 (accepted true/false) | closures on a walk that never '
          'revisits |')
    print('|---|---|---|---|')
    for r in rows:
        cap = r['cap'] if r['cap'] != '0' else 'unbounded'
        if 'r100' in r:
            print(f"| {r['name']} | {cap} | {r['r100']:.2f} ({r['true']}/{r['false']}) | |")
        else:
            closures = ', '.join(f'{q} on {c}' for q, c in r['accepted'][:8])
            more = f' and {len(r["accepted"]) - 8} more' if len(r['accepted']) > 8 else ''
            print(f"| {r['name']} {r['kind']} | {cap} | | **{len(r['accepted'])}**"
                  f"{': ' + closures + more if r['accepted'] else ''} |")
    with open(os.path.join(a.out, 'precision.json'), 'w') as f:
        json.dump(rows, f, indent=1)
    return 0


if __name__ == '__main__':
    sys.exit(main())
