#!/usr/bin/env python3
"""Per (store, drawing): the frame time over a bench_orientation sweep, robust to the machine's isolated stalls.

Reads NAME.csv of bench_orientation, takes per view the median over the runs (as the tool does), and prints a
Markdown table over all views of each store and drawing: median, mean, the 10th and 90th percentile and their
ratio (the spread of the curve without its isolated spikes), min/max (the tool's ratio, spikes included), and the
mean relative to a baseline store (--baseline LABEL).

  python3 bench/orientation_summary.py bench/results/orientation/bricking.csv --baseline "128³ in 4³ bricks of 32"
"""
import argparse
import csv
import statistics
from collections import defaultdict


def percentile(values, p):
    s = sorted(values)
    k = (len(s) - 1) * p / 100
    lo, hi = int(k), min(int(k) + 1, len(s) - 1)
    return s[lo] + (s[hi] - s[lo]) * (k - lo)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv")
    ap.add_argument("--baseline", default="", help="store label whose mean the others are compared with")
    args = ap.parse_args()
    runs = defaultdict(list)  # (store, drawing, axis, angle) -> ms per run
    with open(args.csv, newline="") as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        for r in rows:
            runs[(r["store"], r["drawing"], r["axis"], float(r["angle"]))].append(float(r["ms_total"]))
    views = defaultdict(list)  # (store, drawing) -> per-view medians
    order = []
    for (store, drawing, _axis, _angle), ms in runs.items():
        if (store, drawing) not in views:
            order.append((store, drawing))
        views[(store, drawing)].append(statistics.median(ms))
    base = {d: statistics.mean(v) for (s, d), v in views.items() if s == args.baseline}
    print("| store | drawing | views | median ms | mean ms | p10 ms | p90 ms | p90/p10 | min/max frame rate | mean vs baseline |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for store, drawing in order:
        v = views[(store, drawing)]
        p10, p90 = percentile(v, 10), percentile(v, 90)
        rel = f"{statistics.mean(v) / base[drawing]:.3f}" if drawing in base else "-"
        print(f"| {store} | {drawing} | {len(v)} | {statistics.median(v):.1f} | {statistics.mean(v):.1f} | {p10:.1f} | "
              f"{p90:.1f} | {p90 / p10:.2f} | 1:{max(v) / min(v):.2f} | {rel} |")


if __name__ == "__main__":
    main()
