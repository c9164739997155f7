#!/usr/bin/env python3
"""Runs the README's command blocks as printed, so that a newcomer's first commands work.

  readme_commands.py tour PLACEDB DATASETS WORK
      The five-minute tour's block, line for line through bash, from a folder laid out as a
      checkout after scripts/test.sh (build/tools/ holding PLACEDB) with ../shared/datasets/
      beside it, and a PATH without placedb: the block itself must make `placedb` callable. Its
      lip6_outdoor is the first 40 frames of the real one, so that the tour takes seconds. Also:
      the intro's word on memory agrees with the defaults `placedb settings` gives, and
      docs/datasets.md gives a source and licence for every data set.
  readme_commands.py fleet PLACEDB DATASETS WORK PG_STATE
      The fleet block against ctest's scratch PostgreSQL server (PG_STATE holds its URI; its
      folder takes the place of /tmp/fleet, the only change): the server line, the `map` line run
      by two robots at the same instant (rtabmap_samples' two halves), the `query` line from the
      office and the `copy` line uploading a map made offline.

Exit 77 (ctest: skipped) with a message where a data set or the server is absent.
"""
import json
import os
import re
import shutil
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def fail(message):
    print("FAILED  " + message, flush=True)
    sys.exit(1)


def skip(message):
    print("skip: " + message, flush=True)
    sys.exit(77)


def readme_block(heading):
    """The first indented (4 spaces) code block after `heading` in README.md, as lines."""
    lines = open(os.path.join(ROOT, "README.md"), encoding="utf-8").read().splitlines()
    if heading not in lines:
        fail(f"README.md has no heading {heading!r}")
    block = []
    for line in lines[lines.index(heading) + 1:]:
        if line.startswith("    "):
            block.append(line[4:])
        elif block:
            break
    if not block:
        fail(f"README.md has no command block under {heading!r}")
    return block


def path_without_placedb():
    """PATH without any folder that holds a placedb: the README's lines must provide it."""
    folders = os.environ.get("PATH", "").split(":")
    return ":".join(f for f in folders if f and not os.path.exists(os.path.join(f, "placedb")))


def run(script, cwd, path):
    env = dict(os.environ, PATH=path)
    return subprocess.run(["bash", "-c", "set -euo pipefail\n" + script], cwd=cwd, env=env,
                          capture_output=True, text=True)


def list_of(dataset, first, count, out):
    with open(os.path.join(dataset, "frames.txt")) as f:
        names = [line.strip() for line in f if line.strip()][first:first + count]
    os.makedirs(os.path.dirname(out), exist_ok=True)
    with open(out, "w") as f:
        f.writelines(os.path.join(dataset, name) + "\n" for name in names)
    return [os.path.join(dataset, name) for name in names]


def fresh(work):
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)


def tour(placedb, datasets, work):
    lip6 = os.path.join(datasets, "lip6_outdoor")
    if not os.path.isfile(os.path.join(lip6, "frames.txt")):
        skip(f"lip6_outdoor absent under {datasets}")
    fresh(work)
    checkout = os.path.join(work, "checkout")
    os.makedirs(os.path.join(checkout, "build"))
    os.symlink(os.path.dirname(os.path.abspath(placedb)), os.path.join(checkout, "build", "tools"))
    images = list_of(lip6, 0, 40, os.path.join(work, "shared", "datasets", "lip6_outdoor",
                                               "frames.txt"))
    shutil.copy(images[20], os.path.join(checkout, "photo.jpg"))
    block = readme_block("## A five-minute tour")
    r = run("\n".join(block), checkout, path_without_placedb())
    if r.returncode != 0:
        fail("the tour's commands as printed: exit %d\n%s%s" % (r.returncode, r.stdout, r.stderr))
    for made in ("run.placedb", "run.csv", os.path.join("report", "index.html")):
        if not os.path.exists(os.path.join(checkout, made)):
            fail(f"the tour made no {made}")
    print(f"ok      the tour's {len(block)} lines run as printed, placedb not on PATH before")

    # The intro says what the defaults are.
    settings = {s["key"]: s["default"] for s in json.loads(subprocess.run(
        [placedb, "settings", "--json"], capture_output=True, text=True, check=True).stdout)}
    intro = open(os.path.join(ROOT, "README.md"), encoding="utf-8").read().split("\n## ")[0]
    intro = " ".join(intro.split())
    unbounded = settings["wm_max"] == "0" and settings["t_time_ms"] == "0"
    says_unbounded = "unbounded by default" in intro
    if unbounded != says_unbounded or "`--set wm_max=" not in intro:
        fail(f"README's intro and the defaults disagree: wm_max {settings['wm_max']}, t_time_ms "
             f"{settings['t_time_ms']}; the intro says 'unbounded by default': {says_unbounded}, "
             "and must show how to bound it (`--set wm_max=...`)")
    print("ok      the intro says what the defaults do (memory unbounded) and how to bound it")

    # Every data set has a source and a licence in docs/datasets.md.
    page = open(os.path.join(ROOT, "docs", "datasets.md"), encoding="utf-8").read()
    names = set(re.findall(r"shared/datasets/([a-z0-9_]+)", open(
        os.path.join(ROOT, "README.md"), encoding="utf-8").read()))
    if os.path.isdir(datasets):
        names |= {d for d in os.listdir(datasets) if os.path.isdir(os.path.join(datasets, d))}
    for name in sorted(names):
        row = re.search(r"^\| `%s` \|([^\n]*)\|([^|\n]+)\|$" % re.escape(name), page, re.M)
        if not row or not row.group(2).strip():
            fail(f"docs/datasets.md has no row with the source and licence of {name}")
    print(f"ok      docs/datasets.md gives a source and licence for {', '.join(sorted(names))}")


