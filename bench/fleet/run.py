#!/usr/bin/env python3
"""bench/fleet: 1, 2, 4 and 8 robots writing one map on a PostgreSQL server at once, against the
same robots one after the other in one SQLite file (a file has one writer).

Every robot starts from robot A's map (lip6_outdoor frames 0-539, mapped once into a file and
copied to each run's map). The robots:
  1 writer : B   (lip6_outdoor frames 540-1062)
  2 writers: B, C (rtabmap_samples)
  4 writers: B1 (lip6 540-800), B2 (lip6 801-1062), C, D (lip6_outdoor_160x128 frames 540-1062,
             another camera on B's route)
  8 writers: B1-B4 (lip6 540-670, 671-800, 801-931, 932-1062), C, D1 and D2
             (lip6_outdoor_160x128 540-800, 801-1062), E (lip6_outdoor_120x96 540-1062, a third
             camera on B's route)
Printed per configuration and backend: frames, wall time, aggregate frames per second, per-frame
time p50/p99 and storage time mean (from the --log of every robot), the server's CPU time per
frame (its processes, from /proc), cross-robot closures (onto another session's places; those
of lip6 robots scored against lip6's ground truth, window 10, a closure between two robots on
the same stretch of the route counting as right within 10 frames), closures of rtabmap_samples'
robot onto lip6 places or the reverse ("onto another place", which must be 0), and `placedb
query` p50 over 5 images of each robot (time_ms of its --json) on the map they leave.

Usage: bench/fleet/run.py [--build BUILD] [--datasets DIR] [--work DIR] [--writers 1,2,4,8]
                         [--maps server,file]
BUILD may be any build of placedb (another commit's, to compare): only its tools/placedb is run.
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scenario as fs  # noqa: E402


def percentile(values, p):
    values = sorted(values)
    return values[min(len(values) - 1, max(0, round(p / 100 * (len(values) - 1))))]


def robots(work, data, writers):
    lip6 = os.path.join(data, "lip6_outdoor")
    small = os.path.join(data, "lip6_outdoor_160x128")
    samples = os.path.join(data, "rtabmap_samples")
    out = lambda name: os.path.join(work, name + ".txt")  # noqa: E731
    # name: (list, offset of its frame 0 in lip6's numbering, or None for another place)
    if writers == 1:
        return {"B": (fs.write_list(out("B"), lip6, 540, 1063), 540)}
    if writers == 2:
        return {"B": (fs.write_list(out("B"), lip6, 540, 1063), 540),
                "C": (fs.write_list(out("C"), samples, 0, 10**9), None)}
    if writers == 4:
        return {"B1": (fs.write_list(out("B1"), lip6, 540, 801), 540),
                "B2": (fs.write_list(out("B2"), lip6, 801, 1063), 801),
                "C": (fs.write_list(out("C"), samples, 0, 10**9), None),
                "D": (fs.write_list(out("D"), small, 540, 1063), 540)}
    if writers != 8:
        raise SystemExit(f"--writers: 1, 2, 4 or 8, not {writers}")
    # As 4, each lip6 stretch split once more, and a third camera on B's route.
    smaller = os.path.join(data, "lip6_outdoor_120x96")
    return {"B1": (fs.write_list(out("B1"), lip6, 540, 671), 540),
            "B2": (fs.write_list(out("B2"), lip6, 671, 801), 671),
            "B3": (fs.write_list(out("B3"), lip6, 801, 932), 801),
            "B4": (fs.write_list(out("B4"), lip6, 932, 1063), 932),
            "C": (fs.write_list(out("C"), samples, 0, 10**9), None),
            "D1": (fs.write_list(out("D1"), small, 540, 801), 540),
            "D2": (fs.write_list(out("D2"), small, 801, 1063), 801),
            "E": (fs.write_list(out("E"), smaller, 540, 1063), 540)}


def run_robots(pb, map_uri, team, work, tag, at_once):
    """Maps every robot of `team` into map_uri; at once (a server) or one after the other."""
    logs, started = {}, time.time()
    if at_once:
        processes = []
        for k, (name, (source, _)) in enumerate(team.items()):
            logs[name] = os.path.join(work, f"{tag}_{name}.csv")
            processes.append(subprocess.Popen([pb, "map", map_uri, source, "--log", logs[name],
                                               "-q"], stderr=subprocess.PIPE, text=True))
            if k == 0:
                fs.wait_for_session(map_uri, 2)  # the first continues the main line
        for p in processes:
            err = p.communicate()[1]
            if p.returncode != 0:
                raise RuntimeError(f"map exited {p.returncode}: {err[-1000:]}")
    else:
        for name, (source, _) in team.items():
            logs[name] = os.path.join(work, f"{tag}_{name}.csv")
            fs.placedb(pb, "map", map_uri, source, "--log", logs[name], "-q")
    return logs, time.time() - started


def figures(pb, map_uri, team, logs, wall, gt):
    rows = {name: fs.read_log(path) for name, path in logs.items()}
    times = [float(r["time_ms"]) for rs in rows.values() for r in rs]
    storage = [float(r["storage_ms"]) for rs in rows.values() for r in rs]
    frames = len(times)
    sessions = {}  # session -> lip6 offset of its frame 0
    for name, rs in rows.items():
        if rs and team[name][1] is not None:
            sessions[int(rs[0]["session"])] = team[name][1]
    sessions[1] = 0  # robot A
    cross = right = wrong_place = 0
    for name, rs in rows.items():
        offset = team[name][1]
        own = int(rs[0]["session"])
        got = fs.closures(rs, gt if offset is not None else {}, 10, offset or 0,
                          {s: o for s, o in sessions.items() if s != own} if offset is not None
                          else {}, same_route=True)
        if offset is None:
            wrong_place += got["cross"] + got["foreign"]  # another place's robot onto lip6
        else:
            cross += got["cross"]
            right += got["cross_right"]
            wrong_place += got["foreign"]
    images = []
    for name, (source, _) in team.items():
        lines = [line.strip() for line in open(source)]
        images += [lines[k] for k in range(10, len(lines), max(1, len(lines) // 5))][:5]
    started = time.time()
    answers = json.loads(fs.placedb(pb, "query", map_uri, *images[:20], "--json").stdout)
    query_wall = time.time() - started
    query_ms = [a["time_ms"] for a in answers]
    known = sum(a["verdict"] == "known" for a in answers)
    return {"frames": frames, "wall_s": wall, "fps": frames / wall,
            "p50": percentile(times, 50), "p99": percentile(times, 99),
            "storage": statistics.mean(storage), "cross": cross, "cross_right": right,
            "wrong_place": wrong_place, "query_p50": percentile(query_ms, 50),
            "query_known": f"{known}/{len(answers)}", "query_wall": query_wall}


def main():
    root = fs.ROOT
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default=os.path.join(root, "build"))
    parser.add_argument("--datasets", default=None)
    parser.add_argument("--work", default=None)
    parser.add_argument("--writers", default="1,2,4,8")
    parser.add_argument("--maps", default="server,file",
                        help="which maps each configuration writes: server, file or both")
    args = parser.parse_args()
    maps = args.maps.split(",")
    if not maps or any(m not in ("server", "file") for m in maps):
        raise SystemExit(f"--maps: server, file or server,file, not {args.maps}")
    pb = os.path.join(os.path.abspath(args.build), "tools", "placedb")
    data = fs.datasets_dir(args.datasets)
    work = args.work or tempfile.mkdtemp(prefix="placedb-fleet-bench.")
    os.makedirs(work, exist_ok=True)
    base = os.path.join(work, "a.placedb")
    if not os.path.exists(base):
        a_list = fs.write_list(os.path.join(work, "A.txt"), os.path.join(data, "lip6_outdoor"),
                               *fs.A_FRAMES)
        fs.placedb(pb, "map", base, a_list, "-q")
    gt = fs.load_gt(os.path.join(data, "lip6_outdoor", "gt_pairs.txt"))
    server = fs.PgServer(tempfile.mkdtemp(prefix="placedb-fleet-bench-pg."))
    server.start()
    results = []
    try:
        for writers in [int(w) for w in args.writers.split(",")]:
            team = robots(work, data, writers)
            if "server" in maps:
                uri = server.database(f"fleet{writers}")
                fs.copy_map(pb, base, uri)
                cpu = fs.server_cpu_seconds(server.folder)
                logs, wall = run_robots(pb, uri, team, work, f"pg{writers}", True)
                cpu = fs.server_cpu_seconds(server.folder) - cpu
                f = figures(pb, uri, team, logs, wall, gt)
                f["server_cpu_ms"] = 1000 * cpu / f["frames"]
                results.append((writers, "server", f))
            if "file" not in maps:
                print(f"{writers} writers done", file=sys.stderr, flush=True)
                continue
            path = os.path.join(work, f"file{writers}.placedb")
            for stale in (path, path + "-wal", path + "-shm", path + "-lock"):
                if os.path.exists(stale):
                    os.remove(stale)
            fs.copy_map(pb, base, path)
            logs, wall = run_robots(pb, path, team, work, f"file{writers}", False)
            f = figures(pb, path, team, logs, wall, gt)
            f["server_cpu_ms"] = 0.0
            results.append((writers, "file", f))
            print(f"{writers} writers done", file=sys.stderr, flush=True)
    finally:
        server.stop("immediate")
        shutil.rmtree(server.folder, ignore_errors=True)
    print("| writers | map | frames | wall s | frames/s | frame ms p50 / p99 | storage ms mean | "
          "server CPU ms/frame | cross-robot closures (right) | onto another place | "
          "query ms p50 (known) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for writers, kind, f in results:
        print(f"| {writers} | {kind} | {f['frames']} | {f['wall_s']:.1f} | {f['fps']:.1f} | "
              f"{f['p50']:.1f} / {f['p99']:.1f} | {f['storage']:.2f} | "
              f"{f['server_cpu_ms']:.1f} | {f['cross']} ({f['cross_right']}) | "
              f"{f['wrong_place']} | {f['query_p50']:.1f} ({f['query_known']}) |")
    print(f"work folder: {work}")


if __name__ == "__main__":
    sys.exit(main())
