#!/usr/bin/python3
"""Every Markdown table in the repository's documents and committed results has as many cells in each row, and in
its separator line, as in its header: a results table whose generator adds a column to its rows but not to its header
shows every later value under the wrong heading.

    /usr/bin/python3 scripts/check_tables.py [ROOT]      # exit status 1 naming each table that does not line up
    /usr/bin/python3 scripts/check_tables.py --self-test # a table one heading short must be caught

A `|` inside backquotes or escaped as `\\|` is text, not a cell boundary. Files under node_modules, build folders and
bench/work are not read. Standard library only (ctest `docs.Tables`).
"""

import os
import re
import sys

SKIP_DIRS = {"node_modules", ".git", "bench/work", "demo"}
SEPARATOR = re.compile(r"^\|\s*:?-{3,}")


def cells(line):
    text = re.sub(r"`[^`]*`", lambda m: m.group(0).replace("|", " "), line.strip())
    text = text.replace("\\|", " ")
    return len(text.strip("|").split("|"))


def check_text(lines):
    """The problems of the tables in `lines`, as (line number, what) pairs."""
    problems = []
    i = 0
    while i < len(lines):
        if lines[i].startswith("|") and i + 1 < len(lines) and SEPARATOR.match(lines[i + 1]):
            header = cells(lines[i])
            if cells(lines[i + 1]) != header:
                problems.append((i + 2, f"separator has {cells(lines[i + 1])} cells, the header {header}"))
            j = i + 2
            while j < len(lines) and lines[j].startswith("|"):
                if cells(lines[j]) != header:
                    problems.append((j + 1, f"row has {cells(lines[j])} cells, the header (line {i + 1}) {header}"))
                j += 1
            i = j
        else:
            i += 1
    return problems


def markdown_files(root):
    for dirpath, dirnames, filenames in os.walk(root):
        rel = os.path.relpath(dirpath, root)
        dirnames[:] = [d for d in dirnames
                       if d not in SKIP_DIRS and os.path.normpath(os.path.join(rel, d)) not in SKIP_DIRS
                       and not d.startswith("build")]
        for name in filenames:
            if name.endswith(".md"):
                yield os.path.join(dirpath, name)


def self_test():
    good = ["| a | b |", "| --- | ---: |", "| 1 | `x|y` |", "| 2 | 3 \\| 4 |"]
    short_header = ["| a | b |", "|---|---|---|", "| 1 | 2 | 3 |"]
    if check_text(good):
        sys.exit(f"check_tables.py --self-test: a good table was refused: {check_text(good)}")
    found = check_text(short_header)
    if len(found) != 2:
        sys.exit(f"check_tables.py --self-test: a table one heading short gave {found}, not its separator and row")
    print("check_tables.py --self-test: a good table passes; one heading short is named at lines "
          f"{', '.join(str(n) for n, _ in found)}")


def main():
    if sys.argv[1:] == ["--self-test"]:
        self_test()
        return
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    failed = 0
    files = 0
    for path in sorted(markdown_files(root)):
        files += 1
        with open(path, encoding="utf-8", errors="replace") as f:
            for line, what in check_text(f.read().split("\n")):
                print(f"{os.path.relpath(path, root)}:{line}: {what}")
                failed += 1
    if failed:
        sys.exit(f"check_tables.py: {failed} table lines do not line up with their header (above)")
    print(f"check_tables.py: every table of {files} Markdown files lines up with its header")


if __name__ == "__main__":
    main()
