#!/usr/bin/env bash
# Still frames encoded aside (`[server] encode_aside`, the default) against encoded on the render thread, side by
# side in one run: two real servers on loopback, one each way, the same MRI, one render thread each (so a frame's
# encoding either holds the thread or does not). For each encoding and size, `voxbrick load` clients asking frames
# one at a time run against each server in turn, ROUNDS times. Writes bench/results/server/encode-aside.{csv,md}.
#
#   bash bench/run_encode_aside.sh [--rounds 3] [--duration 8] [--clients 2] [--sizes 512,1024] [--encodings png,jpeg]
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=3 duration=8 clients=2 sizes=512,1024 encodings=png,jpeg
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds=$2; shift 2 ;;
    --duration) duration=$2; shift 2 ;;
    --clients) clients=$2; shift 2 ;;
    --sizes) sizes=$2; shift 2 ;;
    --encodings) encodings=$2; shift 2 ;;
    *) echo "run_encode_aside.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
out=bench/results/server
work=bench/work/encode-aside
mkdir -p "$out" "$work/data"
export VOXBRICK_CONFIG_DIR=$PWD/config
[ -f "$work/data/mri/store.json" ] || "$bin" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$work/data/mri" -q

pids=()
trap 'for p in "${pids[@]}"; do kill "$p" 2> /dev/null || true; done' EXIT
declare -A port
for mode in aside inline; do
  aside=true; [ "$mode" = inline ] && aside=false
  printf '[server]\nencode_aside = %s\n' "$aside" > "$work/$mode.toml"
  rm -f "$work/$mode.port"
  "$bin" serve --config "$work/$mode.toml" --datasets "$work/data" --port 0 --port-file "$work/$mode.port" \
    --render-threads 1 > "$work/$mode.log" 2>&1 &
  pids+=($!)
done
for mode in aside inline; do
  for _ in $(seq 600); do [ -s "$work/$mode.port" ] && break; sleep 0.1; done
  port[$mode]=$(cat "$work/$mode.port")
done

csv=$out/encode-aside.csv
echo "# $(date -u +%Y-%m-%d), $(nproc) cores, $(git rev-parse --short HEAD); bash bench/run_encode_aside.sh --rounds $rounds --duration $duration --clients $clients --sizes $sizes --encodings $encodings" > "$csv"
echo "encoding,size,round,mode,frames_per_s,latency_p50_ms,latency_p99_ms,render_ms_p50,errors" >> "$csv"
for enc in ${encodings//,/ }; do
  for size in ${sizes//,/ }; do
    for r in $(seq 1 "$rounds"); do
      # Taking turns, the first one alternating by round.
      order="aside inline"; [ $((r % 2)) -eq 0 ] && order="inline aside"
      for mode in $order; do
        "$bin" load "127.0.0.1:${port[$mode]}" --dataset mri --tf mri --clients "$clients" --duration "$duration" \
          --size "${size}x${size}" --encoding "$enc" --json "$work/load.json" > /dev/null
        python3 -c "
import json; j = json.load(open('$work/load.json')); l = j['latency_ms']
print('$enc,$size,$r,$mode,%.2f,%.1f,%.1f,%.1f,%d' % (j['frames_per_s'], l['p50'], l['p99'], j.get('render_ms_p50') or 0, j['errors']))" >> "$csv"
        tail -1 "$csv"
      done
    done
  done
done

python3 - "$csv" > "$out/encode-aside.md" << 'EOF'
import csv, statistics, sys
lines = open(sys.argv[1]).read().splitlines()
head = lines[0].lstrip('# ')
rows = list(csv.DictReader(l for l in lines[1:]))
print(f"Still frames encoded aside (the default) against on the render thread, two servers side by side, one render thread each, the MRI, clients asking frames one at a time; {head}. Medians over the rounds.\n")
print("| encoding | size | aside frames/s | on the render thread frames/s | ratio | aside p50 ms | on the render thread p50 ms |")
print("|---|---:|---:|---:|---:|---:|---:|")
for key in dict.fromkeys((r['encoding'], r['size']) for r in rows):
    m = lambda mode, col: statistics.median(float(r[col]) for r in rows if (r['encoding'], r['size']) == key and r['mode'] == mode)
    print(f"| {key[0]} | {key[1]}² | {m('aside', 'frames_per_s'):.2f} | {m('inline', 'frames_per_s'):.2f} | "
          f"{m('aside', 'frames_per_s') / m('inline', 'frames_per_s'):.2f} | {m('aside', 'latency_p50_ms'):.0f} | {m('inline', 'latency_p50_ms'):.0f} |")
EOF
cat "$out/encode-aside.md"
