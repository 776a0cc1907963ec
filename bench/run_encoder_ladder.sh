#!/usr/bin/env bash
# The crowd's ladder on the encoder threads ([scheduler] encoder_ladder), off against on, side by side in one run:
# CLIENTS `voxbrick load --drag 30` clients, each a VP9 (or VP8) stream of SIZE², on a fresh `voxbrick serve` for
# each round and setting, which replays frames drawn beforehand (--replay-frames, 10 ms a frame on RENDER_THREADS
# threads: the drawing taken out, so that the encoders are what is measured). Rounds alternate which setting goes
# first. Then what the smaller streams cost in PSNR: bench_video on the replay's frames (every third: a frame of a
# 30 Hz drag shown at 10 frames a second), at the stream's bitrate, at full size and at the scales the crowd took.
# Writes bench/results/video/encoder-ladder.{csv,md} and encoder-ladder-psnr.csv.
#
#   bash bench/run_encoder_ladder.sh [--clients 16] [--size 1024] [--codec vp9] [--render-threads 2] [--duration 20]
#                                    [--rounds 3]
set -euo pipefail
cd "$(dirname "$0")/.."
clients=16 size=1024 codec=vp9 renderThreads=2 duration=20 rounds=3
while [ $# -gt 0 ]; do
  case "$1" in
    --clients) clients=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --codec) codec=$2; shift 2 ;;
    --render-threads) renderThreads=$2; shift 2 ;;
    --duration) duration=$2; shift 2 ;;
    --rounds) rounds=$2; shift 2 ;;
    *) echo "run_encoder_ladder.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
video=build/bench/bench_video
[ -x "$bin" ] || { echo "run_encoder_ladder.sh: build voxbrick first" >&2; exit 2; }
[ -x "$video" ] || { echo "run_encoder_ladder.sh: build bench_video first (cmake --build build --target bench_video)" >&2; exit 2; }
source bench/browser_bench.sh
video_replay run_encoder_ladder.sh "$bin" "$size"
mkdir -p bench/results/video "$work/encoder-ladder"
stop_server_on_exit
for round in $(seq "$rounds"); do
  order="false true"
  [ $((round % 2)) -eq 0 ] && order="true false"
  for ladder in $order; do
    config=$work/encoder-ladder/$ladder.toml
    printf '# bench/run_encoder_ladder.sh\n[scheduler]\nencoder_ladder = %s\n' "$ladder" > "$config"
    log=$work/encoder-ladder/serve-$ladder-$round.log
    serve_in_background run_encoder_ladder.sh "$log" "$bin" --config "$config" --datasets "$datasets" \
      --render-threads "$renderThreads" --replay-frames "$replay" --replay-draw-ms 10
    crowd_drag "$bin" "$work/encoder-ladder/$ladder-$round.json" "$clients" "$size" "$codec" "$duration"
  done
