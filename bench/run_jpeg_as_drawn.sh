#!/usr/bin/env bash
# A provisional JPEG frame sent as drawn (protocol version 8) against the same drawing scaled up first (version 7):
# the MRI's exact frames at SIZE² for VIEWS views, and its drawings at each of SIDES pixels a side (`voxbrick render`
# at the level of detail of their scale, as the interactive ladder draws them); each drawing JPEG-encoded as drawn at
# qualities 70-95 and shown scaled up bilinearly (as a browser's canvas does), and scaled up first and encoded at 70
# and 85; PSNR (RGB) of what is shown against the exact frame, and bytes. JPEG by Pillow (libjpeg-turbo, the IJG
# quality scale the server's libjpeg-turbo uses). Writes OUT.{csv,md}, OUT bench/results/jpeg/as-drawn by default.
#
#   bash bench/run_jpeg_as_drawn.sh [--size 512] [--sides 64,128,256] [--views 6] [--out OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
size=512 sides=64,128,256 views=6 dest=bench/results/jpeg/as-drawn
while [ $# -gt 0 ]; do
  case "$1" in
    --size) size=$2; shift 2 ;;
    --sides) sides=$2; shift 2 ;;
    --views) views=$2; shift 2 ;;
    --out) dest=$2; shift 2 ;;
    *) echo "run_jpeg_as_drawn.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
exe=$(realpath build/voxbrick)
source bench/browser_bench.sh
work=bench/work/jpeg-as-drawn
mri_datasets "$work" "$exe"
mkdir -p "$(dirname "$dest")" "$work/frames"
for ((v = 0; v < views; v++)); do
  az=$((v * 360 / views + 15))
  [ -f "$work/frames/full-$v-$size.png" ] ||
    "$exe" render "$work/mri.vbs" -o "$work/frames/full-$v-$size.png" --size "${size}x${size}" --tf mri --orbit "$az,20" -q
  for s in ${sides//,/ }; do
    [ -f "$work/frames/drawn-$v-$s.png" ] ||
      "$exe" render "$work/mri.vbs" -o "$work/frames/drawn-$v-$s.png" --size "${s}x${s}" --tf mri --orbit "$az,20" \
        --lod "$(python3 -c "print($s / $size)")" -q
  done
done
/usr/bin/python3 - "$work/frames" "$dest" "$size" "$sides" "$views" <<'PY'
import csv, datetime, io, statistics, sys
import numpy as np
from PIL import Image, features
frames, dest, size, sides, views = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4].split(','), int(sys.argv[5])
def psnr(a, b):
    mse = ((np.asarray(a, float) - np.asarray(b, float)) ** 2).mean()
    return 10 * np.log10(255 ** 2 / mse) if mse > 0 else 99.0
def jpeg(image, quality):
    out = io.BytesIO()
    image.save(out, 'JPEG', quality=quality)
    return Image.open(io.BytesIO(out.getvalue())).convert('RGB'), len(out.getvalue())
rows = []
for v in range(views):
    full = Image.open(f'{frames}/full-{v}-{size}.png').convert('RGB')
    for side in sides:
        drawn = Image.open(f'{frames}/drawn-{v}-{side}.png').convert('RGB')
        grown = drawn.resize((size, size), Image.BILINEAR)
        rows.append({'view': v, 'side': side, 'sent': 'none (the drawing, lossless)', 'quality': '',
                     'bytes': '', 'psnr_db': round(psnr(grown, full), 2)})
        for q in (70, 85):
            shown, n = jpeg(grown, q)
            rows.append({'view': v, 'side': side, 'sent': 'scaled up, then jpeg', 'quality': q, 'bytes': n,
                         'psnr_db': round(psnr(shown, full), 2)})
        for q in (70, 80, 85, 90, 95):
            decoded, n = jpeg(drawn, q)
            rows.append({'view': v, 'side': side, 'sent': 'jpeg as drawn, scaled up by the client', 'quality': q,
                         'bytes': n, 'psnr_db': round(psnr(decoded.resize((size, size), Image.BILINEAR), full), 2)})
with open(dest + '.csv', 'w', newline='') as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
    w.writeheader()
    w.writerows(rows)
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
md = ['# Provisional JPEG frames sent as drawn, against scaled up first', '',
      f'- Command: `bash bench/run_jpeg_as_drawn.sh --size {size} --sides {",".join(sides)} --views {views} --out {dest}`',
      f'- Date: {datetime.date.today()}; machine: {cpu}, Mesa llvmpipe for the frames (bytes and PSNR do not depend on '
      f'the machine); JPEG by Pillow {Image.__version__} (libjpeg-turbo {features.version("libjpeg_turbo") or "?"}).',
      f'- The MRI at {size}², {views} views about it; each drawing (`voxbrick render` at SIDE², `--lod SIDE/{size}`) '
      f'shown at {size}² (bilinear, centres aligned) against the exact {size}² frame. Means over the views.', '',
      '| side | sent | quality | bytes | PSNR dB | bytes / scaled up q85 |', '| ---: | --- | ---: | ---: | ---: | ---: |']
for side in sides:
    base = statistics.mean(r['bytes'] for r in rows if r['side'] == side and r['sent'].startswith('scaled')
                           and r['quality'] == 85)
    seen = []
    for r in rows:
        key = (r['sent'], r['quality'])
        if r['side'] != side or key in seen:
            continue
        seen.append(key)
        sel = [x for x in rows if x['side'] == side and (x['sent'], x['quality']) == key]
        mean_bytes = statistics.mean(x['bytes'] for x in sel) if sel[0]['bytes'] != '' else None
        md.append(f"| {side} | {key[0]} | {key[1]} | {'' if mean_bytes is None else f'{mean_bytes:.0f}'} | "
                  f"{statistics.mean(x['psnr_db'] for x in sel):.2f} | "
                  f"{'' if mean_bytes is None else f'{mean_bytes / base:.2f}'} |")
md.append('')
open(dest + '.md', 'w').write('\n'.join(md))
PY
cat "$dest.md"
