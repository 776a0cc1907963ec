#!/usr/bin/env bash
# A crowd of video streams against memory.video_mb: CLIENTS `voxbrick load --drag` clients (30 cameras a second,
# interactive frames, moving frames as one VP9 or VP8 stream each, decoded in order) on a fresh `voxbrick serve` for
# each budget, which replays frames drawn beforehand (--replay-frames, 10 ms a frame: the drawing taken out, so that
# the encoders are what is measured). Reads the server's own figures at the end of each run (the load report's
# Stats): encoders held, the bytes counted for them, moving frames sent as JPEG, peak resident memory; and the
# server's resident memory 3 s after the clients have gone (/proc). Writes
# bench/results/video/video-memory.{csv,md}.
#
#   bash bench/run_video_memory.sh [--clients 16] [--size 1024] [--codec vp9] [--budgets 4096,512] [--duration 8]
set -euo pipefail
cd "$(dirname "$0")/.."
clients=16 size=1024 codec=vp9 budgets=4096,512 duration=8
while [ $# -gt 0 ]; do
  case "$1" in
    --clients) clients=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --codec) codec=$2; shift 2 ;;
    --budgets) budgets=$2; shift 2 ;;
    --duration) duration=$2; shift 2 ;;
    *) echo "run_video_memory.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
[ -x "$bin" ] || { echo "run_video_memory.sh: build voxbrick first" >&2; exit 2; }
source bench/browser_bench.sh
video_replay run_video_memory.sh "$bin" "$size"
mkdir -p bench/results/video
stop_server_on_exit
for budget in ${budgets//,/ }; do
  log=$work/video-memory-serve-$budget.log
  serve_in_background run_video_memory.sh "$log" "$bin" --datasets "$datasets" --render-threads 1 \
    --replay-frames "$replay" --replay-draw-ms 10 --video-memory "$budget"
  "$bin" load "127.0.0.1:$port" --dataset mri --tf mri --clients "$clients" --size "${size}x${size}" --drag 30 \
    --interactive 50 --provisional-encoding "$codec" --duration "$duration" --json "$work/video-memory-$budget.json" \
    > /dev/null
  # What the server holds once the clients have gone (their sessions closed, their encoders freed).
  sleep 3
  awk '/^VmRSS:/ { print $2 * 1024 }' "/proc/$pid/status" > "$work/video-memory-$budget.rss-after"
  stop_server
done
python3 - "$work" bench/results/video/video-memory "$budgets" "$clients" "$size" "$codec" "$duration" <<'PY'
import csv, json, sys, datetime
work, out_prefix, budgets, clients, size, codec, duration = sys.argv[1:8]
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
MiB = 1 << 20
rows = []
for budget in budgets.split(','):
    r = json.load(open(f'{work}/video-memory-{budget}.json'))
    s = r['server']
    v = s['video']
    frames = sum(v['encoded'][c]['frames'] for c in ('vp8', 'vp9'))
    per_client = [c['frames_per_s'] for c in r['per_client']]
    rows.append({
        'budget_mib': int(budget), 'clients': int(clients), 'size': f'{size}x{size}', 'codec': codec,
        'peak_counted_mib': round(v['memory_peak_bytes'] / MiB, 1), 'limit_mib': round(v['memory_limit_bytes'] / MiB),
        'video_frames': frames, 'jpeg_frames': v['jpeg_frames'], 'encoders_freed': v['encoders_freed'],
        'peak_rss_mib': round(s['memory']['peak_rss_bytes'] / MiB),
        'rss_after_mib': round(int(open(f'{work}/video-memory-{budget}.rss-after').read()) / MiB),
        'frames_per_s_per_client': round(min(per_client), 1),
        'frames_per_s_per_client_max': round(max(per_client), 1), 'latency_p50_ms': round(r['latency_ms']['p50']),
        'latency_p99_ms': round(r['latency_ms']['p99']), 'errors': r['errors'],
        'bytes_per_frame': round(r['payload_bytes_per_frame'])})
with open(out_prefix + '.csv', 'w', newline='') as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
    w.writeheader()
    w.writerows(rows)
out = ['# A crowd of video streams within memory.video_mb', '',
       f'- Command: `bash bench/run_video_memory.sh --clients {clients} --size {size} --codec {codec} --budgets {budgets} '
       f'--duration {duration}`', f'  ({clients} `voxbrick load --drag 30 --interactive 50 --provisional-encoding {codec}` '
       'clients on a fresh `voxbrick serve --render-threads 1', '  --replay-frames --replay-draw-ms 10 --video-memory MB` for '
       'each budget: the MRI\'s frames drawn beforehand, 10 ms each).',
       f'- Date: {datetime.date.today()}; machine: {cpu}, 2 cores, a shared virtual machine: the rates and latencies are this '
       'machine\'s (two', '  cores encode every stream); the encoders and bytes are the server\'s own figures at the end of '
       'the run (Stats), and do not depend on it.', '',
       '| video_mb | clients | encoders counted at most, MiB | video frames | JPEG frames (no room) | peak resident MiB | '
       'resident 3 s after the clients left, MiB | frames/s a client, min–max | latency p50 / p99 ms | bytes a frame | '
       'errors |',
       '| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |']
for r in rows:
    out.append(f"| {r['budget_mib']} | {r['clients']} | {r['peak_counted_mib']} | {r['video_frames']} | "
               f"{r['jpeg_frames']} | {r['peak_rss_mib']} | {r['rss_after_mib']} | {r['frames_per_s_per_client']}–"
               f"{r['frames_per_s_per_client_max']} | {r['latency_p50_ms']} / {r['latency_p99_ms']} | "
               f"{r['bytes_per_frame']} | {r['errors']} |")
out.append('')
open(out_prefix + '.md', 'w').write('\n'.join(out))
print('\n'.join(out))
PY
