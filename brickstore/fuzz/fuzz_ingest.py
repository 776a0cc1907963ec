#!/usr/bin/python3
"""The ingest fuzzer: damaged inputs of every kind voxbrick reads, run through `voxbrick prep`, `info` and `render`.

    python3 brickstore/fuzz/fuzz_ingest.py [--exe build/voxbrick] [--count 5000] [--seed 1] [--jobs 2]
                                           [--formats a,b] [--timeout 30] [--rss-limit 1024] [--work build/fuzz-work]
                                           [--report PREFIX]

Seeds are written by the modules beside this one (NIfTI plain and gzip, NRRD attached raw and gzip, detached NRRD
header and data, a multi-page TIFF, DICOM series native, RLE and deflated, VTK legacy ASCII and binary, gmsh 2.2 and
4.1, an OpenVDB file, a brick store's store.json, index.bin and bricks.bin, a mesh store's mesh.json, index and data).
Mutants are taken round robin over the seeds, each seed's systematic ones first (a truncation at every structure
boundary, absurd values in every known header field, wrong JSON values) in an order shuffled by --seed, then random
bit and byte flips; the same --seed and --count give the same mutants. What is checked is in runner.py beside it;
docs/inputs.md says how to read the result. Every seed unchanged must be accepted first (exit status 2 if
one is not); exit status 1 when any mutant failed a check.

With --report PREFIX, writes PREFIX.md (the command, machine, date, counts per format and outcome, the largest
peak RSS and time, every failure) and PREFIX.csv (one row per voxbrick run). Python 3 standard library only.
"""

import argparse
import collections
import concurrent.futures
import csv
import datetime
import os
import platform
import queue
import random
import shlex
import shutil
import sys
import time

# The modules beside this script are the package `fuzz` (brickstore/fuzz/): its parent goes on the path.
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from fuzz import runner  # noqa: E402
from fuzz.mesh_seeds import mesh_seeds  # noqa: E402
from fuzz.mutate import Mutant, flip_mutant, systematic_mutants  # noqa: E402
from fuzz.seeds import volume_seeds  # noqa: E402
from fuzz.store_seeds import store_seeds  # noqa: E402


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
    ap.add_argument("--exe", default=os.path.join(root, "build", "voxbrick"))
    ap.add_argument("--count", type=int, default=5000, help="mutants to run")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--formats", default="", help="comma-separated seed formats (default: all)")
    ap.add_argument("--timeout", type=float, default=120, help="wall seconds a voxbrick run may take")
    ap.add_argument("--max-minutes", type=float, default=0, help="stop starting mutants after this long (0: never)")
    ap.add_argument("--rss-limit", type=float, default=1024, help="MB of peak RSS a voxbrick run may reach")
    ap.add_argument("--work", default=os.path.join(root, "build", "fuzz-work"))
    ap.add_argument("--report", default="", help="write PREFIX.md and PREFIX.csv")
    ap.add_argument("--list", action="store_true", help="list the seed formats and their systematic mutants")
    ap.add_argument("--match", default="", help="run only the systematic mutants whose 'FORMAT MUTATION' holds this")
    ap.add_argument("--save", default="", help="copy each failed mutant's input to SAVE/N-FORMAT")
    return ap.parse_args()


def schedule(seeds, count, rng):
    """Round robin over the seeds: each one's systematic mutants (shuffled), then flips."""
    lists = []
    for s in seeds:
        ms = systematic_mutants(s)
        rng.shuffle(ms)
        lists.append(collections.deque(ms))
    out = []
    while len(out) < count:
        for s, ms in zip(seeds, lists):
            if len(out) >= count:
                break
            m = ms.popleft() if ms else flip_mutant(s, s.files[s.target], rng)
            if m:
                out.append((s, m))
    return out


def idle_rss(exe, env, work):
    r = runner.run_child([exe, "--version"], env, 30, os.path.join(work, "idle.stderr"))
    return r.peak_mb


