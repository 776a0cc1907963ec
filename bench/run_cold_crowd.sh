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
[ $# -ge 2 ] || { echo "usage: bash bench/run_cold_crowd.sh OLD_VOXBRICK NEW_VOXBRICK [options]" >&2; exit 2; }
old=$1 new=$2
shift 2
rounds=3 clients=40 duration=10 size=128
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds=$2; shift 2 ;;
    --clients) clients=$2; shift 2 ;;
    --duration) duration=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    *) echo "run_cold_crowd.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
out=bench/results/server
work=bench/work/cold-crowd
mkdir -p "$out" "$work/data"
export VOXBRICK_CONFIG_DIR=$PWD/config
[ -f "$work/data/mri/store.json" ] || "$new" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$work/data/mri" -q

server=""
trap '[ -n "$server" ] && kill "$server" 2> /dev/null || true' EXIT
csv=$out/cold-crowd.csv
{
  tree="$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- . ':!bench/results' || echo ' with uncommitted changes')"
  echo "# $(date -u +%Y-%m-%d), $(nproc) cores, source tree $tree; old $old, new $new"
  echo "# bash bench/run_cold_crowd.sh OLD NEW --rounds $rounds --clients $clients --duration $duration --size $size"
  echo "round,build,frames_per_s,fewest,median,most,starved,jain,latency_p50_ms,latency_p99_ms,busy,errors"
} > "$csv"
for r in $(seq 1 "$rounds"); do
  order="old new"; [ $((r % 2)) -eq 0 ] && order="new old"
  for build in $order; do
    exe=$old; [ "$build" = new ] && exe=$new
    rm -f "$work/port"
    "$exe" serve --no-config --datasets "$work/data" --port 0 --port-file "$work/port" --render-threads 2 \
      --max-sessions 256 > "$work/$build.log" 2>&1 &
    server=$!
    for _ in $(seq 600); do [ -s "$work/port" ] && break; sleep 0.1; done
    "$new" load "127.0.0.1:$(cat "$work/port")" --dataset mri --tf mri --step 0.75 --clients "$clients" --drag 30 \
      --interactive 50 --provisional-encoding jpeg --duration "$duration" --size "${size}x${size}" \
      --json "$work/load.json" > /dev/null
    kill "$server"
    wait "$server" 2> /dev/null || true  # its status is that of the signal
    server=""
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
