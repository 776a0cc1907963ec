#!/usr/bin/env bash
# What a moving frame drawn small under a crowd looks like, sent in a video stream of each size: the MRI's exact
# frames at SIZE² (`voxbrick orbit`, FRAMES views a turn: 10° apart, about what a stream of a crowd's 2° camera steps
# at 5 frames a second sees), and the same views drawn as the interactive ladder's cheapest rungs draw them (their
# size, step and level of detail, render/core/Interactive.cpp). Each rung's drawings are scaled up to each stream size
# (image::scaleImage, as the server scales a reduced drawing up to its stream's size) and sent as one VP9 stream with
# the server's settings at KBPS kbit/s and FPS frames a second (bench_video --scales above 1); each decoded frame is
# shown at SIZE² against the exact frame (bench_video --references). A stream that follows its drawing down is sent
# at the smallest size that holds the drawing (server/VideoStream.h, scaleForDrawing); before, such a drawing was
# scaled up to the size the link and the encoders allowed. Writes OUT.{csv,md}, OUT bench/results/video/drawing-psnr
# by default. Bytes and PSNR do not depend on the machine.
#
#   bash bench/run_drawing_psnr.sh [--size 1024] [--frames 36] [--kbps 1573,4718] [--fps 5] [--out OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
size=1024 frames=36 kbps=1573,4718 fps=5 dest=bench/results/video/drawing-psnr
while [ $# -gt 0 ]; do
  case "$1" in
    --size) size=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    --kbps) kbps=$2; shift 2 ;;
    --fps) fps=$2; shift 2 ;;
    --out) dest=$2; shift 2 ;;
    *) echo "run_drawing_psnr.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
tool=build/bench/bench_video
[ -x "$bin" ] && [ -x "$tool" ] || { echo "run_drawing_psnr.sh: build voxbrick and bench_video first" >&2; exit 2; }
source bench/browser_bench.sh
work=bench/work/video
mri_datasets "$work" "$bin"
out=$work/drawing-psnr
mkdir -p "$out" "$(dirname "$dest")"
# The crowd's scene (bench/run_stream_drawing.sh's `voxbrick load`): the MRI, transfer function mri, step 1, unshaded.
scene=(--tf mri --orbit 0,20,2.5 --frames "$frames")
[ -f "$out/exact/f000.png" ] ||
  "$bin" orbit "$work/mri.vbs" "${scene[@]}" --step 1 --size "${size}x${size}" -o "$out/exact/f%03d.png" -q
