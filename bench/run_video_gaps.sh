#!/usr/bin/env bash
# A video stream fed as a browser was shown a drag's frames, with gaps, against the same stream whose frames' bits are
# reckoned over the real gap: image::VideoSettings::maxFrameMs at its default (30 frames a second's share) and at 0.
# The times are those a headless Chromium on two cores was shown a 1024x1024 drag of the MRI through the 10 Mbit/s,
# 40 ms relay (bench/results/video/video-gaps-times.txt, from `node bench/browser_link.mjs ... --frames-out`: the
# frames' `at`; its gaps of 100-150 ms and one of half a second, where the page was busy, are what a real page shows);
# each time is fed the drag's frame of that moment (2° a frame at 30 a second: frames skipped over the gaps), from the
# frames `voxbrick orbit` draws for bench/run_browser_link.sh --replay-draw-ms. Writes
# bench/results/video/video-gaps.{csv,md}: bytes a frame (mean, p90, largest), the largest frame's time on a
# 10 Mbit/s link, and PSNR against the lossless frames.
#
#   bash bench/run_video_gaps.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/voxbrick
tool=build/bench/bench_video
[ -x "$bin" ] && [ -x "$tool" ] || { echo "run_video_gaps.sh: build voxbrick and bench_video first" >&2; exit 2; }
work=bench/work/video
frames=$work/replay/1024x1024
[ -f "$work/mri.vbs/store.json" ] || "$bin" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$work/mri.vbs" -q
if [ ! -f "$frames/f179.png" ]; then
  mkdir -p "$frames"
  "$bin" orbit "$work/mri.vbs" --tf mri --orbit 0,20,2.5 --frames 180 --size 1024x1024 -o "$frames/f%03d.png" -q
fi
times=bench/results/video/video-gaps-times.txt
csv=bench/results/video/video-gaps.csv
mapfile -t pngs < <(ls "$frames"/f*.png | sort)
"$tool" --csv "$csv" --fps 30 --times "$times" --qualities 85 --kbps 1000,2000,4719 --max-frame-ms 33.3,0 -- \
  "${pngs[@]}" > /dev/null
python3 - "$csv" bench/results/video/video-gaps.md "$times" <<'PY'
import csv, sys, datetime
rows = list(csv.DictReader(open(sys.argv[1])))
times = [float(t) for t in open(sys.argv[3]).read().split()]
gaps = sorted(b - a for a, b in zip(times, times[1:]))
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
out = ['# A video stream fed with gaps: each frame\'s bits reckoned over 30 frames a second\'s share, or over the real gap', '',
       '- Command: `bash bench/run_video_gaps.sh` (`bench_video --times bench/results/video/video-gaps-times.txt',
       '  --max-frame-ms 33.3,0`).',
       f'- Date: {datetime.date.today()}; machine: {cpu}. Bytes and PSNR do not depend on the machine, except VP8\'s, whose',
       '  speed libvpx adapts to the time encoding takes.',
       f'- The feed: {len(times)} frames over {(times[-1] - times[0]) / 1000:.1f} s, as headless Chromium showed a 1024x1024 MRI',
       f'  drag through the 10 Mbit/s, 40 ms relay; gaps p50 {gaps[len(gaps) // 2]:.0f} ms, p90 {gaps[int(0.9 * len(gaps))]:.0f} ms,',
       f'  largest {gaps[-1]:.0f} ms. Each frame is the drag\'s frame of its moment (2° a frame at 30 frames a second).',
       '- Capped: image::VideoSettings::maxFrameMs (the server\'s, 33.3 ms); real gaps: 0, libvpx\'s rate control giving',
       '  each frame the bitrate times the time since the frame before.',
       '- Largest on the link: the largest frame\'s time on a 10 Mbit/s link.', '',
       '| codec | kbit/s | frames\' bits | bytes/frame | p90 | largest | largest on the link ms | PSNR dB mean | min |',
       '| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |']
for r in rows:
    if r['encoding'] == 'jpeg':
        continue
    kbps = r['setting'].split()[0]
    how = 'real gaps' if 'real gaps' in r['setting'] else 'capped'
    out.append(f"| {r['encoding']} | {kbps} | {how} | {float(r['bytes_per_frame']):.0f} | {float(r['bytes_p90']):.0f} | "
               f"{float(r['bytes_max']):.0f} | {float(r['bytes_max']) * 8 / 10000:.0f} | {float(r['psnr_mean_db']):.2f} | "
               f"{float(r['psnr_min_db']):.2f} |")
j = next(r for r in rows if r['encoding'] == 'jpeg')
out += ['', f"JPEG q85 of the same frames: {float(j['bytes_per_frame']):.0f} bytes a frame, {float(j['psnr_mean_db']):.2f} dB.", '']
open(sys.argv[2], 'w').write('\n'.join(out))
PY
cat bench/results/video/video-gaps.md
