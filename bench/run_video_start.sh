#!/usr/bin/env bash
# A video stream's first frames with and without the start's quantizer cap (image::VideoSettings::startFrames): the
# MRI drag's frames that bench/run_video.sh renders (it is run first when they are missing), sent by bench_video as
# one VP8 and one VP9 stream at several bitrates, each with the cap (the server's) and without. Writes
# bench/results/video/video-start.{csv,md}: the start's (first 11 frames') bytes and PSNR, and the whole drag's.
#
#   bash bench/run_video_start.sh [--frames 60]
set -euo pipefail
cd "$(dirname "$0")/.."
frames=60
while [ $# -gt 0 ]; do
  case "$1" in
    --frames) frames=$2; shift 2 ;;
    *) echo "run_video_start.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
tool=build/bench/bench_video
[ -x "$tool" ] || { echo "run_video_start.sh: build bench_video first" >&2; exit 2; }
work=bench/work/video
[ -f "$work/drag-512/f000.png" ] && [ -f "$work/drag-1024/f000.png" ] || bash bench/run_video.sh --sizes 512,1024
csv=bench/results/video/video-start.csv
rm -f "$csv"
# The bitrates: 0.025 bits a pixel (the least the server streams a size at), 0.05 (where it starts), 0.1 and 0.2.
for spec in 512:200,400,800,1600 1024:800,1500,3000,6000; do
  size=${spec%%:*}
  mapfile -t pngs < <(ls "$work/drag-$size"/f*.png | sort | head -n "$frames")
  "$tool" --csv "$work/start-$size.csv" --fps 30 --qualities 70 --kbps "${spec#*:}" --start-frames 11,0 -- \
    "${pngs[@]}" > /dev/null
  if [ -f "$csv" ]; then tail -n +2 "$work/start-$size.csv" >> "$csv"; else cp "$work/start-$size.csv" "$csv"; fi
done
python3 - "$csv" bench/results/video/video-start.md "$frames" <<'PY'
import csv, sys, datetime
rows = [r for r in csv.DictReader(open(sys.argv[1])) if r['encoding'] != 'jpeg']
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
out = ['# A video stream\'s start, with and without its quantizer cap', '',
       f'- Command: `bash bench/run_video_start.sh` (the first {sys.argv[3]} frames of `bash bench/run_video.sh`\'s drags of the MRI,',
       '  2° a frame at 30 frames a second, sent by `bench_video --start-frames 11,0`: the server\'s encoder settings with the',
       '  start\'s cap (image::VideoSettings::startFrames, 11 frames) and without it).',
       f'- Date: {datetime.date.today()}; machine: {cpu}. Bytes and PSNR (RGB, each decoded frame against its lossless',
       '  frame) do not depend on the machine, except VP8\'s, whose speed libvpx adapts to the time encoding takes.',
       '- The start: the stream\'s first 11 frames (a third of a second). Its share: 11 frames of the bitrate.',
       '- Bits a pixel: what the bitrate gives a frame at 30 frames a second; the server streams a size from 0.025 and',
       '  starts a stream at 0.05 (server/VideoStream.h).', '',
       '| size | codec | kbit/s | bits a pixel | start bytes/frame, capped / not (share) | start PSNR dB, capped / not | start worst frame dB, capped / not | drag bytes/frame, capped / not | drag PSNR dB, capped / not | drag worst frame dB, capped / not |',
       '| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |']
def pair(a, b, key, fmt):
    return f'{fmt.format(float(a[key]))} / {fmt.format(float(b[key]))}'
for r in rows:
    if 'no start cap' in r['setting']:
        continue
    kbps = int(r['setting'].split()[0])
    plain = next(p for p in rows if p['size'] == r['size'] and p['encoding'] == r['encoding']
                 and p['setting'] == f'{kbps} kbit/s; no start cap')
    w, h = (int(v) for v in r['size'].split('x'))
    share = kbps * 1000 / 8 / 30
    out.append(f"| {r['size']} | {r['encoding']} | {kbps} | {kbps * 1000 / 30 / (w * h):.3f} | "
               f"{pair(r, plain, 'start_bytes_per_frame', '{:.0f}')} ({share:.0f}) | "
               f"{pair(r, plain, 'start_psnr_mean_db', '{:.2f}')} | {pair(r, plain, 'start_psnr_min_db', '{:.2f}')} | "
               f"{pair(r, plain, 'bytes_per_frame', '{:.0f}')} | {pair(r, plain, 'psnr_mean_db', '{:.2f}')} | "
               f"{pair(r, plain, 'psnr_min_db', '{:.2f}')} |")
open(sys.argv[2], 'w').write('\n'.join(out) + '\n')
PY
echo "run_video_start.sh: wrote bench/results/video/video-start.{csv,md}"
