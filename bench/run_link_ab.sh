#!/usr/bin/env bash
# Two builds' measure of a session's link, side by side: one `voxbrick load --drag` client (30 cameras a second,
# interactive frames, moving frames as vp8, each Frame reported with FrameReceived) against a fresh `voxbrick serve`
# of each build, through bench/link_relay.mjs on a far fast link (100 Mbit/s, 80 ms round trip: the round trip
# longer than the time between frames, so frames overlap on it without queueing) and on a slow one (10 Mbit/s, 40 ms).
# The server gives the video stream 70 % of the rate it measures: a link read from the drag's own spacing holds the
# bitrate down. Rounds alternate the builds' order. Writes OUT.{csv,md}: every run, then each build's medians.
#
# --serve-args "ARGS": more options for both servers, e.g. "--replay-frames DIR --replay-draw-ms 10" (frames drawn
# beforehand, bench/run_browser_link.sh --replay-draw-ms makes DIR: everything but the drawing measured). --relay
# build/bench/bench_link_relay: the C++ relay (the same link, less of a busy machine's CPU than Node's). --links
# slow: only the slow link.
#
#   bash bench/run_link_ab.sh OLD_VOXBRICK NEW_VOXBRICK OUT [--rounds 2] [--size 512] [--duration 8] [--serve-args ARGS]
#                             [--relay PROGRAM] [--links far,slow]
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 3 ] || { echo "usage: bash bench/run_link_ab.sh OLD_VOXBRICK NEW_VOXBRICK OUT [--rounds 2] [...]" >&2; exit 2; }
old=$(realpath "$1") new=$(realpath "$2") out=$3
shift 3
rounds=2 size=512 duration=8 serveArgs= relayCmd="node bench/link_relay.mjs" links=far,slow
while [ $# -gt 0 ]; do
  case "$1" in
    --relay) relayCmd=$2; shift 2 ;;
    --links) links=$2; shift 2 ;;
    --serve-args) serveArgs=$2; shift 2 ;;
    --rounds) rounds=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --duration) duration=$2; shift 2 ;;
    *) echo "run_link_ab.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
source bench/browser_bench.sh
work=bench/work/video
datasets=$work/datasets
mkdir -p "$(dirname "$out")"
mri_datasets "$work" "$new"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2> /dev/null || true; done
  pids=()
}
trap cleanup EXIT
# Waits for "PATTERN NUMBER" in FILE and prints the number.
port_in() {
  for _ in $(seq 100); do
    local p
    p=$(grep -ao "$2 [0-9.:]*[0-9]" "$1" | head -1 | sed 's/.*[ :]//') || true
    [ -n "$p" ] && { echo "$p"; return 0; }
    sleep 0.1
  done
  echo "run_link_ab.sh: no '$2' in $1: $(cat "$1")" >&2
  exit 1
}
rows=$work/link-ab-rows.jsonl
: > "$rows"
for r in $(seq 1 "$rounds"); do
  order="old new"; [ $((r % 2)) -eq 0 ] && order="new old"
  for link in "far 100 40" "slow 10 20"; do
    read -r name mbit delay <<< "$link"
    [[ ",$links," == *",$name,"* ]] || continue
    for build in $order; do
      exe=$old; [ "$build" = new ] && exe=$new
      # shellcheck disable=SC2086  # the options, word by word
      "$exe" serve --datasets "$datasets" --port 0 --render-threads 1 $serveArgs > "$work/link-ab-serve.log" 2>&1 &
      pids+=($!)
      port=$(port_in "$work/link-ab-serve.log" "listening on")
      # shellcheck disable=SC2086  # the program and its arguments
      $relayCmd --target "$port" --listen 0 --mbit "$mbit" --delay-ms "$delay" > "$work/link-ab-relay.log" &
      pids+=($!)
      relay=$(port_in "$work/link-ab-relay.log" "listening on")
      json=$work/link-ab-$build-$name-$r.json
      "$exe" load "127.0.0.1:$relay" --dataset mri --tf mri --clients 1 --size "${size}x${size}" --drag 30 \
        --interactive 50 --encoding png --provisional-encoding vp8 --duration "$duration" --json "$json" > /dev/null
      python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print(json.dumps({"build": sys.argv[2],
"round": int(sys.argv[3]), "link": sys.argv[4], "mbit": float(sys.argv[5]), "rtt_ms": 2 * float(sys.argv[6]), **d}))' \
        "$json" "$build" "$r" "$name" "$mbit" "$delay" >> "$rows"
      cleanup
    done
  done
