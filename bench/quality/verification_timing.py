#!/usr/bin/env python3
"""Verification cost at two resolutions (issue 13: verification p99 <= 5 ms at 240x192 and
<= 15 ms at 960x540).

Takes every STEP-th frame of lip6_outdoor (default 3: 355 frames, loops included, so the
geometric check both passes and fails), writes a 960x540 copy of them (placedb_resize_frames,
bicubic, stretched from 240x192: 4x across, 2.8x down; images go to WORK, never to the
repository) with
a frame list and the ground truth of the subset, maps both lists with placedb_quality_run and
prints, per resolution: verification_ms mean / p50 / p99 / max, candidates checked, and the
per-stage means of the frames table of the map (features, quantisation, likelihood, filter,
memory, storage, total), plus the R@100P of each log at window 10 when the scorer is found.

Build first: cmake --build build -j2 --target placedb_quality_run placedb_resize_frames
Usage: bench/quality/verification_timing.py [--build build] [--datasets DIR] [--work DIR]
                                            [--step 3] [--limit N] [--set key=value]...
"""
import argparse
import csv
import json
import os
import sqlite3
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
STAGES = ['features_ms', 'quantisation_ms', 'likelihood_ms', 'filter_ms', 'memory_ms',
          'storage_ms', 'total_ms']


def percentile(values, p):
    if not values:
        return 0.0
    v = sorted(values)
    return v[min(len(v) - 1, int(round(p / 100.0 * (len(v) - 1))))]


def subset(datasets, step, limit):
    base = os.path.join(datasets, 'lip6_outdoor')
    with open(os.path.join(base, 'frames.txt')) as f:
        frames = [l.strip() for l in f if l.strip() and not l.startswith('#')]
    picked = list(range(0, len(frames), step))
    if limit:
        picked = picked[:limit]
    index_of = {old: new for new, old in enumerate(picked)}
    pairs = []
    with open(os.path.join(base, 'gt_pairs.txt')) as f:
        for line in f:
            if line.startswith('#') or not line.strip():
                continue
            q, r = (int(x) for x in line.split()[:2])
            if q in index_of and r in index_of:
                pairs.append((index_of[q], index_of[r]))
    return base, [frames[i] for i in picked], pairs


def write_lists(work, base, frames, pairs, resizer):
    os.makedirs(os.path.join(work, 'images960'), exist_ok=True)
    original, upscaled = os.path.join(work, 'frames240.txt'), os.path.join(work, 'frames960.txt')
    with open(original, 'w') as f:
        f.writelines(os.path.join(base, p) + '\n' for p in frames)
    with open(upscaled, 'w') as f:
        for p in frames:
            f.write(os.path.join('images960', os.path.basename(p)) + '\n')
    with open(os.path.join(work, 'gt_pairs.txt'), 'w') as f:
        f.write('# q r : 0-based line indices into the frame lists (q > r)\n')
        f.writelines(f'{q} {r}\n' for q, r in pairs)
    if not all(os.path.exists(os.path.join(work, 'images960', os.path.basename(p)))
               for p in frames):
        subprocess.run([resizer, original, os.path.join(work, 'images960'), '960', '540'],
                       check=True)
    return original, upscaled


def measure(runner, frames, log, settings, rerun=True):
    if rerun or not os.path.exists(log):
        cmd = [runner, frames, '--log', log]
        for s in settings:
            cmd += ['--set', s]
        subprocess.run(cmd, check=True, capture_output=True, text=True)
    with open(log) as f:
        rows = list(csv.DictReader(f))
    verification = [float(r['verification_ms']) for r in rows]
    checked = [int(r['candidates_checked']) for r in rows]
    # The log's time_ms is the whole frame, the commit included; the frames table's stages stop
    # before the commit (a row cannot time its own write), so storage is the difference.
    totals = [float(r['time_ms']) for r in rows]
    db = sqlite3.connect(f'file:{os.path.splitext(log)[0]}.placedb?mode=ro', uri=True)
    staged = db.execute('SELECT ' + ', '.join(f'avg({s})' for s in STAGES[:5]) +
                        ', avg(features_ms + quantisation_ms + likelihood_ms + filter_ms + '
                        'memory_ms) FROM frames').fetchone()
    means = list(staged[:5]) + [sum(totals) / max(1, len(totals)) - staged[5],
                                sum(totals) / max(1, len(totals))]
    posed = db.execute('SELECT count(*) FROM hypotheses WHERE accepted = 1 '
                       'AND pose_qw IS NOT NULL').fetchone()[0]
    db.close()
    return {
        'frames': len(rows),
        'accepted': sum(int(r['accepted']) for r in rows),
        'posed': posed,
        'verification_mean': sum(verification) / max(1, len(verification)),
        'verification_p50': percentile(verification, 50),
        'verification_p99': percentile(verification, 99),
        'verification_max': max(verification, default=0.0),
        'checked_mean': sum(checked) / max(1, len(checked)),
        'checked_max': max(checked, default=0),
        'stage_means': dict(zip(STAGES, means)),
        'total_p99': percentile(totals, 99),
    }