def fleet(placedb, datasets, work, state):
    line = open(state).read().strip() if os.path.exists(state) else ""
    if not line.startswith("postgresql://"):
        skip(f"no PostgreSQL server: {line or 'run through ctest'}")
    server_dir = re.search(r"host=([^&]+)", line).group(1)
    samples = os.path.join(datasets, "rtabmap_samples")
    if not os.path.isfile(os.path.join(samples, "frames.txt")):
        skip(f"rtabmap_samples absent under {datasets}")
    block = readme_block("### A fleet map")
    lines = {}
    for role, marker in (("server", "pg-server.sh start"), ("map", "placedb map"),
                         ("query", "placedb query"), ("copy", "placedb copy")):
        # The office's query of a read replica is the standby test's (tests/cli, standby).
        found = [text for text in block if marker in text and "standby" not in text]
        if len(found) != 1:
            fail(f"README's fleet block has {len(found)} lines with {marker!r}, expected 1")
        # Its trailing comment goes (a robot's line runs inside parentheses here).
        lines[role] = re.sub(r"\s+#\s.*$", "", found[0]).replace("/tmp/fleet", server_dir)
    # The block names new databases: a second run of this test starts them afresh.
    for db in re.findall(r"pg-server\.sh (?:start|createdb) \S+ (\w+)", "\n".join(block)):
        subprocess.run(["psql", line, "-XAtqc", f"DROP DATABASE IF EXISTS {db} WITH (FORCE)"],
                       check=True, capture_output=True)

    # The office is a checkout (scripts/ for the server lines) holding a map made offline and
    # a photo; each robot runs in a folder of its own with its own frames.
    fresh(work)
    office = os.path.join(work, "office")
    os.makedirs(office)
    os.symlink(os.path.join(ROOT, "scripts"), os.path.join(office, "scripts"))
    list_of(samples, 0, 42, os.path.join(work, "robot_a", "frames.txt"))
    robot_b = list_of(samples, 42, 42, os.path.join(work, "robot_b", "frames.txt"))
    shutil.copy(robot_b[10], os.path.join(office, "photo.jpg"))
    list_of(samples, 0, 10, os.path.join(office, "offline.txt"))
    path = os.path.dirname(os.path.abspath(placedb)) + ":" + path_without_placedb()
    offline = run("placedb map run.placedb offline.txt -q", office, path)
    if offline.returncode != 0:
        fail("the offline map: " + offline.stderr)

    script = f"""
cd office
{lines['server']}
# Two robots at the same instant, each in its own folder.
( cd ../robot_a && {lines['map']} ) >../robot_a/out.txt 2>&1 & a=$!
( cd ../robot_b && {lines['map']} ) >../robot_b/out.txt 2>&1 & b=$!
status=0
wait $a || status=1
wait $b || status=1
if [[ $status != 0 ]]; then cat ../robot_a/out.txt ../robot_b/out.txt; exit 1; fi
{lines['query']}
{lines['copy']}
echo "fleet=$uri"
"""
    r = run(script, work, path)
    if r.returncode != 0:
        fail("the README's fleet lines as printed: exit %d\n%s%s" % (r.returncode, r.stdout,
                                                                     r.stderr))
    if "known place" not in r.stdout:
        fail("the office's query did not find the place:\n" + r.stdout)
    uri = re.search(r"^fleet=(.*)$", r.stdout, re.M).group(1)
    info = json.loads(subprocess.run([placedb, "info", "--json", uri], capture_output=True,
                                     text=True, check=True).stdout)
    if info["frames"] != 84 or len(info["sessions"]) != 2:
        fail(f"the fleet map holds {info['frames']} frames in {len(info['sessions'])} sessions, "
             "expected both robots' 84 in 2")
    copied = re.search(r"createdb \S+ (\w+)", lines["copy"]).group(1)
    uploaded = json.loads(subprocess.run(
        [placedb, "info", "--json", line.replace("/placedb?", f"/{copied}?")],
        capture_output=True, text=True, check=True).stdout)
    if uploaded["frames"] != 10:
        fail(f"the upload holds {uploaded['frames']} frames, expected the offline map's 10")
    for robot in ("robot_a", "robot_b"):
        out = open(os.path.join(work, robot, "out.txt")).read().splitlines()
        waited = any("waiting up to" in text for text in out)
        print(f"{robot}: {'waited for the first place; ' if waited else ''}{out[-1]}")
    print("ok      the README's fleet lines run as printed: two robots at once, the office's "
          "query, the upload into a new database")


def main(argv):
    if len(argv) >= 5 and argv[1] == "tour":
        tour(argv[2], argv[3], argv[4])
    elif len(argv) >= 6 and argv[1] == "fleet":
        fleet(argv[2], argv[3], argv[4], argv[5])
    else:
        print(__doc__, file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
