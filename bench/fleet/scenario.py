"""The fleet scenario of issue #24, in pieces shared by bench/fleet/run.py and the ctest
tests/cli/fleet_test.py: robot A maps lip6_outdoor frames 0-539; then robot B (frames 540-1062)
and robot C (rtabmap_samples) map the same server map at the same time.

Pieces: list files of the robots' frames, a scratch PostgreSQL server (scripts/pg-server.sh),
`placedb` runs, the scoring of closures across sessions against a sequence's ground truth (the
rule of ../shared/tools/score_loops.py: a hypothesis is right when one of its candidate frames
lies within W frames of a ground-truth reference), and a map's per-frame decisions read back from
a file or a server, to compare two maps row by row.
"""
import csv
import os
import shutil
import sqlite3
import subprocess
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PG_SERVER = os.path.join(ROOT, "scripts", "pg-server.sh")

A_FRAMES = (0, 540)  # lip6_outdoor frames [first, end) of robot A
B_FRAMES = (540, 1063)  # and of robot B


def datasets_dir(given=None):
    return given or os.environ.get("PLACEDB_DATASETS") or os.path.join(ROOT, "..", "shared",
                                                                       "datasets")


def server_binaries_present():
    if os.environ.get("PG_BIN"):
        return True
    base = "/usr/lib/postgresql"
    return os.path.isdir(base) and any(
        os.path.exists(os.path.join(base, v, "bin", "initdb")) for v in os.listdir(base))


def write_list(path, folder, first, end):
    """Frames [first, end) of folder/frames.txt as absolute paths, one a line."""
    with open(os.path.join(folder, "frames.txt")) as f:
        names = [line.strip() for line in f if line.strip() and not line.startswith("#")]
    with open(path, "w") as out:
        for name in names[first:min(end, len(names))]:
            out.write(os.path.join(os.path.abspath(folder), name) + "\n")
    return path


def robot_lists(work, datasets, b_end=None):
    """A's, B's and C's list files in `work`; b_end shortens B (a quicker run)."""
    lip6 = os.path.join(datasets, "lip6_outdoor")
    samples = os.path.join(datasets, "rtabmap_samples")
    return {
        "A": write_list(os.path.join(work, "A.txt"), lip6, *A_FRAMES),
        "B": write_list(os.path.join(work, "B.txt"), lip6, B_FRAMES[0], b_end or B_FRAMES[1]),
        "C": write_list(os.path.join(work, "C.txt"), samples, 0, 10**9),
    }


def placedb(binary, *args, check=True, **kwargs):
    result = subprocess.run([binary, *args], capture_output=True, text=True, **kwargs)
    if check and result.returncode != 0:
        raise RuntimeError(f"placedb {' '.join(args)} exited {result.returncode}: "
                           f"{result.stderr.strip()[-2000:]}")
    return result


class PgServer:
    """A throwaway server in `folder` (scripts/pg-server.sh), one database per map."""

    def __init__(self, folder):
        self.folder = folder
        self.base = None

    def start(self):
        self.base = subprocess.run(["bash", PG_SERVER, "start", self.folder], check=True,
                                   capture_output=True, text=True).stdout.strip()
        return self.base

    def stop(self, mode="fast"):
        subprocess.run(["bash", PG_SERVER, "stop", self.folder, mode], check=True,
                       capture_output=True, text=True)

    def database(self, name):
        """A fresh empty database; its map URI."""
        self.sql(self.base, f"DROP DATABASE IF EXISTS {name} WITH (FORCE)")
        self.sql(self.base, f"CREATE DATABASE {name}")
        return self.base.replace("/placedb?", f"/{name}?")

    @staticmethod
    def sql(uri, statement):
        """Rows of one statement, as lists of text (NULL as None)."""
        out = subprocess.run(["psql", uri, "-XAtq", "-F", "\x1f", "-R", "\x1e", "-P",
                              "null=\x1d", "-c", statement], check=True, capture_output=True,
                             text=True).stdout
        rows = []
        for line in out.rstrip("\n").split("\x1e"):
            if line.strip("\n"):
                rows.append([None if v == "\x1d" else v for v in line.strip("\n").split("\x1f")])
        return rows


def load_gt(path):
    gt = {}
    with open(path) as f:
        for line in f:
            line = line.split("#", 1)[0].split()
            if len(line) >= 2:
                gt.setdefault(int(line[0]), set()).add(int(line[1]))
    return gt


