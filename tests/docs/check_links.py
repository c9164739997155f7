#!/usr/bin/env python3
"""Fails when a relative Markdown link of the repository points nowhere.

Scans every tracked *.md file (`git ls-files '*.md'` from the repository root, or a walk of
the tree where git is absent), finds links `[text](target)` and images `![alt](target)` whose
target is relative (not http:, https:, mailto:), and checks that the target exists relative to
the file and, for `path#anchor` or `#anchor`, that the target Markdown file has a heading with
that GitHub-style slug. Links to ../shared/... (outside the repository) may be missing.
Run from anywhere; exit 0 when every link resolves, 1 listing file:line target.
"""
import os
import re
import subprocess
import sys

LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^ {0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
FENCE = re.compile(r"^ {0,3}(```|~~~)")
SKIP_DIRS = {".git", "build"}


def markdown_files(root):
    try:
        out = subprocess.run(["git", "ls-files", "*.md"], cwd=root, capture_output=True,
                             text=True, check=True).stdout
        files = [f for f in out.splitlines() if f]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for dirpath, dirnames, filenames in os.walk(root):
            dirnames[:] = [d for d in dirnames
                           if d not in SKIP_DIRS and not d.startswith("build")]
            for name in filenames:
                if name.endswith(".md"):
                    files.append(os.path.relpath(os.path.join(dirpath, name), root))
    return sorted(f for f in files
                  if not f.startswith(("build/", "build-")) and "/../" not in f)


def slug(heading):
    """GitHub's anchor for a heading: lowercase, markup and punctuation dropped, spaces to '-'."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link keeps its text
    text = text.replace("`", "").lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def lines_outside_code(path):
    """(line number, text) of every line not inside a fenced code block."""
    with open(path, encoding="utf-8") as f:
        fenced = False
        for number, line in enumerate(f, 1):
            if FENCE.match(line):
                fenced = not fenced
                continue
            if not fenced:
                yield number, line


_anchor_cache = {}


def anchors(path):
    if path not in _anchor_cache:
        found, seen = set(), {}
        for _, line in lines_outside_code(path):
            m = HEADING.match(line)
            if not m:
                continue
            base = slug(m.group(2))
            n = seen.get(base, 0)
            seen[base] = n + 1
            found.add(base if n == 0 else f"{base}-{n}")
        _anchor_cache[path] = found
    return _anchor_cache[path]


def external(target):
    return re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target) is not None  # http:, https:, mailto:


def check(root):
    broken = []
    for rel in markdown_files(root):
        path = os.path.join(root, rel)
        if not os.path.isfile(path):
            continue
        for number, line in lines_outside_code(path):
            line = re.sub(r"`[^`]*`", lambda m: " " * len(m.group(0)), line)  # code spans
            for m in LINK.finditer(line):
                target = m.group(1)
                if external(target):
                    continue
                file_part, _, anchor = target.partition("#")
                resolved = os.path.normpath(os.path.join(os.path.dirname(path), file_part))
                outside = os.path.relpath(resolved, root).startswith("..")
                if file_part and not os.path.exists(resolved):
                    if not outside:  # ../shared/... lies beside the checkout and may be absent
                        broken.append(f"{rel}:{number}: {target} (no such file)")
                    continue
                if anchor and (not file_part or resolved.endswith(".md")):
                    if os.path.isfile(resolved) and anchor.lower() not in anchors(resolved):
                        broken.append(f"{rel}:{number}: {target} (no heading '#{anchor}')")
    return broken


def main():
    # The repository root: two folders above this script (tests/docs/check_links.py).
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    broken = check(root)
    for entry in broken:
        print(entry)
    if broken:
        print(f"{len(broken)} broken link(s)", file=sys.stderr)
        return 1
    print("every relative Markdown link resolves")
    return 0


if __name__ == "__main__":
    sys.exit(main())