# The ladder's rungs drawn under the crowd: scale, step factor, level-of-detail factor (a scene of lod 1: the rung's
# lod is 1 where its factor is 1, the factor otherwise).
rungs="0.25:3:1 0.18:4:1 0.125:4:2 0.125:6:4"
streams="1 0.75 0.5 0.375 0.25"
csv=$dest.csv
rm -f "$csv"
for rung in $rungs; do
  IFS=: read -r scale stepFactor lodFactor <<< "$rung"
  side=$(python3 -c "print(max(1, round($size * $scale)))")
  dir=$out/rung-$scale-$stepFactor-$lodFactor
  [ -f "$dir/f000.png" ] ||
    "$bin" orbit "$work/mri.vbs" "${scene[@]}" --step "$stepFactor" --lod "$lodFactor" --size "${side}x${side}" \
      -o "$dir/f%03d.png" -q
  # Each stream size at least the drawing's, as a factor of the drawing's side.
  factors=$(python3 -c "
side, size = $side, $size
print(','.join(repr(round(size * float(s)) / side) for s in '$streams'.split() if round(size * float(s)) >= side))")
  mapfile -t pngs < <(ls "$dir"/f*.png | sort)
  "$tool" --csv "$dir/psnr.csv" --fps "$fps" --kbps "$kbps" --qualities 70 --scales "$factors" \
    --references "$out/exact" "${pngs[@]}" > /dev/null
  python3 - "$dir/psnr.csv" "$csv" "$scale" "$stepFactor" "$lodFactor" "$side" "$size" <<'PY'
import csv, os, re, sys
src, dest, scale, stepFactor, lodFactor, side, size = sys.argv[1:8]
rows = []
for r in csv.DictReader(open(src)):
    if r['encoding'] != 'vp9':  # (bench_video's JPEG rows are of the drawing at its own size: no server's frame)
        continue
    m = re.search(r'scale ([0-9.e+-]+)', r['setting'])
    factor = float(m.group(1)) if m else 1.0
    kbps = re.match(r'(\d+) kbit/s', r['setting'])
    rows.append({'rung_scale': scale, 'rung_step_factor': stepFactor, 'rung_lod_factor': lodFactor,
                 'drawn_side': side, 'encoding': r['encoding'], 'stream_side': round(int(side) * factor),
                 'kbps': kbps.group(1),
                 'bytes_per_frame': r['bytes_per_frame'], 'psnr_mean_db': r['psnr_mean_db'],
                 'psnr_min_db': r['psnr_min_db'], 'encode_ms': r['encode_ms']})
new = not os.path.exists(dest)
with open(dest, 'a', newline='') as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
    if new:
        w.writeheader()
    w.writerows(rows)
PY
done
/usr/bin/python3 - "$out" "$csv" "$dest.md" "$size" "$frames" "$kbps" "$fps" <<'PY'
import csv, datetime, glob, sys
import numpy as np
from PIL import Image
out, csvPath, mdPath, size, frames, kbps, fps = sys.argv[1:8]
size = int(size)
rows = list(csv.DictReader(open(csvPath)))
def psnr(a, b):
    mse = ((np.asarray(a, float) - np.asarray(b, float)) ** 2).mean()
    return 10 * np.log10(255 ** 2 / mse) if mse > 0 else 99.0
# Without any encoding: each drawing shown at SIZE² straight (Pillow's bilinear, centres aligned, as a browser's canvas).
straight = {}
for d in sorted(glob.glob(f'{out}/rung-*')):
    vals = []
    for path in sorted(glob.glob(f'{d}/f*.png')):
        exact = Image.open(f'{out}/exact/' + path.rsplit('/', 1)[1]).convert('RGB')
        vals.append(psnr(Image.open(path).convert('RGB').resize((size, size), Image.BILINEAR), exact))
    straight[d.rsplit('rung-', 1)[1]] = sum(vals) / len(vals)
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
md = ['# A moving frame drawn small, sent at each stream size', '',
      f'- Command: `bash bench/run_drawing_psnr.sh --size {size} --frames {frames} --kbps {kbps} --fps {fps}`',
      f'- Date: {datetime.date.today()}; machine: {cpu}, llvmpipe for the frames. Bytes and PSNR do not depend on the '
      'machine.',
      f'- The MRI at {size}², {frames} views 10° apart; each rung\'s drawing scaled up to the stream\'s side '
      '(image::scaleImage), sent as one VP9 stream (the server\'s settings) at the bitrate and frames a second given, '
      f'each decoded frame shown at {size}² (bilinear) against the exact frame. "Straight": the drawing shown at '
      f'{size}² with no stream between. Means over the views.', '']
for kb in kbps.split(','):
    md += [f'## {kb} kbit/s at {fps} frames a second', '',
           '| rung (scale, step ×, lod ×) | drawn side | straight dB | ' +
           ' | '.join(f'stream {s} dB (bytes)' for s in ('1024', '768', '512', '384', '256')) + ' |',
           '| --- | ---: | ---: | ' + ' | '.join('---:' for _ in range(5)) + ' |']
    for key in straight:
        scale, step, lod = key.split('-')
        sel = [r for r in rows if r['encoding'] == 'vp9' and r['kbps'] == kb and r['rung_scale'] == scale and
               r['rung_step_factor'] == step and r['rung_lod_factor'] == lod]
        cells = []
        for s in (1, 0.75, 0.5, 0.375, 0.25):
            hit = [r for r in sel if int(r['stream_side']) == round(size * s)]
            cells.append(f"{hit[0]['psnr_mean_db']} ({hit[0]['bytes_per_frame']})" if hit else '')
        md.append(f"| {scale}, {step}, {lod} | {sel[0]['drawn_side'] if sel else ''} | {straight[key]:.2f} | " +
                  ' | '.join(cells) + ' |')
    md.append('')
open(mdPath, 'w').write('\n'.join(md))
PY
cat "$dest.md"
