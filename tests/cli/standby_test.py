#!/usr/bin/python3
"""Read replicas (issue #49): the office reads a hot standby of the fleet's map while robots
write the primary, on two PostgreSQL servers of its own (scripts/pg-server.sh start, then
standby: streaming replication from a pg_basebackup -R copy).

1. Robot A maps rtabmap_samples into the primary; once the standby has replayed the primary's
   WAL, `info --json`, `query --json` (three images), `export` (g2o) and `report` give on the
   standby what they give on the primary, but for the map's name and the times.
2. Robot B maps lip6_outdoor's first 100 frames into the primary while `query` and `info` run on
   the standby, each exiting 0; caught up again, the standby's `info` is the primary's.
3. `map` and `copy` into the standby exit 6 with one error line that names the standby.
4. The standby's server log holds no error: no command tried to write it.

Exit 77 (ctest: skipped) with a message where the server binaries or the data sets are absent.
Usage: standby_test.py PLACEDB PG_SERVER_SCRIPT DATASETS
"""
import glob
import html
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

FAILURES = []
PATIENCE_S = 120


def check(ok, what):
    print(('ok      ' if ok else 'FAILED  ') + what, flush=True)
    if not ok:
        FAILURES.append(what)
    return ok


def run(*args, expect=0):
    p = subprocess.run(args, capture_output=True, text=True)
    if expect is not None and p.returncode != expect:
        raise RuntimeError(f'{" ".join(args)}: exit {p.returncode}: {p.stderr.strip()[-500:]}')
    return p


def psql(uri, sql):
    return run('psql', uri, '-Atc', sql).stdout.strip()


def caught_up(primary, standby):
    """Waits until the standby has replayed everything the primary has written."""
    target = psql(primary, 'select pg_current_wal_lsn()')
    deadline = time.monotonic() + PATIENCE_S
    while psql(standby, f"select pg_last_wal_replay_lsn() >= '{target}'::pg_lsn") != 't':
        if time.monotonic() > deadline:
            raise RuntimeError('the standby did not catch up with the primary')
        time.sleep(0.05)


def without(value, names):
    """A JSON value with the keys `names` dropped, everywhere."""
    if isinstance(value, dict):
        return {k: without(v, names) for k, v in value.items() if k not in names}
    if isinstance(value, list):
        return [without(v, names) for v in value]
    return value


