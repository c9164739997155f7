#!/usr/bin/env python3
"""Scores builds on cameras the defaults were never looked at with: copies of lip6_outdoor made
by placedb_resize_frames as another camera would see the same walk (another size, a mirror,
sensor noise, a darker and flatter response) and the walk at half the frame rate. The copies go
to WORK and are made once. For each copy and each build: `placedb_quality_run LIST --log L.csv
[--set K=V ...]` scored by ../shared/tools/score_loops.py at window 10 (R@100P, accepted
true/false), then every accepted closure that is false at window 10, with its distance to the
nearest ground-truth frame, so that a miss by one frame past the window reads apart from a wrong
place.

Usage: bench/quality/unseen_derivations.py --build DIR [--base-build DIR] [--work DIR]
                                           [--set KEY=VALUE]...
Build first: cmake --build build -j2 --target placedb_quality_run placedb_resize_frames
"""
import argparse
import csv
import os
import subprocess
import sys

from run import score as score_log  # score_loops.py --json on one log

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
SHARED = os.path.join(os.path.dirname(ROOT), 'shared')
LIP6 = os.path.join(SHARED, 'datasets', 'lip6_outdoor')
LIP6_120 = os.path.join(SHARED, 'datasets', 'lip6_outdoor_120x96')

# name: (source set, width, height, placedb_resize_frames options, keep every n-th frame)
DERIVATIONS = {
    'size_200x160': (LIP6, 200, 160, [], 1),
    'mirror_160x128': (LIP6, 160, 128, ['--mirror'], 1),
    'noise8_120x96': (LIP6, 120, 96, ['--noise', '8'], 1),
    'dark_160x128': (LIP6, 160, 128, ['--gamma', '1.8', '--gain', '0.7'], 1),
    'every2nd': (LIP6, 0, 0, [], 2),
    'every2nd_120x96': (LIP6_120, 0, 0, [], 2),
}


def read_list(path):
    base = os.path.dirname(path)
    with open(path) as f:
        return [os.path.join(base, line.strip()) for line in f if line.strip()]


def read_pairs(path):
    pairs = []
    with open(path) as f:
        for line in f:
            if line.strip() and not line.startswith('#'):
                q, r = line.split()[:2]
                pairs.append((int(q), int(r)))
    return pairs


def make_copy(name, work, resizer):
    """Writes WORK/NAME/frames.txt and gt_pairs.txt (and the images, when resized)."""
    source, width, height, options, every = DERIVATIONS[name]
    out = os.path.join(work, name)
    frames_path, gt_path = os.path.join(out, 'frames.txt'), os.path.join(out, 'gt_pairs.txt')
    if os.path.exists(frames_path) and os.path.exists(gt_path):
        return frames_path, gt_path
    os.makedirs(out, exist_ok=True)
    frames = read_list(os.path.join(source, 'frames.txt'))
    if width:
        subprocess.run([resizer, os.path.join(source, 'frames.txt'), os.path.join(out, 'images'),
                        str(width), str(height)] + options, check=True)
        frames = [os.path.join(out, 'images', os.path.basename(p)) for p in frames]
    kept = frames[::every]
    # A pair survives when both frames are kept; indices are renumbered in the shorter list.
    pairs = [(q // every, r // every) for q, r in read_pairs(os.path.join(source, 'gt_pairs.txt'))
             if q % every == 0 and r % every == 0]
    with open(gt_path + '.tmp', 'w') as f:
        f.write('# q r : 0-based line indices into frames.txt (q > r)\n')
        f.writelines(f'{q} {r}\n' for q, r in pairs)
    with open(frames_path + '.tmp', 'w') as f:
        f.writelines(p + '\n' for p in kept)
    os.replace(gt_path + '.tmp', gt_path)
    os.replace(frames_path + '.tmp', frames_path)
    return frames_path, gt_path


def false_closures(log, gt_path):
    """(frame, named frames, distance to the nearest ground-truth frame) of every accepted
    closure farther than 10 frames from all of its frame's ground truth."""
    truth = {}
    for q, r in read_pairs(gt_path):
        truth.setdefault(q, []).append(r)
    out = []
    with open(log, newline='') as f:
        for row in csv.DictReader(f):
            if row['accepted'] != '1':
                continue
            q = int(row['frame'])
            named = [int(x) for x in row['candidate_frames'].split()]
            near = min((abs(a - b) for a in named for b in truth.get(q, [])), default=None)
            if near is None or near > 10:
                out.append((q, named, near))
    return out


def map_and_score(build, name, frames, gt, settings, work, tag):
    log = os.path.join(work, f'{name}.{tag}.csv')
    cmd = [os.path.join(build, 'bench', 'quality', 'placedb_quality_run'), frames, '--log', log]
    for s in settings:
        cmd += ['--set', s]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    s = score_log(os.path.join(SHARED, 'tools', 'score_loops.py'), log, gt, 10)
    return s, false_closures(log, gt)


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--build', default=os.path.join(ROOT, 'build'))
    p.add_argument('--base-build', help='a second build to score side by side')
    p.add_argument('--work', default='/tmp/placedb_unseen')
    p.add_argument('--set', action='append', default=[], metavar='KEY=VALUE')
    a = p.parse_args()
    resizer = os.path.join(a.build, 'bench', 'quality', 'placedb_resize_frames')
    for tool in (resizer, os.path.join(a.build, 'bench', 'quality', 'placedb_quality_run')):
        if not os.path.exists(tool):
            sys.exit(f'{tool} is missing: build it first (see --help)')
    builds = [('build', a.build)] + ([('base', a.base_build)] if a.base_build else [])
    settings = ' '.join(a.set) or 'defaults'
    print(f'R@100P at window 10 (accepted true/false), {settings}')
    for name in DERIVATIONS:
        frames, gt = make_copy(name, a.work, resizer)
        cells, misses = [], []
        for tag, build in builds:
            s, false = map_and_score(build, name, frames, gt, a.set, a.work, tag)
            cells.append(f"{tag} {s['recall_at_100_precision']:.2f} "
                         f"({s['accepted_true']}/{s['accepted_false']})")
            misses += [f'{tag}: frame {q} named {" ".join(map(str, named))}, '
                       f'{"no ground truth" if d is None else f"{d} frames from it"}'
                       for q, named, d in false]
        print(f'{name:18s} ' + '   '.join(cells), flush=True)
        for m in misses:
            print(f'    false: {m}')


if __name__ == '__main__':
    main()
