#!/usr/bin/env bash
# A crowd meeting a cold server, two builds side by side in one run: for each round, a fresh server of each build in
# turn (its render threads have made no renderer yet) and CLIENTS `voxbrick load` clients dragging the MRI at once.
# What it shows is whether the first sessions to reach a cold thread are charged its warm-up (the renderer made for
# the dataset) and then wait while the others drag: each client's frames, the fewest, and the clients that got less
# than a quarter of the median. Writes bench/results/server/cold-crowd.{csv,md}.
#
#   bash bench/run_cold_crowd.sh OLD_VOXBRICK NEW_VOXBRICK [--rounds 3] [--clients 40] [--duration 10] [--size 128]
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=3 clients=40 duration=10 size=128
source bench/crowd_ab.sh
crowd_ab_args run_cold_crowd.sh "$@"
crowd_ab_begin cold-crowd run_cold_crowd.sh "--rounds $rounds --clients $clients --duration $duration --size $size" \
  round,build,frames_per_s,fewest,median,most,starved,jain,latency_p50_ms,latency_p99_ms,busy,errors
for r in $(seq 1 "$rounds"); do
  order="old new"; [ $((r % 2)) -eq 0 ] && order="new old"
  for build in $order; do
    crowd_ab_serve "$build"
    crowd_ab_load "$clients" "$duration" "$work/load.json"
    crowd_ab_stop
    python3 - "$work/load.json" "$r" "$build" >> "$csv" << 'EOF'
import json, statistics, sys
j = json.load(open(sys.argv[1]))
frames = sorted(c['frames'] for c in j['per_client'])
median = statistics.median(frames)
starved = sum(1 for f in frames if f < median / 4)
l = j['latency_ms']
print(f"{sys.argv[2]},{sys.argv[3]},{j['frames_per_s']:.1f},{frames[0]},{median:g},{frames[-1]},{starved},"
      f"{j['jain_index']:.3f},{l['p50']:.1f},{l['p99']:.1f},{j['busy']},{j['errors']}")
EOF
    tail -1 "$csv"
  done
done

python3 - "$csv" > "$out/cold-crowd.md" << 'EOF'
import csv, statistics, sys
lines = open(sys.argv[1]).read().splitlines()
heads = [l.lstrip('# ') for l in lines if l.startswith('#')]
rows = list(csv.DictReader(l for l in lines if not l.startswith('#')))
print("# A crowd meeting a cold server\n")
print(f"- Run: {heads[0]}.")
print(f"- Command: `{heads[1]}`.")
print("- Each run: a fresh `voxbrick serve --render-threads 2` on the MRI, then at once that many `voxbrick load` clients")
print("  dragging at 30 Hz (interactive 50 ms, provisional JPEG). Starved: clients with less than a quarter of the median")
print("  frames. Every run below, then the medians over the rounds.\n")
print("| round | build | frames/s | fewest frames | median | most | starved | Jain | p50 ms | p99 ms | busy | errors |")
print("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for r in rows:
    print(f"| {r['round']} | {r['build']} | {r['frames_per_s']} | {r['fewest']} | {r['median']} | {r['most']} | "
          f"{r['starved']} | {r['jain']} | {r['latency_p50_ms']} | {r['latency_p99_ms']} | {r['busy']} | {r['errors']} |")
print("\n| build | frames/s | fewest frames | starved | Jain |")
print("|---|---:|---:|---:|---:|")
for build in ('old', 'new'):
    m = lambda col: statistics.median(float(r[col]) for r in rows if r['build'] == build)
    print(f"| {build} | {m('frames_per_s'):.1f} | {m('fewest'):g} | {m('starved'):g} | {m('jain'):.3f} |")
EOF
cat "$out/cold-crowd.md"