def main(argv):
    placedb, server, datasets = argv[1:4]
    if not glob.glob('/usr/lib/postgresql/*/bin/pg_basebackup') and not os.environ.get('PG_BIN'):
        print('skipped: PostgreSQL\'s server binaries are not installed (Debian package '
              'postgresql; scripts/install-deps.sh installs it)')
        return 77
    rtab = os.path.join(datasets, 'rtabmap_samples', 'frames.txt')
    lip6 = os.path.join(datasets, 'lip6_outdoor', 'frames.txt')
    if not (os.path.exists(rtab) and os.path.exists(lip6)):
        print(f'skipped: the data sets are absent ({datasets})')
        return 77
    work = tempfile.mkdtemp(prefix='placedb-standby-test.')
    w = lambda name: os.path.join(work, name)  # noqa: E731
    started = time.monotonic()
    try:
        primary = run('bash', server, 'start', w('primary')).stdout.strip()
        run(placedb, 'map', primary, rtab, '--log', w('a.csv'), '-q')
        standby = run('bash', server, 'standby', w('primary'), w('standby')).stdout.strip()
        check(psql(standby, 'select pg_is_in_recovery()') == 't',
              f'pg-server.sh standby started a hot standby: {standby}')
        caught_up(primary, standby)

        # 1. The same answers.
        # The map's name, also as the report's HTML writes it.
        name = lambda uri, text: text.replace(uri, 'MAP').replace(html.escape(uri), 'MAP')  # noqa
        infos = [json.loads(name(uri, run(placedb, 'info', uri, '--json').stdout))
                 for uri in (primary, standby)]
        check(infos[0] == infos[1] and infos[0]['frames'] == 84,
              f'info --json: the standby\'s equals the primary\'s ({infos[1]["frames"]} frames, '
              f'{infos[1]["accepted_closures"]} closures)')
        images = [os.path.join(datasets, 'rtabmap_samples', 'images', f'{i}.jpg')
                  for i in (5, 40, 70)]
        queries = [without(json.loads(run(placedb, 'query', uri, *images, '--json').stdout),
                           {'time_ms'}) for uri in (primary, standby)]
        check(queries[0] == queries[1] and all(q['verdict'] == 'known' for q in queries[1]),
              'query --json of three images: the standby answers as the primary '
              f'({[q["verdict"] for q in queries[1]]})')
        for uri, out in ((primary, 'p.g2o'), (standby, 's.g2o')):
            run(placedb, 'export', uri, w(out))
        with open(w('p.g2o'), 'rb') as p, open(w('s.g2o'), 'rb') as s:
            check(p.read() == s.read(), 'export: the standby\'s g2o file is the primary\'s')
        pages = []
        for uri, out in ((primary, 'report_p'), (standby, 'report_s')):
            run(placedb, 'report', uri, w('a.csv'), '--out', w(out))
            with open(os.path.join(w(out), 'index.html')) as f:
                pages.append(name(uri, f.read()))
        check(pages[0] == pages[1], 'report: the standby\'s page is the primary\'s')

        # 2. The office reads the standby while a robot writes the primary.
        robot = subprocess.Popen([placedb, 'map', primary, lip6, '--stop-after', '100', '-q'],
                                 stderr=subprocess.PIPE, text=True)
        reads = 0
        while robot.poll() is None or reads < 2:
            for args in (('query', standby, images[2]), ('info', standby)):
                run(placedb, *args)
                reads += 1
            time.sleep(0.5)  # the office reads now and then; the robot keeps the cores
        check(robot.wait() == 0, f'robot B mapped 100 frames into the primary meanwhile '
              f'{robot.stderr.read().strip()[-300:]}')
        check(reads >= 2, f'{reads} reads of the standby (query, info) while B mapped, each exit 0')
        caught_up(primary, standby)
        infos = [json.loads(name(uri, run(placedb, 'info', uri, '--json').stdout))
                 for uri in (primary, standby)]
        check(infos[0] == infos[1] and infos[1]['frames'] == 184,
              f'caught up again: the standby\'s info equals the primary\'s '
              f'({infos[1]["frames"]} frames)')

        # 3. Writing the standby: one clear line, exit 6.
        for args in (('map', standby, rtab), ('copy', w('none.placedb'), standby)):
            if args[0] == 'copy':
                run(placedb, 'map', w('none.placedb'), rtab, '--stop-after', '2', '-q')
            p = run(placedb, *args, expect=None)
            lines = p.stderr.strip().splitlines()
            check(p.returncode == 6 and len(lines) == 1 and 'hot standby' in lines[0] and
                  standby in lines[0], f'{args[0]} into the standby: exit {p.returncode} '
                  f'(expected 6), {lines}')

        # 4. Nothing tried to write the standby.
        with open(os.path.join(w('standby'), 'server.log')) as f:
            errors = [line.strip() for line in f if 'ERROR' in line]
        check(not errors, f'the standby\'s server log holds no error ({errors[:3]})')
    finally:
        for folder in ('standby', 'primary'):
            if os.path.isdir(w(folder)):
                subprocess.run(['bash', server, 'stop', w(folder), 'immediate'],
                               capture_output=True)
        shutil.rmtree(work, ignore_errors=True)
    print(f'{time.monotonic() - started:.1f} s; ' +
          (f'{len(FAILURES)} FAILED' if FAILURES else 'all passed'), flush=True)
    return 1 if FAILURES else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
