#!/usr/bin/env bash
# Turns under a crowd that drags and lets go, two builds side by side in one run: for each round, a fresh server of
# each build in turn (2 render threads, the MRI; 4 clients drag for 3 s first, so that the capacity is measured), then
# CLIENTS `voxbrick load` clients that each drag DRAG seconds at 30 Hz and rest REST, over and over, from phases of
# their own (`--drag-cycle`): more drags at once than the server keeps at min_interactive_fps, so that drags wait
# their turn. What it shows is who gets a turn: per drag, the wait from its first camera to its first frame (p50, p90,
# max) and the drags that got none before they ended; per client, its frames a second over the run, the slowest and
# Jain's index over them; latency of the frames shown. The load is this tree's `voxbrick load` for both builds.
# Writes bench/results/server/crowd-turns.{csv,md}.
#
#   bash bench/run_crowd_turns.sh OLD_VOXBRICK NEW_VOXBRICK [--rounds 3] [--clients 80] [--duration 30] [--size 128]
#     [--cycle 3,3]
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { sed -n 2,12p "$0"; exit 2; }
rounds=3 clients=80 duration=30 size=128 cycle=3,3
source bench/crowd_ab.sh
crowd_ab_own=(cycle)
crowd_ab_args run_crowd_turns.sh "$@"
crowd_ab_begin crowd-turns run_crowd_turns.sh \
  "--rounds $rounds --clients $clients --duration $duration --size $size --cycle $cycle" \
  round,build,capacity,drags_taken,drags_refused,wait_p50_ms,wait_p90_ms,wait_max_ms,slowest_client_fps,median_client_fps,jain,frames_per_s,latency_p50_ms,latency_p99_ms,busy,errors
for r in $(seq 1 "$rounds"); do
  order="old new"; [ $((r % 2)) -eq 0 ] && order="new old"
  for build in $order; do
    crowd_ab_serve "$build"
    crowd_ab_load 4 3 "$work/warmup.json"
    "$new" load "127.0.0.1:$port" --dataset mri --tf mri --step 0.75 --clients "$clients" --drag 30 --interactive 50 \
      --provisional-encoding jpeg --duration "$duration" --size "${size}x${size}" --drag-cycle "$cycle" \
      --json "$work/load.json" > /dev/null
    crowd_ab_stop
    python3 - "$work/load.json" "$r" "$build" >> "$csv" << 'PY'
import json, statistics, sys
j = json.load(open(sys.argv[1]))
rates = sorted(c['frames_per_s'] for c in j['per_client'])
jain = sum(rates) ** 2 / (len(rates) * sum(x * x for x in rates)) if any(rates) else float('nan')
d, l, s = j['drag_cycle'], j['latency_ms'], j['server']
print(','.join(str(x) for x in (sys.argv[2], sys.argv[3], s['sessions']['interactive_capacity'], d['drags_taken'],
      d['drags_refused'], f"{d['wait_ms']['p50']:.0f}", f"{d['wait_ms']['p90']:.0f}", f"{d['wait_ms']['max']:.0f}",
      f"{rates[0]:.2f}", f"{statistics.median(rates):.2f}", f"{jain:.3f}", f"{j['frames_per_s']:.1f}",
      f"{l['p50']:.1f}", f"{l['p99']:.1f}", j['busy'], j['errors'])))
PY
    echo "round $r $build: $(tail -1 "$csv")"
  done
done
python3 bench/crowd_ab_table.py "$csv" "Turns under a crowd that drags and lets go" \
  "\`drags_taken\`: drags that got a frame; \`drags_refused\`: drags that ended (a still Render, as a viewer's release) without one; \`wait\`: from a drag's first camera to its first frame, over the drags taken; \`client fps\`: each client's frames a second over the whole run, and Jain's index over them." \
  > "$out/crowd-turns.md"
cat "$out/crowd-turns.md"
