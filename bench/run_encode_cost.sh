#!/usr/bin/env bash
# What a VP8 and a VP9 frame cost to encode at each of the stream sizes (VideoStream::kScales), the power of its
# megapixels the time grows by (VideoStream::costExponent: the encoders' ladder predicts a smaller stream's time with
# it). bench_video on every third frame of the replay's SIZE² turn of the MRI (a 30 Hz drag shown at 10 frames a
# second), one encoder thread (a crowd's streams share the cores), KBPS at every size (the link sets the bitrate, not
# the size), the frames scaled before the encoding is timed (the server draws them at the stream's size); ROUNDS runs,
# each size's median. Writes bench/results/video/encode-cost.{csv,md}.
#
#   bash bench/run_encode_cost.sh [--size 1024] [--kbps 4719] [--rounds 3]
set -euo pipefail
cd "$(dirname "$0")/.."
size=1024 kbps=4719 rounds=3
while [ $# -gt 0 ]; do
  case "$1" in
    --size) size=$2; shift 2 ;;
    --kbps) kbps=$2; shift 2 ;;
    --rounds) rounds=$2; shift 2 ;;
    *) echo "run_encode_cost.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
tool=build/bench/bench_video
[ -x "$tool" ] || { echo "run_encode_cost.sh: build bench_video first (cmake --build build --target bench_video)" >&2; exit 2; }
source bench/browser_bench.sh
video_replay run_encode_cost.sh build/voxbrick "$size"
out=$work/encode-cost
mkdir -p "$out" bench/results/video
frames=()
for f in "$replay/${size}x${size}"/f*.png; do frames+=("$f"); done
thirds=()
for ((i = 0; i < ${#frames[@]}; i += 3)); do thirds+=("${frames[$i]}"); done
for r in $(seq "$rounds"); do
  "$tool" --csv "$out/round-$r.csv" --qualities 70 --kbps "$kbps" --fps 10 --threads 1 \
    --scales 1,0.75,0.5,0.375,0.25 -- "${thirds[@]}" > /dev/null
done
python3 - "$out" bench/results/video/encode-cost "$size" "$kbps" "$rounds" "${#thirds[@]}" <<'PY'
import csv, datetime, glob, math, re, statistics, sys
sys.path.insert(0, 'bench')
from video_crowd import write_rows
out, dest, size, kbps, rounds, frames = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5], sys.argv[6]
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
ms = {}
for f in sorted(glob.glob(f'{out}/round-*.csv')):
    for r in csv.DictReader(open(f)):
        if r['encoding'] not in ('vp8', 'vp9'):
            continue
        m = re.search(r'scale ([0-9.]+)', r['setting'])
        ms.setdefault((r['encoding'], float(m.group(1)) if m else 1.0), []).append(float(r['encode_ms']))
rows, fits = [], {}
for codec in ('vp8', 'vp9'):
    points = []
    for scale in sorted({s for c, s in ms if c == codec}, reverse=True):
        side = max(16, round(size * scale))
        mp = side * side / 1e6
        median = statistics.median(ms[(codec, scale)])
        points.append((math.log(mp), math.log(median)))
        rows.append({'codec': codec, 'scale': scale, 'side': side, 'megapixels': round(mp, 4),
                     'encode_ms_median': round(median, 2), 'encode_ms_rounds': ' '.join(f'{v:.2f}' for v in ms[(codec, scale)]),
                     'ms_per_megapixel': round(median / mp, 2)})
    mx = statistics.mean(p[0] for p in points)
    my = statistics.mean(p[1] for p in points)
    fits[codec] = sum((x - mx) * (y - my) for x, y in points) / sum((x - mx) ** 2 for x, _ in points)
write_rows(dest + '.csv', rows)
md = ['# What a video frame costs to encode at each stream size', '',
      f'- Command: `bash bench/run_encode_cost.sh --size {size} --kbps {kbps} --rounds {rounds}` (bench_video, {frames} '
      f'frames of the MRI\'s {size}² turn, one encoder thread, {kbps} kbit/s at every size, each frame scaled before its '
      'encoding is timed).',
      f'- Date: {datetime.date.today()}; machine: {cpu}, 2 cores, a shared virtual machine: times are this machine\'s.', '',
      '| codec | scale | side | encode ms (median of rounds) | the rounds | ms a megapixel |',
      '| --- | ---: | ---: | ---: | --- | ---: |']
for r in rows:
    md.append(f"| {r['codec']} | {r['scale']} | {r['side']} | {r['encode_ms_median']} | {r['encode_ms_rounds']} | "
              f"{r['ms_per_megapixel']} |")
md += ['', 'A smaller frame costs more a pixel: the time grows as the megapixels to the power (least squares over the '
       'sizes, log against log):', '']
for codec, slope in fits.items():
    md.append(f'- {codec}: **{slope:.2f}**')
md += ['', 'The encoders\' ladder (server/VideoStream: `costExponent`) predicts a stream\'s time at a smaller size with '
       'these powers, rounded; with a power of 1 (time in proportion to the pixels) a stream shrunk to fit its share '
       'was too slow at the size chosen and shrank again, a key frame each time.', '']
open(dest + '.md', 'w').write('\n'.join(md))
PY
cat bench/results/video/encode-cost.md
