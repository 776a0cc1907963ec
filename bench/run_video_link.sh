#!/usr/bin/env bash
# A drag over a slow link, JPEG against the video stream, side by side in one run: `voxbrick load --drag` (one client,
# 30 cameras a second, interactive frames, each Frame reported with FrameReceived as the viewer does) against a
# fresh `voxbrick serve` of the MRI, on loopback and through bench/link_relay.mjs (10 Mbit/s, 40 ms round trip, a
# 200 ms queue). Writes bench/results/video/link.{csv,md}.
#
#   bash bench/run_video_link.sh [--size 1024] [--duration 10] [--mbit 10] [--rtt-ms 40] [--encodings jpeg,vp8,vp9]
set -euo pipefail
cd "$(dirname "$0")/.."
size=1024
duration=10
mbit=10
rtt=40
encodings=jpeg,vp8,vp9
while [ $# -gt 0 ]; do
  case "$1" in
    --size) size=$2; shift 2 ;;
    --duration) duration=$2; shift 2 ;;
    --mbit) mbit=$2; shift 2 ;;
    --rtt-ms) rtt=$2; shift 2 ;;
    --encodings) encodings=$2; shift 2 ;;
    *) echo "run_video_link.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
[ -x "$bin" ] || { echo "run_video_link.sh: build voxbrick first" >&2; exit 2; }
work=bench/work/video
datasets=$work/datasets
mkdir -p "$datasets" bench/results/video
[ -f "$work/mri.vbs/store.json" ] ||
  "$bin" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$work/mri.vbs" -q
[ -e "$datasets/mri" ] || ln -s ../mri.vbs "$datasets/mri"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2> /dev/null || true; done; }
trap cleanup EXIT
start_server() {
  "$bin" serve --datasets "$datasets" --port 0 --render-threads 1 > "$work/serve.log" 2>&1 &
  pids+=($!)
  for _ in $(seq 100); do
    port=$(grep -ao 'listening on [0-9.]*:[0-9]*' "$work/serve.log" | head -1 | sed 's/.*://') || true
    [ -n "${port:-}" ] && return 0
    sleep 0.1
  done
  echo "run_video_link.sh: the server did not start: $(cat "$work/serve.log")" >&2
  exit 1
}
rows=$work/link-rows.jsonl
: > "$rows"
for link in loopback relay; do
  for encoding in ${encodings//,/ }; do
    start_server
    target=$port
    if [ "$link" = relay ]; then
      node bench/link_relay.mjs --target "$port" --listen 0 --mbit "$mbit" --delay-ms $((rtt / 2)) > "$work/relay.log" &
      pids+=($!)
      for _ in $(seq 50); do
        target=$(grep -ao 'listening on [0-9]*' "$work/relay.log" | sed 's/.* //') || true
        [ -n "${target:-}" ] && break
        sleep 0.1
      done
    fi
    out=$work/link-$link-$encoding.json
    "$bin" load "127.0.0.1:$target" --dataset mri --tf mri --clients 1 --size "${size}x${size}" --drag 30 \
      --interactive 50 --encoding png --provisional-encoding "$encoding" --duration "$duration" --json "$out" > /dev/null
    python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); d["link"]=sys.argv[2]; print(json.dumps(d))' \
      "$out" "$link" >> "$rows"
    cleanup
    pids=()
  done
done
python3 - "$rows" bench/results/video/link.csv bench/results/video/link.md "$size" "$duration" "$mbit" "$rtt" <<'PY'
import csv, json, sys, datetime
rows = [json.loads(l) for l in open(sys.argv[1])]
size, duration, mbit, rtt = sys.argv[4:8]
cols = ['link', 'provisional_encoding', 'frames_per_s', 'latency_p50_ms', 'latency_p99_ms', 'bytes_per_frame',
        'encode_ms_p50', 'decode_ms_p50', 'key_frames', 'errors']
table = []
for d in rows:
    v = d.get('video') or {}
    table.append({'link': d['link'], 'provisional_encoding': d.get('provisional_encoding'),
                  'frames_per_s': round(d['frames_per_s'], 1), 'latency_p50_ms': round(d['latency_ms']['p50'], 1),
                  'latency_p99_ms': round(d['latency_ms']['p99'], 1),
                  'bytes_per_frame': round(d['payload_bytes_per_frame']),
                  'encode_ms_p50': round(d['encode_ms_p50'], 2) if d.get('encode_ms_p50') is not None else '',
                  'decode_ms_p50': round(v['decode_ms']['p50'], 2) if v else '',
                  'key_frames': v.get('key_frames', '') if v else '', 'errors': d['errors']})
with open(sys.argv[2], 'w', newline='') as f:
    w = csv.DictWriter(f, fieldnames=cols)
    w.writeheader()
    w.writerows(table)
load = open('/proc/loadavg').read().split()[:3]
out = ['# A drag over a slow link: JPEG frames against a video stream', '',
       f'- Command: `bash bench/run_video_link.sh --size {size} --duration {duration} --mbit {mbit} --rtt-ms {rtt}`',
       f'- Date: {datetime.datetime.now().isoformat(timespec="minutes")}; 2 shared cores, Mesa llvmpipe; load average at the end {" ".join(load)}.',
       f'- One `voxbrick load --drag 30 --interactive 50` client at {size}², {duration} s, the MRI with the `mri` preset; each',
       '  Frame reported with FrameReceived; moving frames in the encoding named, exact frames png. `relay`: through',
       f'  bench/link_relay.mjs, {mbit} Mbit/s each way, {rtt} ms round trip, a 200 ms queue. Latency: from a camera sent to its',
       '  first frame received. Frames/s: first replies a second.', '',
       '| ' + ' | '.join(cols) + ' |', '|' + '---|' * len(cols)]
for r in table:
    out.append('| ' + ' | '.join(str(r[c]) for c in cols) + ' |')
open(sys.argv[3], 'w').write('\n'.join(out) + '\n')
PY
echo "run_video_link.sh: wrote bench/results/video/link.{csv,md}"