def main():
    a = parse_args()
    exe = os.path.abspath(a.exe)
    work = os.path.abspath(a.work)
    env = dict(os.environ)
    env.setdefault("VOXBRICK_CONFIG_DIR", os.path.join(os.path.dirname(exe), "..", "config"))
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    seeds = volume_seeds() + mesh_seeds() + store_seeds(exe, os.path.join(work, "seeds"), env)
    if a.formats:
        wanted = set(a.formats.split(","))
        seeds = [s for s in seeds if s.fmt in wanted]
    if a.list:
        for s in seeds:
            print(f"{s.fmt:20} {len(systematic_mutants(s)):5} systematic mutants of {s.target}")
        return 0
    rng = random.Random(a.seed)
    if a.match:
        plan = [(s, m) for s in seeds for m in systematic_mutants(s) if a.match in f"{m.fmt} {m.label}"][:a.count]
    else:
        plan = schedule(seeds, a.count, rng)
    pristine = {"kept": os.path.join(work, "seeds", "store"), "kept-mesh": os.path.join(work, "seeds", "mesh-store")}
    slots = queue.Queue()
    for j in range(a.jobs):
        slots.put(runner.Slot(os.path.join(work, f"slot{j}"), pristine, env, exe, a.timeout, a.rss_limit))

    def one(item):
        slot = slots.get()
        try:
            v = slot.judge(*item)
            if v.failures and a.save:
                name = "".join(c if c.isalnum() or c in "-.=@" else "_" for c in f"{v.fmt}-{v.label}")
                shutil.copytree(slot.inp, os.path.join(a.save, name), dirs_exist_ok=True)
            return v
        finally:
            slots.put(slot)

    # The seeds themselves first: each must be accepted, or its mutants prove nothing.
    bad_seeds = 0
    for s in seeds:
        v = one((s, Mutant(s.fmt, "unchanged seed", s.files[s.target], False)))
        if v.outcome != "accepted" or v.failures:
            bad_seeds += 1
            print(f"fuzz_ingest: seed {s.fmt} is not accepted: " + "; ".join(
                v.failures + [runner.message_lines(r.stderr)[0] for r in v.runs if r.rc == 1][:1]), file=sys.stderr)
    if bad_seeds:
        return 2
    start = time.monotonic()
    verdicts = []
    idle = idle_rss(exe, env, work)
    deadline = start + a.max_minutes * 60 if a.max_minutes > 0 else None

    def timed(item):
        return None if deadline and time.monotonic() > deadline else one(item)

    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        for k, v in enumerate(pool.map(timed, plan)):
            if v is None:
                continue
            verdicts.append(v)
            for f in v.failures:
                print(f"FAIL {v.fmt} {v.label}: {f}", flush=True)
            if (k + 1) % 250 == 0:
                print(f"fuzz_ingest: {k + 1}/{len(plan)} mutants, {time.monotonic() - start:.0f} s", flush=True)
                if a.report:  # a partial report, in case the run is stopped
                    write_report(a, verdicts, summarise(verdicts, idle), time.monotonic() - start, idle, exe)
    elapsed = time.monotonic() - start
    summary = summarise(verdicts, idle)
    print(summary["text"])
    if a.report:
        write_report(a, verdicts, summary, elapsed, idle, exe)
    return 1 if summary["failed"] else 0


def summarise(verdicts, idle):
    per = collections.defaultdict(collections.Counter)
    for v in verdicts:
        per[v.fmt][v.outcome] += 1
        per[v.fmt]["failed"] += bool(v.failures)
    runs = [(v, r) for v in verdicts for r in v.runs]
    refused = [(v, r) for v, r in runs if r.rc == 1]
    top_rss = max(runs, key=lambda x: x[1].peak_mb)
    top_refused = max(refused, key=lambda x: x[1].peak_mb) if refused else None
    top_time = max(runs, key=lambda x: x[1].seconds)
    top_cpu = max(runs, key=lambda x: x[1].cpu)
    failed = [v for v in verdicts if v.failures]
    text = (f"fuzz_ingest: {len(verdicts)} mutants, {len(runs)} voxbrick runs, {len(failed)} failed; peak RSS "
            f"{top_rss[1].peak_mb:.0f} MB ({top_rss[0].fmt} {top_rss[0].label}, {top_rss[1].command}); refused: "
            f"{top_refused[1].peak_mb if top_refused else 0:.0f} MB, idle {idle:.0f} MB; longest run "
            f"{top_time[1].seconds:.2f} s ({top_time[0].fmt} {top_time[0].label}, {top_time[1].command}); most CPU "
            f"{top_cpu[1].cpu:.2f} s ({top_cpu[0].fmt} {top_cpu[0].label}, {top_cpu[1].command})")
    return {"per": per, "runs": runs, "top_rss": top_rss, "top_refused": top_refused, "top_time": top_time,
            "top_cpu": top_cpu,
            "failed": failed, "text": text}


