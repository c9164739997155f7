#!/usr/bin/env python3
"""What the frames behind each window's p99 spend their time on.

    p99_frames.py FRAME_TIMES.csv [--window 5000] [--windows 2,20]

FRAME_TIMES.csv is placedb_scale_bench's --frame-times output. For each window (1-based, as the
bench's rows count them: window 2 is frames 5000-9999 at --window 5000) it prints the p99 of the
frame time, then the mean stage times and tier moves of the frames at or above the p99 ("top")
and of all the others ("rest"): a p99 that grows with the map shows here which stage and which
per-frame work grow with it. Last, per window, the least-squares line memory = a + b x retrieved
over its frames: a is what every frame pays whatever it retrieves (the place-code scan grows it
with the map), b what each retrieval and the transfer that makes room for it cost. Where the file
has the bench's disk_kb column, per window too: how many frames read the disk (pages the page
cache no longer held) and how many of those are at or above the p99, and the p99 of the frames
that read nothing from it, which is the engine's own work without waits on the disk.
"""
import argparse
import csv
import sys

STAGES = ['features', 'quantisation', 'likelihood', 'filter', 'verification', 'memory', 'storage']
MOVES = ['retrieved', 'retrieved_by_search', 'transferred', 'accepted']
# The bench's own column names where it prints the same figure.
LABELS = ['feat', 'quant', 'like', 'filt', 'verif', 'mem', 'stor', 'retr', 'srch', 'trans', 'acc']


def percentile(values, p):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(p / 100 * (len(ordered) - 1)))]


def mean(rows, column):
    return sum(float(r[column]) for r in rows) / len(rows) if rows else 0.0


def fit_line(xs, ys):
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs)
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx else 0.0
    return my - b * mx, b


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('frame_times')
    parser.add_argument('--window', type=int, default=5000)
    parser.add_argument('--windows', default='',
                        help='comma-separated window numbers (default: every window)')
    args = parser.parse_args()
    try:
        with open(args.frame_times, newline='') as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        sys.exit(f'error: {args.frame_times}: {e.strerror}')
    missing = [c for c in ['frame', 'ms'] + STAGES + MOVES if rows and c not in rows[0]]
    if not rows or missing:
        sys.exit(f'error: {args.frame_times}: not a --frame-times file'
                 + (f' (no column {missing[0]})' if missing else ' (no rows)'))
    windows = {}
    for r in rows:
        windows.setdefault(int(r['frame']) // args.window + 1, []).append(r)
    wanted = [int(w) for w in args.windows.split(',') if w] or sorted(windows)
    header = ' '.join(f'{c:>6}' for c in LABELS)
    print(f'{"window":>6} {"p99 ms":>7} {"frames":>6} {"ms":>6} {header}')
    for w in wanted:
        frames = windows.get(w, [])
        if not frames:
            print(f'{w:>6}: no frames')
            continue
        p99 = percentile([float(r['ms']) for r in frames], 99)
        top = [r for r in frames if float(r['ms']) >= p99]
        rest = [r for r in frames if float(r['ms']) < p99]
        for name, group in (('top', top), ('rest', rest)):
            cells = ' '.join(f'{mean(group, c):>6.2f}' for c in STAGES + MOVES)
            label = f'{w:>6} {p99:>7.2f}' if name == 'top' else f'{"":>6} {"rest":>7}'
            print(f'{label} {len(group):>6} {mean(group, "ms"):>6.2f} {cells}')
    print(f'\n{"window":>6} {"a ms":>7} {"b ms":>7}   memory = a + b x retrieved')
    for w in wanted:
        frames = windows.get(w, [])
        if frames:
            a, b = fit_line([float(r['retrieved']) for r in frames],
                            [float(r['memory']) for r in frames])
            print(f'{w:>6} {a:>7.3f} {b:>7.3f}')
    if rows and 'disk_kb' in rows[0]:
        print_disk(windows, wanted)


def print_disk(windows, wanted):
    print(f'\n{"window":>6} {"p99 ms":>7} {"disk fr":>7} {"in top":>6} {"disk MB":>7} '
          f'{"p99 w/o":>7}   frames that read the disk; p99 of those that did not')
    for w in wanted:
        frames = windows.get(w, [])
        if not frames:
            continue
        p99 = percentile([float(r['ms']) for r in frames], 99)
        disk = [r for r in frames if int(r['disk_kb']) > 0]
        top = sum(1 for r in disk if float(r['ms']) >= p99)
        clean = [float(r['ms']) for r in frames if int(r['disk_kb']) == 0]
        mb = sum(int(r['disk_kb']) for r in frames) * 1024 / 1e6  # MB, as the bench prints
        without = f'{percentile(clean, 99):>7.2f}' if clean else f'{"-":>7}'
        print(f'{w:>6} {p99:>7.2f} {len(disk):>7} {top:>6} {mb:>7.1f} {without}')


if __name__ == '__main__':
    main()