def recall(scorer, log, gt):
    if not os.path.exists(scorer):
        return None
    out = subprocess.run([sys.executable, scorer, log, gt, '--window', '10', '--json'],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--build', default=os.path.join(ROOT, 'build'))
    ap.add_argument('--datasets', default=os.path.join(ROOT, '..', 'shared', 'datasets'))
    ap.add_argument('--scorer', default=os.path.join(ROOT, '..', 'shared', 'tools',
                                                     'score_loops.py'))
    ap.add_argument('--work', default=None, help='default: BUILD/bench-verification')
    ap.add_argument('--step', type=int, default=3)
    ap.add_argument('--limit', type=int, default=0, help='at most this many frames (0: all)')
    ap.add_argument('--set', action='append', default=[], dest='settings')
    ap.add_argument('--report-only', action='store_true',
                    help='do not map again: report the logs and maps WORK already holds')
    ap.add_argument('--camera', action='store_true',
                    help='also map both with assumed intrinsics (240x192: fx=fy=190, cx=120, '
                         'cy=96; scaled for 960x540), to time the relative pose')
    args = ap.parse_args()
    work = args.work or os.path.join(args.build, 'bench-verification')
    runner = os.path.join(args.build, 'bench', 'quality', 'placedb_quality_run')
    base, frames, pairs = subset(args.datasets, args.step, args.limit)
    resizer = os.path.join(args.build, 'bench', 'quality', 'placedb_resize_frames')
    original, upscaled = write_lists(work, base, frames, pairs, resizer)
    gt = os.path.join(work, 'gt_pairs.txt')
    print(f'{len(frames)} frames (every {args.step}th of lip6_outdoor), {len(pairs)} gt pairs; '
          f'settings: {" ".join(args.settings) or "defaults"}')
    header = ('| resolution | frames | accepted (with pose) | R@100P w10 (true/false) | verification mean / p50 / p99 / max '
              '| candidates mean / max | frame mean / p99 | features | quantisation | likelihood '
              '| filter | memory | storage |')
    print(header)
    print('|' + '---|' * (header.count('|') - 1))
    results = {}
    runs = [('240x192', original, []), ('960x540', upscaled, [])]
    if args.camera:
        runs += [('240x192 + camera', original, ['fx=190', 'fy=190', 'cx=120', 'cy=96']),
                 ('960x540 + camera', upscaled, ['fx=760', 'fy=534.375', 'cx=480', 'cy=270'])]
    for name, frames_list, camera in runs:
        log = os.path.join(work, f"run{name.replace(' + ', '_')}.csv")
        m = measure(runner, frames_list, log, args.settings + camera, not args.report_only)
        score = recall(args.scorer, log, gt)
        r100 = (f"{score['recall_at_100_precision']:.2f} "
                f"({score['accepted_true']}/{score['accepted_false']})" if score else '-')
        s = m['stage_means']
        print(f"| {name} | {m['frames']} | {m['accepted']} ({m['posed']}) | {r100} | "
              f"{m['verification_mean']:.2f} / {m['verification_p50']:.2f} / "
              f"{m['verification_p99']:.2f} / {m['verification_max']:.2f} | "
              f"{m['checked_mean']:.1f} / {m['checked_max']} | "
              f"{s['total_ms']:.1f} / {m['total_p99']:.1f} | {s['features_ms']:.1f} | "
              f"{s['quantisation_ms']:.1f} | {s['likelihood_ms']:.1f} | {s['filter_ms']:.1f} | "
              f"{s['memory_ms']:.1f} | {s['storage_ms']:.1f} |")
        results[name] = m
    with open(os.path.join(work, 'summary.json'), 'w') as f:
        json.dump(results, f, indent=2)


if __name__ == '__main__':
    main()
