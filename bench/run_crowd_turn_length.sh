#!/usr/bin/env bash
# The turn's length (`[scheduler] interactive_turn_s`) under two crowds, one build, every length side by side in one
# run: for each round, for each length, a fresh server (2 render threads, the MRI; 4 clients drag for 3 s first, so
# that the capacity is measured) and CLIENTS `voxbrick load` clients dragging at 30 Hz at SIZE², in two crowds:
#   steady  every client drags for the whole run and never lets go (a script that drags without end, or a class of
#           viewers that all keep turning): more than the server keeps at min_interactive_fps;
#   cycle   each client drags 3 s and rests 3 s, from a phase of its own (`--drag-cycle 3,3`), each drag ending with a
#           still Render (a viewer's release).
# A length of 0 is no turn. What it shows is the front the default is chosen from: fairness (Jain's index over the
# clients' frames a second, the slowest client, the clients that got no frame) against the frames drawn in all and
# the latency of the frames shown. Writes bench/results/server/crowd-turn-length.{csv,md}.
#
#   bash bench/run_crowd_turn_length.sh VOXBRICK [--lengths 0,1,2,3,5] [--rounds 2] [--clients 80] [--duration 20]
#     [--size 128]
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 1 ] || { sed -n 2,14p "$0"; exit 2; }
exe=$1
shift
lengths=0,1,2,3,5 rounds=2 clients=80 duration=20 size=128
source bench/crowd_ab.sh
# The shared options and --lengths; crowd_ab_begin's head names an old and a new build: here both are this one.
crowd_ab_own=(lengths)
crowd_ab_args run_crowd_turn_length.sh "$exe" "$exe" "$@"
crowd_ab_begin crowd-turn-length run_crowd_turn_length.sh \
  "--lengths $lengths --rounds $rounds --clients $clients --duration $duration --size $size" \
  round,crowd,turn_s,capacity,turns_ended,clients_without_frames,slowest_client_fps,median_client_fps,jain,frames_per_s,latency_p50_ms,latency_p99_ms,drags_refused,drag_wait_p50_ms,drag_wait_p90_ms,busy,errors
sed -i -e '1s/; old .*/; voxbrick '"${exe//\//\\/}"'/' -e '2s/ OLD NEW / VOXBRICK /' "$csv"
for r in $(seq 1 "$rounds"); do
  for crowd in steady cycle; do
    for turn in ${lengths//,/ }; do
      printf '[scheduler]\ninteractive_turn_s = %s\n' "$turn" > "$work/turn.toml"
      rm -f "$work/port"
      "$exe" serve --config "$work/turn.toml" --datasets "$work/data" --port 0 --port-file "$work/port" \
        --render-threads 2 --max-sessions 256 > "$work/server.log" 2>&1 &
      server=$!
      for _ in $(seq 600); do [ -s "$work/port" ] && break; sleep 0.1; done
      port=$(cat "$work/port")
      crowd_ab_load 4 3 "$work/warmup.json"
      cycle=()
      [ "$crowd" = cycle ] && cycle=(--drag-cycle 3,3)
      "$exe" load "127.0.0.1:$port" --dataset mri --tf mri --step 0.75 --clients "$clients" --drag 30 --interactive 50 \
        --encoding png --provisional-encoding jpeg --duration "$duration" --size "${size}x${size}" "${cycle[@]}" \
        --json "$work/load.json" > /dev/null
      crowd_ab_stop
      python3 - "$work/load.json" "$r" "$crowd" "$turn" >> "$csv" << 'PY'
import json, statistics, sys
j = json.load(open(sys.argv[1]))
rates = sorted(c['frames_per_s'] for c in j['per_client'])
jain = sum(rates) ** 2 / (len(rates) * sum(x * x for x in rates)) if any(rates) else float('nan')
l, s = j['latency_ms'], j['server']
d = j.get('drag_cycle')
print(','.join(str(x) for x in (sys.argv[2], sys.argv[3], sys.argv[4], s['sessions']['interactive_capacity'],
      s['sessions']['drag_turns_ended'], sum(1 for c in j['per_client'] if c['frames'] == 0), f"{rates[0]:.2f}",
      f"{statistics.median(rates):.2f}", f"{jain:.3f}", f"{j['frames_per_s']:.1f}", f"{l['p50']:.1f}",
      f"{l['p99']:.1f}", d['drags_refused'] if d else '', f"{d['wait_ms']['p50']:.0f}" if d else '',
      f"{d['wait_ms']['p90']:.0f}" if d else '', j['busy'], j['errors'])))
PY
      echo "round $r $crowd turn $turn: $(tail -1 "$csv")"
    done
  done
done
python3 bench/crowd_ab_table.py "$csv" "The turn's length under a crowd" \
  "\`turn_s\`: interactive_turn_s (0: no turn); \`clients without frames\`: clients that got no frame in the whole run; \`client fps\`: each client's frames a second over the run, and Jain's index over them; \`drags refused\` (cycle): drags that ended without a frame; \`drag wait\`: from a drag's first camera to its first frame." \
  crowd,turn_s > "$out/crowd-turn-length.md"
cat "$out/crowd-turn-length.md"
