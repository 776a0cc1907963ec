#!/usr/bin/python3
"""Where the test command's time goes: each test's seconds from a ctest log, how ctest schedules it (RUN_SERIAL,
RESOURCE_LOCK, PROCESSORS, labels: from `ctest --show-only=json-v1` in the build folder), and the build's seconds of a
core per target from its ninja log.

    /usr/bin/python3 bench/ci_times.py --log CTEST_LOG [--build build] [--out bench/results/ci/ci-times]
                                       [--command "..."] [--note "..."]

CTEST_LOG is what ctest printed (`bash scripts/test.sh > LOG`, or `ctest ... > LOG`); the build folder is the one the
tests ran in (its `.ninja_log` should be the fresh build's: later partial builds replace the entries they rebuild).
Writes PREFIX.csv (a row a test) and PREFIX.md (the totals, the groups, the tests that run alone, the longest tests,
the build's targets). Standard library only.

Why serial time counts double: ctest runs the tests two at a time on two cores (`-j2`), except those marked RUN_SERIAL,
which run alone; so the run takes about (seconds of the serial tests) + (seconds of the others) / 2.
"""

import argparse
import collections
import csv
import datetime
import json
import os
import platform
import re
import subprocess
import sys


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--log", required=True, help="ctest's output")
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="bench/results/ci/ci-times")
    ap.add_argument("--command", default="", help="the command that made the log, for the report")
    ap.add_argument("--note", default="", help="a line about the run (machine state, commit), for the report")
    return ap.parse_args()


LINE = re.compile(r"Test\s+#\d+: (\S+) .*?(Passed|\*\*\*Failed|Failed|\*\*\*Timeout|Not Run|\*\*\*Exception)\s+([0-9.]+) sec")
TOTAL = re.compile(r"Total Test time \(real\) =\s*([0-9.]+) sec")


def read_log(path):
    times, statuses, total = {}, {}, None
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            m = LINE.search(line)
            if m:
                times[m.group(1)] = float(m.group(3))
                statuses[m.group(1)] = m.group(2).strip("*")
            t = TOTAL.search(line)
            if t:
                total = float(t.group(1))
    if not times:
        sys.exit(f"ci_times.py: no test lines in {path} (is it ctest's output?)")
    return times, statuses, total


def read_properties(build):
    try:
        out = subprocess.run(["ctest", "--show-only=json-v1"], cwd=build, capture_output=True, text=True, check=True)
    except (OSError, subprocess.CalledProcessError) as e:
        sys.exit(f"ci_times.py: ctest --show-only=json-v1 in {build} failed: {e}")
    props = {}
    for t in json.loads(out.stdout)["tests"]:
        p = {q["name"]: q["value"] for q in t.get("properties", [])}
        props[t["name"]] = {
            "serial": bool(p.get("RUN_SERIAL")),
            "lock": ";".join(p.get("RESOURCE_LOCK", [])),
            "processors": int(p.get("PROCESSORS", 1)),
            "labels": ";".join(p.get("LABELS", [])),
        }
    return props


def group_of(name):
    # server.X.Y -> server; Suite.Case (gtest without a prefix) -> Suite, a parameterised one -> its suite.
    head = name.split(".")[0]
    return head.split("/")[-1] if "/" in head else head


def read_ninja(build):
    path = os.path.join(build, ".ninja_log")
    if not os.path.exists(path):
        return None
    latest = {}
    with open(path) as f:
        for line in f:
            if line.startswith("#"):
                continue
            parts = line.rstrip("\n").split("\t")
            if len(parts) >= 4:
                latest[parts[3]] = (int(parts[0]), int(parts[1]))
    targets = collections.Counter()
    for out, (start, end) in latest.items():
        out = os.path.relpath(out, build) if os.path.isabs(out) else out
        # An object file names its target (DIR/CMakeFiles/TARGET.dir/...); a program or library is its link.
        m = re.search(r"CMakeFiles/([^/]+)\.dir/", out)
        key = m.group(1) if m else re.sub(r"^lib|\.a$", "", os.path.basename(out)) + " (link)"
        targets[key] += (end - start) / 1000.0
    return targets


def main():
    a = parse_args()
    times, statuses, total = read_log(a.log)
    props = read_properties(a.build)
    rows = []
    for name, sec in times.items():
        p = props.get(name, {"serial": False, "lock": "", "processors": 1, "labels": ""})
        rows.append({"test": name, "group": group_of(name), "seconds": sec, "status": statuses[name], **p})
    rows.sort(key=lambda r: -r["seconds"])
    os.makedirs(os.path.dirname(a.out) or ".", exist_ok=True)
    with open(a.out + ".csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["test", "group", "seconds", "status", "serial", "lock", "processors", "labels"])
        w.writeheader()
        for r in rows:
            w.writerow(r)

    serial = sum(r["seconds"] for r in rows if r["serial"])
    others = sum(r["seconds"] for r in rows if not r["serial"])
    groups = collections.defaultdict(lambda: [0, 0.0, 0.0])
    for r in rows:
        g = groups[r["group"]]
        g[0] += 1
        g[1] += r["seconds"]
        g[2] += r["seconds"] if r["serial"] else 0.0
    ninja = read_ninja(a.build)

    md = ["# Where the test command's time goes", ""]
    md.append(f"- Command: `/usr/bin/python3 bench/ci_times.py --log {a.log} --build {a.build} --out {a.out}`"
              + (f", on the log of `{a.command}`" if a.command else ""))
    md.append(f"- Date: {datetime.date.today().isoformat()}; machine: {platform.node()}, {os.cpu_count()} cores, "
              f"{platform.platform()}")
    if a.note:
        md.append(f"- {a.note}")
    md.append(f"- {len(rows)} tests, {sum(r['status'] != 'Passed' for r in rows)} not passed; ctest's wall time "
              f"{total:.0f} s" if total else f"- {len(rows)} tests")
    md.append(f"- Seconds of all tests {serial + others:.0f}: {serial:.0f} in tests that run alone (RUN_SERIAL), "
              f"{others:.0f} in the others, which run two at a time: about {serial + others / 2:.0f} s of wall time "
              "on two cores")
    md += ["", "## By group", "", "| group | tests | seconds | of them alone |", "| --- | ---: | ---: | ---: |"]
    for name, (n, sec, alone) in sorted(groups.items(), key=lambda kv: -kv[1][1])[:25]:
        md.append(f"| {name} | {n} | {sec:.1f} | {alone:.1f} |")
    md += ["", "## The tests that run alone, longest first", "", "| test | seconds |", "| --- | ---: |"]
    md += [f"| {r['test']} | {r['seconds']:.1f} |" for r in rows if r["serial"]][:25]
    md += ["", "## The longest tests", "", "| test | seconds | alone |", "| --- | ---: | --- |"]
    md += [f"| {r['test']} | {r['seconds']:.1f} | {'yes' if r['serial'] else ''} |" for r in rows[:25]]
    if ninja:
        md += ["", "## The build: seconds of a core per target (ninja log)", "",
               f"{sum(ninja.values()):.0f} s of a core in all.", "", "| target | seconds |", "| --- | ---: |"]
        md += [f"| {k} | {v:.1f} |" for k, v in ninja.most_common(25)]
    md.append("")
    with open(a.out + ".md", "w") as f:
        f.write("\n".join(md))
    print("\n".join(md))


if __name__ == "__main__":
    main()