def docs_link(prefix):
    """docs/inputs.md relative to the report's folder, wherever the report is written."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    return os.path.relpath(os.path.join(root, "docs", "inputs.md"), os.path.dirname(os.path.abspath(prefix)))


def write_report(a, verdicts, s, elapsed, idle, exe):
    prefix, work = a.report, os.path.abspath(a.work)
    os.makedirs(os.path.dirname(os.path.abspath(prefix)), exist_ok=True)
    with open(prefix + ".csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["mutant", "format", "mutation", "must_refuse", "command", "status", "seconds", "cpu_s", "peak_rss_mb",
                    "outcome", "failures", "message"])
        for k, v in enumerate(verdicts):
            for r in v.runs:
                msg = runner.message_lines(r.stderr)
                msg = msg[0].replace(work, "WORK")[:160] if msg else ""  # WORK: the --work directory
                w.writerow([k, v.fmt, v.label, int(v.must), r.command, r.rc, f"{r.seconds:.3f}", f"{r.cpu:.3f}",
                            f"{r.peak_mb:.1f}", v.outcome, "; ".join(v.failures), msg])
    outcomes = ["refused", "accepted", "partly refused", "crashed or killed"]
    lines = ["# Ingest fuzzer", "",
             "Damaged inputs of every kind voxbrick reads through `prep`, `info` and `render` "
             "([docs/inputs.md](" + docs_link(prefix) + "#the-ingest-fuzzer) says what is checked).", "",
             "```sh", "nice -n 19 python3 " + " ".join(shlex.quote(x) for x in sys.argv), "```", "",
             f"- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC; machine: "
             f"{platform.node()}, {os.cpu_count()} CPUs (shared), {platform.platform()}; binary: {exe}",
             f"- {len(verdicts)} mutants, {len(s['runs'])} voxbrick runs, {elapsed / 60:.1f} min with {a.jobs} jobs",
             f"- failed checks: **{len(s['failed'])}** mutants",
             f"- largest peak RSS of any run: {s['top_rss'][1].peak_mb:.0f} MB ({s['top_rss'][0].fmt}, "
             f"{s['top_rss'][0].label}, `{s['top_rss'][1].command}`)"]
    if s["top_refused"]:
        v, r = s["top_refused"]
        lines.append(f"- largest peak RSS of a refusal: {r.peak_mb:.0f} MB, {r.peak_mb - idle:.0f} MB above an idle "
                     f"`voxbrick --version` ({idle:.0f} MB) ({v.fmt}, {v.label}, `{r.command}`)")
    v, r = s["top_time"]
    vc, rc = s["top_cpu"]
    lines += [f"- longest run: {r.seconds:.2f} s wall ({v.fmt}, {v.label}, `{r.command}`); most CPU: {rc.cpu:.2f} s "
              f"({vc.fmt}, {vc.label}, `{rc.command}`); the wall time counts the machine's load", "",
              "| format | mutants | " + " | ".join(outcomes) + " | failed |",
              "| --- | ---: | " + " | ".join("---:" for _ in outcomes) + " | ---: |"]
    for fmt, c in s["per"].items():
        total = sum(c[o] for o in outcomes)
        lines.append(f"| {fmt} | {total} | " + " | ".join(str(c[o]) for o in outcomes) + f" | {c['failed']} |")
    lines += ["", "## Failures", ""]
    if not s["failed"]:
        lines.append("None.")
    for v in s["failed"]:
        lines.append(f"- {v.fmt}, {v.label}: " + "; ".join(v.failures))
    with open(prefix + ".md", "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main())
