#!/usr/bin/env python3
"""Which tables a mapping frame writes: maps a sequence into a new file, stops the writer a few
seconds in (SIGSTOP: the -wal then holds the last frames' pages, uncheckpointed), copies the map
and its -wal, and counts the log's pages by the table or index they belong to (SQLite's dbstat;
pages past the end of the copied file are "(new pages)"). Prints pages per committed frame.

Usage: bench/storage/wal_pages.py [--build DIR] [--list FRAMES] [--seconds S]
"""
import argparse
import collections
import os
import shutil
import signal
import sqlite3
import struct
import subprocess
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def wal_frames(wal_path):
    """The page numbers of the log's valid frames (the current salt), and its commit count."""
    with open(wal_path, 'rb') as f:
        data = f.read()
    if len(data) < 32:
        return [], 0
    _, _, page_size, _, salt1, salt2, _, _ = struct.unpack('>8I', data[:32])
    pages, commits, at = [], 0, 32
    while at + 24 + page_size <= len(data):
        page, db_size, s1, s2 = struct.unpack('>4I', data[at:at + 16])
        if (s1, s2) != (salt1, salt2):
            break
        pages.append(page)
        commits += db_size != 0
        at += 24 + page_size
    return pages, commits


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--build', default=os.path.join(ROOT, 'build'))
    p.add_argument('--list', default=os.path.join(os.path.dirname(ROOT), 'shared', 'datasets',
                                                  'lip6_outdoor', 'frames.txt'))
    p.add_argument('--seconds', type=float, default=6.0)
    args = p.parse_args()
    work = tempfile.mkdtemp(prefix='placedb-wal-pages.')
    try:
        path = os.path.join(work, 'map.placedb')
        child = subprocess.Popen([os.path.join(args.build, 'tools', 'placedb'), 'map', path,
                                  args.list, '-q'], stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL)
        time.sleep(args.seconds)
        if child.poll() is not None:
            raise SystemExit(f'the run ended within {args.seconds} s: give fewer --seconds')
        child.send_signal(signal.SIGSTOP)
        snap = os.path.join(work, 'snap.placedb')
        shutil.copyfile(path, snap)
        shutil.copyfile(path + '-wal', os.path.join(work, 'log.wal'))
        child.kill()
        child.wait()
        pages, commits = wal_frames(os.path.join(work, 'log.wal'))
        if not commits:
            raise SystemExit('no committed frame in the log: try another --seconds')
        db = sqlite3.connect(snap)
        owner = dict(db.execute('SELECT pageno, name FROM dbstat'))
        db.close()
        counts = collections.Counter(owner.get(page, '(new pages)') for page in pages)
        print(f'{len(pages)} pages in {commits} commits: {len(pages) / commits:.1f} a commit')
        print('pages a commit | table or index')
        for name, n in counts.most_common():
            print(f'{n / commits:.1f} | {name}')
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == '__main__':
    main()
