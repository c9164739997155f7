#!/usr/bin/env python3
"""Issue #24's fleet scenario, end to end on a PostgreSQL server of its own (the test stops and
restarts it, so it cannot share ctest's pg_server fixture):

1. Baselines in files: robot A maps lip6_outdoor frames 0-539; robot B (frames 540-1062) maps
   after it, one session after the other; robot C maps rtabmap_samples alone.
2. Fleet: A's map is copied to the server; B and C map it at the same time. B's closures onto
   A's places have no false one (window 10, the README's scoring) and are at least 95 % of the
   baseline's; C accepts no closure onto lip6 places and at least 40 of its own, all right;
   a second writer of B's session exits 5 while B runs; `query` finds B's and C's places.
3. B losing the server for 5 s with --server-wait 1 (exit 13, then resumed), then killed with
   SIGKILL at random points and resumed: the map holds every frame of B once, with the
   baseline's decisions (every frame row and hypothesis but the times, ids included).
4. The server stopped at once for 5 s during B (default --server-wait): B waits, goes on and
   ends with the baseline's decisions; its summary and its log count every frame once.

Exit 77 (ctest: skipped) with a message where the server binaries or the data sets are absent.
Usage: fleet_test.py PLACEDB WORK_DIR [--quick] [--seed N]
--quick maps B's first 200 frames only (the sanitizer build, where frames are slower).
"""
import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench",
                                "fleet"))
import scenario as fs  # noqa: E402

FAILURES = []


def check(ok, what):
    print(("ok      " if ok else "FAILED  ") + what, flush=True)
    if not ok:
        FAILURES.append(what)
    return ok


