#!/usr/bin/env python3
"""A time budget set from this machine's own pace (issue 12): maps a sequence with working memory
unbounded, then again with t_time_ms = RATIO x that run's mean frame time, back to back, and
prints R@100P at window 10, the accepted closures and the frame times of both, with what memory
management did under the budget: the smallest WM after frame 100, the WM at the end and the mean
time of the memory stages, which are what t_time_ms bounds (from the map's frames table).

A budget is measured against wall time, so only runs made side by side on the same machine
compare; the unbounded run of the same call is the reference.

Build first: cmake --build build -j2 --target placedb_quality_run
Usage: bench/quality/time_budget.py [--build build] [--list FRAMES --gt GT_PAIRS] [--ratio 1.25]
                                    [--out DIR]
"""
import argparse
import json
import os
import sqlite3
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
DATASETS = os.path.join(os.path.dirname(ROOT), 'shared', 'datasets')


def run(args, name, settings):
    base = os.path.join(args.out, name)
    for suffix in ('.placedb', '.placedb-wal', '.placedb-shm', '.csv'):
        if os.path.exists(base + suffix):
            os.remove(base + suffix)
    runner = os.path.join(args.build, 'bench', 'quality', 'placedb_quality_run')
    command = [runner, args.list, '--log', base + '.csv', '--map', base + '.placedb']
    for s in settings:
        command += ['--set', s]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    scored = subprocess.run([sys.executable, args.scorer, base + '.csv', args.gt, '--window', '10',
                             '--json'], check=True, capture_output=True, text=True)
    figures = json.loads(scored.stdout)
    with sqlite3.connect(base + '.placedb') as db:
        figures['wm_min'], figures['wm_last'] = db.execute(
            'SELECT MIN(wm_size), (SELECT wm_size FROM frames ORDER BY id DESC LIMIT 1) '
            'FROM frames WHERE id > 100').fetchone()
        figures['memory_ms'] = db.execute('SELECT AVG(memory_ms) FROM frames').fetchone()[0]
    return figures


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--build', default=os.path.join(ROOT, 'build'))
    p.add_argument('--list', default=os.path.join(DATASETS, 'lip6_outdoor', 'frames.txt'))
    p.add_argument('--gt', default=os.path.join(DATASETS, 'lip6_outdoor', 'gt_pairs.txt'))
    p.add_argument('--scorer', default=os.path.join(os.path.dirname(ROOT), 'shared', 'tools',
                                                    'score_loops.py'))
    p.add_argument('--ratio', type=float, default=1.25)
    p.add_argument('--out', default='/tmp/placedb-time-budget')
    args = p.parse_args()
    os.makedirs(args.out, exist_ok=True)

    unbounded = run(args, 'unbounded', [])
    budget = max(1, round(args.ratio * unbounded['time_ms_mean']))
    bounded = run(args, f't{budget}', [f't_time_ms={budget}'])
    print(f'{"settings":<22} {"R@100P w10":>10} {"true/false":>11} {"mean ms":>8} {"p99 ms":>8} '
          f'{"memory ms":>9} {"WM min":>6} {"WM end":>6}')
    for label, f in (('unbounded', unbounded), (f't_time_ms={budget}', bounded)):
        print(f'{label:<22} {f["recall_at_100_precision"]:>10.2f} '
              f'{f["accepted_true"]:>5}/{f["accepted_false"]:<5} {f["time_ms_mean"]:>8.1f} '
              f'{f["time_ms_p99"]:>8.1f} {f["memory_ms"]:>9.2f} {f["wm_min"]:>6} {f["wm_last"]:>6}')
    print(f'budget: {args.ratio} x the unbounded mean {unbounded["time_ms_mean"]:.1f} ms = '
          f'{budget} ms; R@100P difference '
          f'{bounded["recall_at_100_precision"] - unbounded["recall_at_100_precision"]:+.2f} points')


if __name__ == '__main__':
    main()