done
# The stream's bitrate (VideoStream::capKbps: 0.15 bits a pixel at 30 frames a second), as a crowd's streams had it.
kbps=$(python3 -c "print(round($size * $size * 0.15 * 30 / 1000))")
frames=()
for f in "$replay/${size}x${size}"/f*.png; do frames+=("$f"); done
thirds=()
for ((i = 0; i < ${#frames[@]}; i += 3)); do thirds+=("${frames[$i]}"); done
"$video" --csv bench/results/video/encoder-ladder-psnr.csv --qualities 70,85 --kbps "$kbps" --fps 10 \
  --scales 1,0.75,0.5,0.375 -- "${thirds[@]}" > /dev/null
python3 - "$work/encoder-ladder" bench/results/video/encoder-ladder "$clients" "$size" "$codec" "$renderThreads" \
  "$duration" "$rounds" "$kbps" <<'PY'
import csv, datetime, sys
sys.path.insert(0, 'bench')
from video_crowd import crowd_row, median_of, range_of, write_rows
work, out, clients, size, codec, threads, duration, rounds, kbps = sys.argv[1:10]
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
rows = []
for r in range(1, int(rounds) + 1):
    for ladder in ('false', 'true'):
        row = crowd_row(f'{work}/{ladder}-{r}.json')
        rows.append({'encoder_ladder': 'on' if ladder == 'true' else 'off', 'round': r,
                     **{k: row[k] for k in ('fps_min', 'fps_max', 'jain', 'latency_p50_ms', 'latency_p99_ms',
                                            'bytes_per_frame', 'encode_ms_mean', 'video_frames')},
                     'scaled_for_encoders': row['scaled_frames']['encoders'],
                     'size_key_frames': row['size_key_frames'], 'errors': row['errors']})
write_rows(out + '.csv', rows)
med = lambda value, key: median_of(rows, 'encoder_ladder', value, key)
rng = lambda value, key: range_of(rows, 'encoder_ladder', value, key)
psnr = list(csv.DictReader(open(out + '-psnr.csv')))
md = ['# The crowd\'s ladder on the encoder threads: off against on', '',
      f'- Command: `bash bench/run_encoder_ladder.sh --clients {clients} --size {size} --codec {codec} --render-threads '
      f'{threads} --duration {duration} --rounds {rounds}`',
      f'  ({clients} `voxbrick load --drag 30 --interactive 50 --provisional-encoding {codec}` clients, {size}², on a fresh '
      f'`voxbrick serve --render-threads {threads} --replay-frames --replay-draw-ms 10`', '  for each round and setting, '
      '`[scheduler] encoder_ladder` false or true; the MRI\'s frames drawn beforehand, 10 ms each, so that the two '
      'encoder', '  threads are what is measured; rounds alternate which setting goes first).',
      f'- Date: {datetime.date.today()}; machine: {cpu}, 2 cores, a shared virtual machine: the load clients decode '
      'every stream on', '  the same two cores, so rates and latencies are this machine\'s; compare the two settings '
      'only with each other.', '',
      f'Medians of {rounds} rounds (the range over rounds after each):', '',
      '| encoder_ladder | frames/s a client, slowest | fastest | Jain | latency p50 ms | p99 ms | bytes a frame | '
      'encode ms a frame | frames sent smaller | size key frames | errors |',
      '| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |']
for mode in ('off', 'on'):
    md.append(f"| {mode} | {med(mode, 'fps_min')} ({rng(mode, 'fps_min')}) | {med(mode, 'fps_max')} | "
              f"{med(mode, 'jain')} | {med(mode, 'latency_p50_ms')} ({rng(mode, 'latency_p50_ms')}) | "
              f"{med(mode, 'latency_p99_ms')} ({rng(mode, 'latency_p99_ms')}) | {med(mode, 'bytes_per_frame')} | "
              f"{med(mode, 'encode_ms_mean')} | {med(mode, 'scaled_for_encoders')} of {med(mode, 'video_frames')} | "
              f"{med(mode, 'size_key_frames')} | {sum(r['errors'] for r in rows if r['encoder_ladder'] == mode)} |")
md += ['', f'What a smaller stream costs in PSNR (`bench_video` on every third frame of the replay\'s {size}² turn, 2° a '
       f'frame: a 30 Hz drag shown at 10 frames a second; {kbps} kbit/s, the most a {size}² stream is given; each '
       f'decoded frame scaled back to {size}² against its lossless frame; `encoder-ladder-psnr.csv`):', '',
       '| encoding | setting | bytes a frame | PSNR mean dB | PSNR min dB | encode ms (idle machine, indicative) |',
       '| --- | --- | ---: | ---: | ---: | ---: |']
for p in psnr:
    if p['encoding'] == 'jpeg' or p['encoding'] == codec:
        md.append(f"| {p['encoding']} | {p['setting']} | {p['bytes_per_frame']} | {float(p['psnr_mean_db']):.2f} | "
                  f"{float(p['psnr_min_db']):.2f} | {float(p['encode_ms']):.1f} |")
md.append('')
open(out + '.md', 'w').write('\n'.join(md))
print('\n'.join(md))
PY
