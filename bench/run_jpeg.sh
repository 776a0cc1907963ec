#!/usr/bin/env bash
# JPEG frames against lossless ones on the MRI: renders a few views at 512² and 1024² (the lossless frames the
# server would send as png), then bench_jpeg encodes each as the server's jpeg frame at several qualities, with
# 4:4:4 and 4:2:0 chroma, and measures bytes and PSNR against the lossless frame. Writes bench/results/jpeg/jpeg.{csv,md}.
# Bytes and PSNR do not depend on the machine; encode times are indicative only.
#
#   bash bench/run_jpeg.sh [--nifti FILE] [--sizes 512,1024] [--qualities 50,60,70,75,80,85,90,95]
set -euo pipefail
cd "$(dirname "$0")/.."
nifti=/usr/share/mricron/templates/ch2better.nii.gz
sizes=512,1024
qualities=50,60,70,75,80,85,90,95
while [ $# -gt 0 ]; do
  case "$1" in
    --nifti) nifti=$2; shift 2 ;;
    --sizes) sizes=$2; shift 2 ;;
    --qualities) qualities=$2; shift 2 ;;
    *) echo "run_jpeg.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
tool=build/bench/bench_jpeg
[ -x "$bin" ] && [ -x "$tool" ] || { echo "run_jpeg.sh: build voxbrick and bench_jpeg first" >&2; exit 2; }
work=bench/work/jpeg
store=$work/mri.vbs
mkdir -p "$work" bench/results/jpeg
[ -f "$store/store.json" ] || "$bin" prep "$nifti" -o "$store" -q
# Views a viewer shows: the MRI preset shaded from the front-left, the grayscale preset from the side, and the
# MRI preset from above (each frame fitted, opaque black background as the server sends it).
views=("mri-shaded:--tf mri --shading --orbit 30,20" "grayscale-left:--tf grayscale --view left"
       "mri-superior:--tf mri --view superior")
frames=()
for size in ${sizes//,/ }; do
  for view in "${views[@]}"; do
    name=${view%%:*}
    # shellcheck disable=SC2086
    "$bin" render "$store" ${view#*:} --size "${size}x${size}" -o "$work/$name-$size.png" > /dev/null
    frames+=("$work/$name-$size.png")
  done
done
csv=bench/results/jpeg/jpeg.csv
"$tool" --csv "$csv" --qualities "$qualities" -- "${frames[@]}"
python3 - "$csv" bench/results/jpeg/jpeg.md <<'PY'
import csv, sys
from collections import defaultdict
rows = list(csv.DictReader(open(sys.argv[1])))
out = ['# JPEG frames against lossless ones', '',
       'Produced by `bash bench/run_jpeg.sh` (the MRI `ch2better.nii.gz`, prepped; three views at each size rendered by',
       '`voxbrick render` on Mesa llvmpipe, 2 shared cores; then each frame encoded as the server encodes a jpeg frame).',
       'Bytes and PSNR (RGB against the lossless frame) do not depend on the machine; encode ms are indicative only',
       '(medians of 3, a shared machine).',
       'Each cell is the mean over the views of the size. Raw frames are 4 bytes a pixel.', '']
by = defaultdict(list)
for r in rows:
    by[(r['size'], r['encoding'], r['chroma'], r['quality'])].append(r)
sizes = sorted({r['size'] for r in rows}, key=lambda s: int(s.split('x')[0]))
for size in sizes:
    out += [f'## {size}', '', '| encoding | chroma | quality | bytes/frame | PSNR dB (min over views) | encode ms |',
            '| --- | --- | --- | --- | --- | --- |']
    keys = [k for k in by if k[0] == size]
    keys.sort(key=lambda k: (k[1] != 'png', k[1] != 'zstd_rgba8', k[2], int(k[3] or 0)))
    for k in keys:
        g = by[k]
        b = sum(int(r['bytes']) for r in g) / len(g)
        ps = [float(r['psnr_db']) for r in g]
        ms = sum(float(r['encode_ms']) for r in g) / len(g)
        p = 'lossless' if ps[0] == float('inf') else f'{sum(ps) / len(ps):.2f} ({min(ps):.2f})'
        out.append(f'| {k[1]} | {k[2] or "-"} | {k[3] or "-"} | {b:,.0f} | {p} | {ms:.1f} |')
    out.append('')
# The rule behind the defaults: per chroma layout, the lowest quality whose worst view reaches 40 dB at every size;
# then the layout that does it in fewer bytes.
out += ['## Choice', '',
        'Rule: for each chroma layout, the lowest quality whose worst view reaches 40 dB at every size; the layout',
        'that meets it in fewer bytes is the frames\' layout (`image::kFrameJpegChroma`) and its quality the default',
        '`jpeg_quality` (`image::kDefaultJpegQuality`).', '']
qualities = sorted({int(r['quality']) for r in rows if r['quality']})
for chroma in ('420', '444'):
    for q in qualities:
        worst = [min(float(r['psnr_db']) for r in by[(size, 'jpeg', chroma, str(q))]) for size in sizes]
        if min(worst) >= 40:
            sizes_bytes = ', '.join(
                f'{sum(int(r["bytes"]) for r in by[(size, "jpeg", chroma, str(q))]) / len(by[(size, "jpeg", chroma, str(q))]):,.0f} bytes at {size}'
                for size in sizes)
            out.append(f'- {chroma}: quality {q} ({sizes_bytes}; worst view {min(worst):.2f} dB)')
            break
out.append('')
open(sys.argv[2], 'w').write('\n'.join(out) + '\n')
PY
echo "wrote $csv and bench/results/jpeg/jpeg.md"