def start_map(binary, uri, source, log, *extra, quiet=True):
    return subprocess.Popen([binary, "map", uri, source, "--log", log, *(["-q"] if quiet else []),
                             *extra],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def finish(process, what, expected=0):
    err = process.communicate()[1]
    check(process.returncode == expected,
          f"{what}: exit {process.returncode} (expected {expected}) {err.strip()[-500:]}")
    return err


def run_to_end(binary, uri, source, log, rng, server, kills):
    """Maps `source` into `uri` to its end: first losing the server for 5 s with --server-wait 1
    (exit 13), then SIGKILLed `kills` times at random points; each time run again to resume."""
    killed, lost = 0, False
    for _ in range(kills + 10):
        p = start_map(binary, uri, source, log, "--server-wait", "1")
        if not lost:
            # Once B maps: a server that cannot be reached at B's start is exit 11 at once.
            fs.wait_for_frames(uri, 2, 5)
            time.sleep(rng.uniform(0.2, 1.0))
            server.stop()
            time.sleep(5)
            err = p.communicate()[1]
            server.start()
            lost = True
            check(p.returncode == 13 and "--server-wait" in err,
                  f"B without its server for 5 s, --server-wait 1: exit {p.returncode} "
                  f"(expected 13) {err.strip()[-300:]}")
            continue
        if killed < kills:
            try:
                p.wait(timeout=rng.uniform(0.5, 4.0))
            except subprocess.TimeoutExpired:
                p.send_signal(signal.SIGKILL)
                p.communicate()
                killed += 1
                # A kill that lands after B ended its session (the summary, the close) leaves
                # nothing to resume: a run now would begin a new session, and the log refuses it.
                if session_ended(uri, 2):
                    return killed, lost
                continue
        err = p.communicate()[1]
        if p.returncode == 5 and "busy" in err:
            time.sleep(0.5)  # the server has not yet seen the killed writer's connection go
            continue
        check(p.returncode == 0, f"resumed B: exit {p.returncode}: {err.strip()[-500:]}")
        return killed, lost
    check(False, "B did not finish")
    return killed, lost


def session_ended(uri, session):
    rows = fs.PgServer.sql(uri, f"SELECT ended_at IS NOT NULL FROM sessions WHERE id = {session}")
    return bool(rows) and rows[0][0] == "t"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("placedb")
    parser.add_argument("work")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--seed", type=int, default=int(time.time()) % 100000)
    args = parser.parse_args()
    if not fs.server_binaries_present():
        print("skip: PostgreSQL's server binaries are not installed (Debian package postgresql; "
              "scripts/install-deps.sh installs it)")
        return 77
    data = fs.datasets_dir()
    for name in ("lip6_outdoor", "rtabmap_samples"):
        if not os.path.isfile(os.path.join(data, name, "frames.txt")):
            print(f"skip: {name} absent under {data}")
            return 77
    started = time.time()
    rng = random.Random(args.seed)
    print(f"seed {args.seed} (--seed to repeat the kill points)")
    work = os.path.abspath(args.work)
    subprocess.run(["rm", "-rf", work], check=True)
    os.makedirs(work)
    lists = fs.robot_lists(work, data, b_end=740 if args.quick else None)
    b_frames = sum(1 for _ in open(lists["B"]))
    pb = args.placedb
    w = lambda name: os.path.join(work, name)  # noqa: E731

    # 1. Baselines in files.
    fs.placedb(pb, "map", w("a.placedb"), lists["A"], "-q")
    fs.copy_map(pb, w("a.placedb"), w("ab.placedb"))
    fs.placedb(pb, "map", w("ab.placedb"), lists["B"], "--log", w("ab_b.csv"), "-q")
    fs.placedb(pb, "map", w("c.placedb"), lists["C"], "--log", w("c.csv"), "-q")
    lip6_gt = fs.load_gt(os.path.join(data, "lip6_outdoor", "gt_pairs.txt"))
    samples_gt = fs.load_gt(os.path.join(data, "rtabmap_samples", "gt_pairs.txt"))
    base_b = fs.closures(fs.read_log(w("ab_b.csv")), lip6_gt, 10, 540, {1: 0})
    alone_c = fs.closures(fs.read_log(w("c.csv")), samples_gt, 10)
    baseline = fs.decisions_of_file(w("ab.placedb"), 2)
    print(f"baselines: B after A in a file {base_b}; C alone {alone_c}")
    check(base_b["cross"] > 0 and len(baseline) == b_frames, "the baselines mapped")

    # Under /tmp, as ctest's fixture does: the server's user must reach it.
    server = fs.PgServer(tempfile.mkdtemp(prefix="placedb-fleet-pg."))
    server.start()
    try:
        # 2. B and C at the same time on A's map.
        fleet = server.database("fleet")
        fs.copy_map(pb, w("a.placedb"), fleet)
        b = start_map(pb, fleet, lists["B"], w("fleet_b.csv"))
        fs.wait_for_session(fleet, 2)  # B begins first: it continues the main line
        c = start_map(pb, fleet, lists["C"], w("fleet_c.csv"))
        second = subprocess.run([pb, "map", fleet, lists["B"], "-q"], capture_output=True,
                                text=True)
        check(second.returncode == 5 and "busy" in second.stderr,
              f"a second writer of B's session: exit {second.returncode} (expected 5) "
              f"{second.stderr.strip()[-300:]}")
        finish(b, "B in the fleet")
        finish(c, "C in the fleet")
        fleet_b = fs.closures(fs.read_log(w("fleet_b.csv")), lip6_gt, 10, 540, {1: 0})
        fleet_c = fs.closures(fs.read_log(w("fleet_c.csv")), samples_gt, 10)
        print(f"fleet: B {fleet_b}; C {fleet_c}")
        check(fleet_b["cross"] == fleet_b["cross_right"],
              f"B's closures onto A's places are all right ({fleet_b['cross_right']} of "
              f"{fleet_b['cross']})")
        check(fleet_b["cross"] >= 0.95 * base_b["cross"],
              f"B closes {fleet_b['cross']} times onto A's places, at least 95 % of the "
              f"{base_b['cross']} one after the other in a file")
        check(fleet_b["foreign"] == 0, "B accepts no closure onto C's places")
        check(fleet_c["cross"] + fleet_c["foreign"] == 0, "C accepts no closure onto lip6 places")
        check(fleet_c["own"] >= 40 and fleet_c["own_right"] == fleet_c["own"],
              f"C accepts {fleet_c['own']} closures of its own, all right (alone: "
              f"{alone_c['own']}; at least 40)")
        images_b = [line.strip() for line in open(lists["B"])]
        images_c = [line.strip() for line in open(lists["C"])]
        answers = json.loads(fs.placedb(pb, "query", fleet, images_b[100], images_c[47],
                                        "--json").stdout)
        for answer, sessions, who in zip(answers, ({1, 2}, {3}), ("B", "C")):
            found = {f["session"] for m in answer["matches"][:1] for f in m["frames"]}
            check(answer["verdict"] == "known" and found and found <= sessions,
                  f"query on the shared map finds {who}'s place (sessions {sorted(found)})")

        # 3. B killed at random points and resumed, and once without its server.
        killed_uri = server.database("killed")
        fs.copy_map(pb, w("a.placedb"), killed_uri)
        kills, lost = run_to_end(pb, killed_uri, lists["B"], w("killed_b.csv"), rng, server, 3)
        got = fs.decisions_of_server(killed_uri, 2)
        indices = [row[0] for row in got]
        check(len(got) == b_frames and len(set(indices)) == b_frames,
              f"after {kills} kills and a lost server, B's session holds every frame once "
              f"({len(got)} rows, {len(set(indices))} distinct)")
        check(got == baseline, "and the decisions of an uninterrupted B (every frame and "
              "hypothesis column but the times)" + describe_difference(got, baseline))
        logged = [int(row["frame"]) for row in fs.read_log(w("killed_b.csv"))]
        check(logged == list(range(b_frames)),
              f"and B's log holds each frame once, in order ({len(logged)} rows): a row a kill "
              "took between the frame's commit and its write is written back from the map")

        # 4. The server stopped for 5 s during B, at once (its last commits, not yet flushed
        # under synchronous_commit = off, are lost): B waits, goes on, maps the lost frames again.
        waited_uri = server.database("waited")
        fs.copy_map(pb, w("a.placedb"), waited_uri)
        p = start_map(pb, waited_uri, lists["B"], w("waited_b.csv"), quiet=False)
        fs.wait_for_frames(waited_uri, 2, 5)
        time.sleep(rng.uniform(0.2, 2.0))
        server.stop("immediate")
        time.sleep(5)
        server.start()
        err = finish(p, "B over a 5 s server stop")
        check("waiting up to 60 s" in err and "goes on from frame" in err,
              "B waited for the server and went on")
        got = fs.decisions_of_server(waited_uri, 2)
        check(got == baseline, "B's decisions after the wait are an uninterrupted B's" +
              describe_difference(got, baseline))
        summary = [line for line in err.splitlines() if line.startswith("placedb: session 2:")]
        check(len(summary) == 1 and f": {b_frames} frames (" in summary[0],
              f"B's summary counts each of its {b_frames} frames once: {summary}")
        logged = [int(row["frame"]) for row in fs.read_log(w("waited_b.csv"))]
        check(sorted(logged) == list(range(b_frames)) == logged,
              f"B's log holds each frame once, in order ({len(logged)} rows)")
    finally:
        server.stop("immediate")
        shutil.rmtree(server.folder, ignore_errors=True)
    print(f"fleet test: {time.time() - started:.0f} s, {len(FAILURES)} failed")
    return 1 if FAILURES else 0


def describe_difference(got, expected):
    if got == expected:
        return ""
    for a, b in zip(got, expected):
        if a != b:
            return f"; first difference: {a} against {b}"
    return f"; {len(got)} rows against {len(expected)}"


if __name__ == "__main__":
    sys.exit(main())
