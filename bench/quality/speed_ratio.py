#!/usr/bin/env python3
"""Time per frame of this tree against a base commit: builds the `placedb` CLI of both, maps the
same sequence with each back to back (`placedb map NEW.placedb LIST --log LOG`, alternating,
--rounds times) and prints per-stage means from the logs and the ratio of the frame means.
On a shared machine only the ratio of runs made side by side means anything.

Usage: bench/quality/speed_ratio.py [--base COMMIT] [--base-dir DIR] [--build DIR]
                                    [--list FRAMES] [--rounds N] [--out DIR] [--set K=V]...
The base commit is checked out with `git worktree add --detach` into --base-dir (kept for the
next call) and built there; this tree's CLI is taken from --build as it stands.
"""
import argparse
import csv
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
CLI = os.path.join('tools', 'placedb')
STAGES = ('features_ms', 'quantisation_ms', 'likelihood_ms', 'filter_ms', 'verification_ms',
          'memory_ms', 'storage_ms')


def build(tree, build_dir):
    subprocess.run(['cmake', '-S', tree, '-B', build_dir, '-DCMAKE_BUILD_TYPE=Release'],
                   check=True, stdout=subprocess.DEVNULL)
    subprocess.run(['cmake', '--build', build_dir, '-j2', '--target', 'placedb'],
                   check=True, stdout=subprocess.DEVNULL)


def percentile(values, p):
    v = sorted(values)
    return v[min(len(v) - 1, round(p / 100 * (len(v) - 1)))] if v else 0.0


def run(cli, frames, out_dir, name, settings=()):
    base = os.path.join(out_dir, name)
    for suffix in ('.placedb', '.placedb-wal', '.placedb-shm', '.csv'):
        if os.path.exists(base + suffix):
            os.remove(base + suffix)
    cmd = [cli, 'map', base + '.placedb', frames, '--log', base + '.csv']
    for s in settings:
        cmd += ['--set', s]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(base + '.csv', newline='') as f:
        rows = list(csv.DictReader(f))
    figures = {'time_ms': [float(r['time_ms']) for r in rows]}
    for stage in STAGES:
        if rows and stage in rows[0]:
            figures[stage] = [float(r[stage]) for r in rows]
    return figures


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--base', default='c6a58ab')
    p.add_argument('--base-dir', default='/tmp/placedb-speed-base')
    p.add_argument('--build', default=os.path.join(ROOT, 'build'))
    p.add_argument('--list', default=os.path.join(os.path.dirname(ROOT), 'shared', 'datasets',
                                                  'lip6_outdoor', 'frames.txt'))
    p.add_argument('--rounds', type=int, default=1)
    p.add_argument('--out', default='/tmp/placedb-speed')
    p.add_argument('--set', action='append', default=[],
                   help='KEY=VALUE for this tree only (settings the base may not know)')
    a = p.parse_args()
    if not os.path.isdir(a.base_dir):
        subprocess.run(['git', '-C', ROOT, 'worktree', 'add', '--detach', a.base_dir, a.base],
                       check=True)
    base_build = os.path.join(a.base_dir, 'build')
    build(a.base_dir, base_build)
    clis = {'base': os.path.join(base_build, CLI), 'this': os.path.join(a.build, CLI)}
    if not os.path.exists(clis['this']):
        print(f'missing CLI (build target placedb): {clis["this"]}', file=sys.stderr)
        return 2
    os.makedirs(a.out, exist_ok=True)
    runs = {'base': [], 'this': []}
    for r in range(a.rounds):
        for name in ('base', 'this'):
            settings = a.set if name == 'this' else ()
            runs[name].append(run(clis[name], a.list, a.out, f'{name}_{r}', settings))
            t = runs[name][-1]['time_ms']
            print(f'round {r} {name}: mean {sum(t) / len(t):.1f} ms, p99 '
                  f'{percentile(t, 99):.1f}, max {max(t):.1f}', flush=True)
    print('| build | frame mean | ' + ' | '.join(s.replace('_ms', '') for s in STAGES) +
          ' | filter p99 | verification p99 |')
    print('|---' * (len(STAGES) + 4) + '|')
    means, p99s = {}, {}
    for name in ('base', 'this'):
        merged = {}
        for figures in runs[name]:
            for key, values in figures.items():
                merged.setdefault(key, []).extend(values)
        means[name] = sum(merged['time_ms']) / len(merged['time_ms'])
        cells = [f'{sum(merged[s]) / len(merged[s]):.1f}' if s in merged else '-' for s in STAGES]
        p99 = [f'{percentile(merged[s], 99):.1f}' if s in merged else '-'
               for s in ('filter_ms', 'verification_ms')]
        label = a.base if name == 'base' else 'this tree'
        p99s[name] = percentile(merged['time_ms'], 99)
        print(f"| {label} | {means[name]:.1f} | {' | '.join(cells)} | {' | '.join(p99)} |")
    print(f"ratio of frame means (this / base): {means['this'] / means['base']:.3f}")
    print(f"ratio of frame p99 (this / base): {p99s['this'] / p99s['base']:.3f}")
    return 0


if __name__ == '__main__':
    sys.exit(main())