done
python3 - "$rows" "$out" "$old" "$new" "$rounds" "$size" "$duration" "$serveArgs" "$relayCmd" "$links" <<'PY'
import csv, json, statistics, subprocess, sys
from datetime import date
rows_path, out, old, new, rounds, size, duration, serve_args, relay, links = sys.argv[1:11]
runs = [json.loads(l) for l in open(rows_path)]
table = []
for d in runs:
    fps, bpf = d['frames_per_s'], d['payload_bytes_per_frame']
    table.append({'build': d['build'], 'round': d['round'], 'link': d['link'], 'mbit': d['mbit'], 'rtt_ms': d['rtt_ms'],
                  'frames_per_s': round(fps, 1), 'latency_p50_ms': round(d['latency_ms']['p50'], 1),
                  'latency_p99_ms': round(d['latency_ms']['p99'], 1), 'bytes_per_frame': round(bpf),
                  'kbit_per_s': round(fps * bpf * 8 / 1000), 'errors': d['errors']})
cols = list(table[0])
with open(out + '.csv', 'w', newline='') as f:
    w = csv.DictWriter(f, fieldnames=cols)
    w.writeheader()
    w.writerows(table)
load = open('/proc/loadavg').read().split()[:3]
tree = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], capture_output=True, text=True).stdout.strip()
md = ['# Two builds\' measure of the link, side by side', '',
      f'- Command: `bash bench/run_link_ab.sh OLD NEW {out} --rounds {rounds} --size {size} --duration {duration}'
      + (f' --serve-args "{serve_args}"' if serve_args else '')
      + (f' --relay {relay}' if relay != 'node bench/link_relay.mjs' else '')
      + (f' --links {links}' if links != 'far,slow' else '') + f'`; old `{old}`, new `{new}` (source tree {tree}).',
      f'- Date: {date.today()}; 2 shared cores, Mesa llvmpipe; load average at the end {" ".join(load)}.',
      f'- One `voxbrick load --drag 30 --interactive 50 --provisional-encoding vp8` client at {size}², {duration} s, the MRI;',
      f'  each Frame reported with FrameReceived. Through {relay}: far, 100 Mbit/s with an 80 ms round trip;',
      '  slow, 10 Mbit/s with 40 ms. kbit/s: the moving frames\' bytes a second (frames/s x bytes a frame).', '',
      '| ' + ' | '.join(cols) + ' |', '|' + '---|' * len(cols)]
md += ['| ' + ' | '.join(str(r[c]) for c in cols) + ' |' for r in table]
md += ['', 'Medians over the rounds:', '', '| link | build | frames/s | latency p50 ms | p99 ms | bytes/frame | kbit/s |',
       '|---|---|---:|---:|---:|---:|---:|']
for link in dict.fromkeys(r['link'] for r in table):
    for build in ('old', 'new'):
        sel = [r for r in table if r['link'] == link and r['build'] == build]
        med = lambda k: statistics.median(r[k] for r in sel)
        md.append(f"| {link} | {build} | {med('frames_per_s'):.1f} | {med('latency_p50_ms'):.0f} | "
                  f"{med('latency_p99_ms'):.0f} | {med('bytes_per_frame'):.0f} | {med('kbit_per_s'):.0f} |")
open(out + '.md', 'w').write('\n'.join(md) + '\n')
print('\n'.join(md))
PY
