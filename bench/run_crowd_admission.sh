#!/usr/bin/env bash
# Admission under a crowd that comes at once, two builds side by side in one run: for each round, a fresh server of
# each build in turn (2 render threads, the MRI) and CLIENTS `voxbrick load` clients dragging at 30 Hz that start
# together, in two scenarios:
#   cold  the crowd meets a server that has drawn nothing (its capacity not measured yet);
#   warm  4 clients drag for 3 s first (the capacity is measured), then the crowd comes.
# What it shows is whether the sessions the server lets drag each get the min_interactive_fps (5) the capacity is
# sized for, and how many it lets in: per client, its frames a second from its first frame (`voxbrick load`'s
# frames_per_s_since_first), the slowest and the median of those let in, Jain's index over them, latency, Busy
# replies, the measured capacity at the end and the render threads' busy share. The load is this tree's
# `voxbrick load` for both builds. Writes bench/results/server/crowd-admission.{csv,md}.
#
#   bash bench/run_crowd_admission.sh OLD_VOXBRICK NEW_VOXBRICK [--rounds 2] [--clients 80] [--duration 10] [--size 128]
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { sed -n 2,13p "$0"; exit 2; }
rounds=2 clients=80 duration=10 size=128
source bench/crowd_ab.sh
crowd_ab_args run_crowd_admission.sh "$@"
crowd_ab_begin crowd-admission run_crowd_admission.sh \
  "--rounds $rounds --clients $clients --duration $duration --size $size" \
  round,build,scenario,capacity,admitted,admitted_in_first_s,slowest_fps,median_fps,jain,frames_per_s,latency_p50_ms,latency_p99_ms,busy,errors,render_busy_share
for r in $(seq 1 "$rounds"); do
  order="old new"; [ $((r % 2)) -eq 0 ] && order="new old"
  for scenario in cold warm; do
    for build in $order; do
      crowd_ab_serve "$build"
      [ "$scenario" = warm ] && crowd_ab_load 4 3 "$work/warmup.json"
      crowd_ab_load "$clients" "$duration" "$work/load.json"
      crowd_ab_stop
      python3 - "$work/load.json" "$r" "$build" "$scenario" >> "$csv" << 'EOF'
import json, statistics, sys
j = json.load(open(sys.argv[1]))
taken = [c for c in j['per_client'] if c['frames'] > 0]
rates = sorted(c['frames_per_s_since_first'] for c in taken if c['frames_per_s_since_first'] is not None)
jain = sum(rates) ** 2 / (len(rates) * sum(x * x for x in rates)) if rates else float('nan')
s, b = j['server'], j['server_before']
busy_share = (sum(s['render_busy_s']) - sum(b['render_busy_s'])) / (len(s['render_busy_s']) * (s['uptime_s'] - b['uptime_s']))
l = j['latency_ms']
print(','.join(str(x) for x in (sys.argv[2], sys.argv[3], sys.argv[4], s['sessions']['interactive_capacity'], len(taken),
      sum(1 for c in taken if c['first_frame_s'] < 1), f"{rates[0]:.2f}" if rates else '',
      f"{statistics.median(rates):.2f}" if rates else '', f"{jain:.3f}", f"{j['frames_per_s']:.1f}",
      f"{l['p50']:.1f}", f"{l['p99']:.1f}", j['busy'], j['errors'], f"{busy_share:.3f}")))
EOF
      echo "round $r $scenario $build: $(tail -1 "$csv")"
    done
  done
done
python3 bench/crowd_ab_table.py "$csv" "Admission under a crowd that comes at once" \
  "\`admitted\`: clients that got a frame; \`slowest\`/\`median fps\`: their frames a second from their first frame; the targets are ≥ 5 for every one admitted (min_interactive_fps) and Jain ≥ 0.9 over them." \
  > "$out/crowd-admission.md"
cat "$out/crowd-admission.md"