def read_log(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def closures(log_rows, gt, window, frame_offset=0, session_offsets=None, same_route=False):
    """The accepted closures of one robot's log: those onto its own session, those onto the
    sessions of `session_offsets` ({session: offset of its frame 0 in the ground truth's
    numbering}), scored against `gt` (its frames numbered from frame_offset), and those onto any
    other session. Every accepted row counts once. A closure is right by score_loops.py's rule:
    a candidate frame within `window` of a ground-truth reference of the frame. With same_route
    (robots that drive the same route at once), also when the candidate is within `window` of
    the frame itself or the frame of a reference of the candidate: the ground truth lists only
    revisits (q > r) of one camera."""
    session_offsets = session_offsets or {}

    def right(q, candidates):
        if any(abs(c - r) <= window for c in candidates for r in gt.get(q, ())):
            return True
        return same_route and any(abs(c - q) <= window or
                                  any(abs(q - r) <= window for r in gt.get(c, ()))
                                  for c in candidates)
    out = {"accepted": 0, "own": 0, "own_right": 0, "cross": 0, "cross_right": 0, "foreign": 0}
    for row in log_rows:
        if row["accepted"] != "1":
            continue
        out["accepted"] += 1
        q = frame_offset + int(row["frame"])
        others = [tuple(int(v) for v in c.split(":")) for c in row["other_candidates"].split()]
        if others:
            known = [session_offsets[s] + i for s, i in others if s in session_offsets]
            if not known:
                out["foreign"] += 1
                continue
            out["cross"] += 1
            out["cross_right"] += right(q, known)
        else:
            own = [frame_offset + int(c) for c in row["candidate_frames"].split()]
            out["own"] += 1
            out["own_right"] += right(q, own)
    return out


DECISION_SQL = (
    "SELECT f.source_index, f.outcome, f.location_id, f.feature_count, f.words_created, "
    "f.vocabulary_size, f.wm_size, f.stm_size, f.mean_quantisation_error, h.best_location_id, "
    "h.posterior, h.loop_probability, h.accepted, h.rejected_reason FROM frames f "
    "LEFT JOIN hypotheses h ON h.frame_id = f.id WHERE f.session_id = {session} "
    "ORDER BY f.source_index, f.id")
REAL_COLUMNS = (8, 10, 11)


def _normalise(rows):
    out = []
    for row in rows:
        row = list(row)
        for i, v in enumerate(row):
            if v is None:
                continue
            row[i] = float(v) if i in REAL_COLUMNS else (v if isinstance(v, str) and i == 13
                                                          else int(v))
        out.append(tuple(row))
    return out


def decisions_of_file(path, session):
    """Every frame of `session` in a map file with its decision, by source index."""
    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as db:
        return _normalise(db.execute(DECISION_SQL.format(session=int(session))).fetchall())


def decisions_of_server(uri, session):
    return _normalise(PgServer.sql(uri, DECISION_SQL.format(session=int(session))))


def session_of(binary, map_path, source_list):
    """The id of the newest session over a list file (placedb info --json)."""
    import json
    info = json.loads(placedb(binary, "info", "--json", map_path).stdout)
    ids = [s["id"] for s in info["sessions"] if os.path.samefile(s["source"], source_list)]
    return ids[-1] if ids else None


def copy_map(binary, source, destination):
    if destination.startswith("postgres"):
        placedb(binary, "copy", source, destination)
    else:
        shutil.copyfile(source, destination)


def server_cpu_seconds(folder):
    """CPU time the server in `folder` used so far: the postmaster, its live children and those
    it has reaped (each connection's backend is a child process)."""
    tick = os.sysconf("SC_CLK_TCK")
    with open(os.path.join(folder, "data", "postmaster.pid")) as f:
        postmaster = int(f.readline())

    def times(pid):
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return int(fields[1]), [int(v) for v in fields[11:15]]  # ppid; utime stime cutime cstime

    total = sum(times(postmaster)[1])
    for pid in os.listdir("/proc"):
        if pid.isdigit():
            try:
                ppid, t = times(pid)
            except (OSError, IndexError):
                continue
            if ppid == postmaster:
                total += t[0] + t[1]
    return total / tick


def wait_for_frames(server_uri_of_map, session, count, timeout=300):
    """Waits until `session` of the map holds `count` frames (its writer is under way)."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        rows = PgServer.sql(server_uri_of_map,
                            f"SELECT count(*) FROM frames WHERE session_id = {int(session)}")
        if int(rows[0][0]) >= count:
            return
        time.sleep(0.05)
    raise RuntimeError(f"session {session} has no {count} frames after {timeout} s")


def wait_for_session(server_uri_of_map, count, timeout=60):
    """Waits until the map holds `count` sessions (another writer has begun)."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        rows = PgServer.sql(server_uri_of_map, "SELECT count(*) FROM sessions")
        if int(rows[0][0]) >= count:
            return
        time.sleep(0.05)
    raise RuntimeError(f"no session {count} after {timeout} s")
