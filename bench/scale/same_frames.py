#!/usr/bin/env python3
"""The same frames on a small and a large map: what a frame's cost owes to the map's size.

    same_frames.py --bench BIN --small MAP --large MAP [--frames 100000] [--seed 2]
                   [--first 98500] [--count 1000] [--rounds 3] [--width 160] [--height 120]
                   [--wm-max 1000] [--set key=value]...

Both maps are placedb_scale_bench maps of one size (--width, --height), the small one made with
fewer frames (say --frames 10000), the large one with many (--frames 100000). Each round maps
COUNT frames of the sequence of seed --seed, starting at FIRST, again on a fresh copy of each map
(--remap; the maps themselves stay as they are), small then large, back to back. With a seed other
than the maps' own the frames show places neither map has seen, so both maps get the same
frames and the same kind of work: what differs is the map behind them.

Prints each run's frame time p50 and p99 and its stage means, the large map's ratio to the small
one per round, and then the frames paired (the same frame of the same round on both maps) and
grouped by how many more places the large map brought back from LTM for them. The group "+0"
did the same tier work on both maps: its difference is what the size alone costs (the place-code
scan, deeper tables, colder caches); the other groups add what the extra retrievals, and the
checks of the places they bring, cost. A p99 that grows with the map while the +0 group's
difference stays small grows with the work the decisions ask for, not with the cost of each step.
"""
import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile

from p99_frames import percentile

STAGES = ['features', 'quantisation', 'filter', 'verification', 'memory', 'storage']
LABELS = ['feat', 'quant', 'filt', 'verif', 'mem', 'stor']


def mean(values):
    return sum(values) / len(values) if values else 0.0


def run_once(args, map_path, work_dir, label):
    copy = os.path.join(work_dir, 'remap.placedb')
    times = os.path.join(work_dir, f'{label}.csv')
    for leftover in (copy, copy + '-wal', copy + '-shm', copy + '-lock'):
        if os.path.exists(leftover):
            os.remove(leftover)
    shutil.copyfile(map_path, copy)
    # The copy's dirty pages would otherwise be written back while the frames run, and the
    # commits' fsyncs would wait for them.
    os.sync()
    command = [args.bench, '--frames', str(args.frames), '--seed', str(args.seed),
               '--width', str(args.width), '--height', str(args.height),
               '--wm-max', str(args.wm_max), '--frame-times', times]
    for setting in args.set:
        command += ['--set', setting]
    command += ['--remap', copy, str(args.first), str(args.count)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f'error: {args.bench} on {map_path} exited {done.returncode}: '
                 + (done.stderr.strip() or done.stdout.strip()))
    with open(times, newline='') as f:
        rows = {int(r['frame']): r for r in csv.DictReader(f)}
    if not rows:
        sys.exit(f'error: {times}: the bench wrote no frame')
    return rows


def summary(rows):
    ms = [float(r['ms']) for r in rows.values()]
    out = {'p50': percentile(ms, 50), 'p99': percentile(ms, 99), 'mean': mean(ms),
           'retr': mean([float(r['retrieved']) for r in rows.values()])}
    for stage in STAGES:
        out[stage] = mean([float(r[stage]) for r in rows.values()])
    return out


def print_run(name, s):
    stages = ' '.join(f'{label} {s[stage]:5.2f}' for label, stage in zip(LABELS, STAGES))
    print(f'  {name:5} p50 {s["p50"]:6.2f}  p99 {s["p99"]:6.2f}  mean {s["mean"]:6.2f} ms | '
          f'{stages} | retrieved {s["retr"]:.2f}')


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--bench', required=True, help='placedb_scale_bench')
    parser.add_argument('--small', required=True, help='a map made with few frames')
    parser.add_argument('--large', required=True, help='a map made with many frames')
    parser.add_argument('--frames', type=int, default=100000, help='the sequence planned')
    parser.add_argument('--seed', type=int, default=2, help='the frames\' world (maps: seed 1)')
    parser.add_argument('--first', type=int, default=98500)
    parser.add_argument('--count', type=int, default=1000)
    parser.add_argument('--rounds', type=int, default=3)
    parser.add_argument('--width', type=int, default=160)
    parser.add_argument('--height', type=int, default=120)
    parser.add_argument('--wm-max', type=int, default=1000)
    parser.add_argument('--set', action='append', default=[], help='an engine setting, key=value')
    parser.add_argument('--work-dir', help='where the copies go (default: beside --large)')
    args = parser.parse_args()
    for path in (args.bench, args.small, args.large):
        if not os.path.isfile(path):
            sys.exit(f'error: {path}: no such file')

    work_parent = args.work_dir or os.path.dirname(os.path.abspath(args.large))
    pairs = []  # (small rows, large rows) per round
    with tempfile.TemporaryDirectory(prefix='same_frames.', dir=work_parent) as work_dir:
        for r in range(1, args.rounds + 1):
            small = run_once(args, args.small, work_dir, f'small_{r}')
            large = run_once(args, args.large, work_dir, f'large_{r}')
            s, l = summary(small), summary(large)
            print(f'round {r}: frames {args.first}-{args.first + args.count - 1} of seed '
                  f'{args.seed}')
            print_run('small', s)
            print_run('large', l)
            print(f'  large/small: p50 {l["p50"] / s["p50"]:.3f}x  p99 {l["p99"] / s["p99"]:.3f}x  '
                  f'mean {l["mean"] / s["mean"]:.3f}x')
            pairs.append((small, large))

    # Each frame against itself on the other map, grouped by the extra places it brought back.
    groups = {}
    for small, large in pairs:
        for frame, s in small.items():
            l = large.get(frame)
            if l is None:
                continue
            extra = int(l['retrieved']) - int(s['retrieved'])
            group = groups.setdefault(extra, {'ms': [], **{st: [] for st in STAGES}})
            group['ms'].append(float(l['ms']) - float(s['ms']))
            for stage in STAGES:
                group[stage].append(float(l[stage]) - float(s[stage]))
    print('\nthe same frame, large map minus small, by the places the large map brought back '
          'beyond the small one\'s (ms)')
    print('extra  frames      ms  ' + '  '.join(f'{label:>5}' for label in LABELS))
    for extra in sorted(groups):
        g = groups[extra]
        stages = '  '.join(f'{mean(g[stage]):+5.2f}' for stage in STAGES)
        print(f'{extra:+5d}  {len(g["ms"]):6d}  {mean(g["ms"]):+6.2f}  {stages}')


if __name__ == '__main__':
    main()
