#!/usr/bin/env bash
# A drag's frames as JPEG against a VP8/VP9 stream, at equal PSNR: renders the MRI turning 2° a frame (the viewer's
# drag: 2° a move at 30 moves a second) at each size with `voxbrick orbit` (the lossless frames a resting camera would
# get), then bench_video sends them as the server would: JPEG frames at several qualities, and one video stream at
# several bitrates with the server's encoder settings. Writes bench/results/video/video.{csv,md}. Bytes and PSNR do
# not depend on the machine; encode and decode ms are indicative only (a shared machine).
#
#   bash bench/run_video.sh [--sizes 512,1024] [--frames 60]
set -euo pipefail
cd "$(dirname "$0")/.."
nifti=/usr/share/mricron/templates/ch2better.nii.gz
sizes=512,1024
frames=60
while [ $# -gt 0 ]; do
  case "$1" in
    --sizes) sizes=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    *) echo "run_video.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
tool=build/bench/bench_video
[ -x "$bin" ] && [ -x "$tool" ] || { echo "run_video.sh: build voxbrick and bench_video first" >&2; exit 2; }
work=bench/work/video
store=$work/mri.vbs
mkdir -p "$work" bench/results/video
[ -f "$store/store.json" ] || "$bin" prep "$nifti" -o "$store" -q
csv=bench/results/video/video.csv
rm -f "$csv"
for size in ${sizes//,/ }; do
  dir=$work/drag-$size
  rm -rf "$dir"
  mkdir -p "$dir"
  # 180 frames a turn: 2° a frame; the first $frames of them are the drag.
  "$bin" orbit "$store" --tf mri --shading --frames 180 --size "${size}x${size}" -o "$dir/f%03d.png" -q
  mapfile -t pngs < <(ls "$dir"/f*.png | sort | head -n "$frames")
  "$tool" --csv "$dir/video.csv" --fps 30 "${pngs[@]}" > /dev/null
  if [ -f "$csv" ]; then tail -n +2 "$dir/video.csv" >> "$csv"; else cp "$dir/video.csv" "$csv"; fi
done
python3 - "$csv" bench/results/video/video.md "$frames" <<'PY'
import csv, sys, datetime, platform
rows = list(csv.DictReader(open(sys.argv[1])))
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), platform.processor())
out = ['# A drag as JPEG frames and as a video stream', '',
       f'- Command: `bash bench/run_video.sh` ({sys.argv[3]} frames of the MRI `ch2better.nii.gz`, transfer function `mri`, shaded,',
       '  turning 2° a frame, rendered losslessly by `voxbrick orbit`; each sent as JPEG frames, and as one VP8 and one VP9',
       '  stream at 30 frames a second with the server\'s encoder settings (image/Video.h: realtime, constant bitrate, no lag)).',
       f'- Date: {datetime.date.today()}; machine: {cpu}, Mesa llvmpipe for the frames. Bytes and PSNR (RGB, each decoded',
       '  frame against its lossless frame) do not depend on the machine; encode and decode ms are one core\'s, indicative.',
       '- Key bytes: the stream\'s first frame (a key frame).', '']
sizes = sorted({r['size'] for r in rows}, key=lambda s: int(s.split('x')[0]))
for size in sizes:
    mine = [r for r in rows if r['size'] == size]
    out += [f'## {size}', '', '| encoding | setting | bytes/frame | PSNR mean dB | PSNR min dB | encode ms | decode ms | key bytes |',
            '| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |']
    for r in mine:
        out.append(f"| {r['encoding']} | {r['setting']} | {float(r['bytes_per_frame']):.0f} | {float(r['psnr_mean_db']):.2f} | "
                   f"{float(r['psnr_min_db']):.2f} | {float(r['encode_ms']):.1f} | {float(r['decode_ms']):.1f} | "
                   f"{r['key_bytes'] if r['encoding'] != 'jpeg' else ''} |")
    out += ['', 'At equal PSNR: for each JPEG quality, the fewest bytes a video stream took for at least its mean PSNR '
            '(none: no bitrate measured reached it).', '',
            '| JPEG | its bytes/frame | its PSNR dB | vp8 bytes/frame (ratio) | vp9 bytes/frame (ratio) |',
            '| --- | ---: | ---: | ---: | ---: |']
    for j in [r for r in mine if r['encoding'] == 'jpeg']:
        jb, jp = float(j['bytes_per_frame']), float(j['psnr_mean_db'])
        cells = []
        for codec in ('vp8', 'vp9'):
            ok = [float(r['bytes_per_frame']) for r in mine if r['encoding'] == codec and float(r['psnr_mean_db']) >= jp]
            cells.append(f'{min(ok):.0f} ({min(ok) / jb:.2f})' if ok else 'none')
        out.append(f"| {j['setting']} | {jb:.0f} | {jp:.2f} | {cells[0]} | {cells[1]} |")
    out.append('')
open(sys.argv[2], 'w').write('\n'.join(out) + '\n')
PY
echo "run_video.sh: wrote bench/results/video/video.{csv,md}"
