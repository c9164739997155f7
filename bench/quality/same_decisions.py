#!/usr/bin/env python3
"""Checks that two builds decide alike: maps each frame list with the `placedb` CLI of both
builds (`placedb map M LIST --log LOG [--set K=V ...]`) and compares every log column but the
times (`time_ms` and the per-stage `*_ms`), row by row. Exit 0 when every run matches, 1 when
one differs (the first differing cells are printed), 2 on bad arguments.

Usage: bench/quality/same_decisions.py --base-build DIR [--build DIR] [--list FRAMES]...
                                       [--set KEY=VALUE]... [--out DIR]
Each --list is mapped once with the defaults and once with every --set given (when any is);
without --list, the four data sets in ../shared/datasets are used. Either build may be any
commit's build folder, so a change is checked against the commit before it:
  git worktree add --detach /tmp/prev HEAD~1 && cmake -S /tmp/prev -B /tmp/prev/build ... &&
  bench/quality/same_decisions.py --base-build /tmp/prev/build --set wm_max=300
"""
import argparse
import csv
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
DATASETS = os.path.join(os.path.dirname(ROOT), 'shared', 'datasets')
DEFAULT_SETS = ('lip6_outdoor', 'lip6_outdoor_160x128', 'lip6_outdoor_120x96', 'rtabmap_samples')


def is_time(column):
    return column == 'time_ms' or column.endswith('_ms')


def run(build, frames, settings, out):
    cli = os.path.join(build, 'tools', 'placedb')
    for path in [out + '.placedb' + s for s in ('', '-wal', '-shm', '-lock')] + [out + '.csv']:
        if os.path.exists(path):
            os.remove(path)
    cmd = [cli, 'map', out + '.placedb', frames, '--log', out + '.csv']
    for s in settings:
        cmd += ['--set', s]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(out + '.csv', newline='') as f:
        return list(csv.DictReader(f))


def compare(base_rows, rows):
    """The differing (row, column, base, this) cells, at most 5; a row count differs first."""
    if len(base_rows) != len(rows):
        return [('rows', '', len(base_rows), len(rows))]
    columns = [c for c in base_rows[0] if c in rows[0] and not is_time(c)] if rows else []
    diffs = []
    for i, (a, b) in enumerate(zip(base_rows, rows)):
        for c in columns:
            if a[c] != b[c]:
                diffs.append((i, c, a[c], b[c]))
                if len(diffs) >= 5:
                    return diffs
    return diffs


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--base-build', required=True)
    p.add_argument('--build', default=os.path.join(ROOT, 'build'))
    p.add_argument('--list', action='append', default=[])
    p.add_argument('--set', action='append', default=[])
    p.add_argument('--out', default='/tmp/placedb-same')
    a = p.parse_args()
    lists = a.list or [os.path.join(DATASETS, s, 'frames.txt') for s in DEFAULT_SETS]
    for build in (a.base_build, a.build):
        if not os.access(os.path.join(build, 'tools', 'placedb'), os.X_OK):
            print(f'{build}: no tools/placedb in this build folder', file=sys.stderr)
            return 2
    os.makedirs(a.out, exist_ok=True)
    variants = [[]] + ([a.set] if a.set else [])
    differing = 0
    for frames in lists:
        name = os.path.basename(os.path.dirname(os.path.abspath(frames)))
        for settings in variants:
            label = name + (' ' + ' '.join(settings) if settings else '')
            tag = os.path.join(a.out, name + ('_set' if settings else ''))
            base_rows = run(a.base_build, frames, settings, tag + '_base')
            rows = run(a.build, frames, settings, tag + '_this')
            diffs = compare(base_rows, rows)
            print(f'{label}: {len(rows)} frames, ' +
                  ('same decisions' if not diffs else f'DIFFERENT, first: {diffs}'))
            differing += bool(diffs)
    return 1 if differing else 0


if __name__ == '__main__':
    sys.exit(main())
