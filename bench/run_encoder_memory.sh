#!/usr/bin/env bash
# What a video encoder holds, against what the server counts for it: bench_stream_start makes encoders with the
# server's settings (image::videoThreadsFor's threads for a machine of 2 and of 16 cores) from 256² to 2048², VP8 and
# VP9, has each encode its key frame and the frame after, and reads what malloc has given out for it (mallinfo2: every
# arena, and blocks of their own mappings) beside image::videoEncoderBytes, which memory.video_mb counts. Writes
# bench/results/video/encoder-memory.{csv,md}.
#
#   bash bench/run_encoder_memory.sh [--repeats 3]
set -euo pipefail
cd "$(dirname "$0")/.."
repeats=3
while [ $# -gt 0 ]; do
  case "$1" in
    --repeats) repeats=$2; shift 2 ;;
    *) echo "run_encoder_memory.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
tool=build/bench/bench_stream_start
[ -x "$bin" ] && [ -x "$tool" ] || { echo "run_encoder_memory.sh: build voxbrick and bench_stream_start first" >&2; exit 2; }
work=bench/work/video
mkdir -p "$work" bench/results/video
[ -f "$work/mri.vbs/store.json" ] || "$bin" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$work/mri.vbs" -q
frame=$work/stream-start-frame.png
[ -f "$frame" ] || "$bin" render "$work/mri.vbs" --tf mri --orbit 0,20,2.5 --size 1920x1080 -o "$frame" > /dev/null
sizes=256x256,512x512,1024x1024,1920x1080,2048x2048
for cores in 2 16; do
  "$tool" --csv "$work/encoder-memory-$cores.csv" --repeats "$repeats" --cores "$cores" --sizes "$sizes" "$frame" \
    > /dev/null
done
python3 - "$work/encoder-memory-2.csv" "$work/encoder-memory-16.csv" bench/results/video/encoder-memory "$repeats" <<'PY'
import csv, sys, datetime
runs = [(2, list(csv.DictReader(open(sys.argv[1])))), (16, list(csv.DictReader(open(sys.argv[2]))))]
out_prefix, repeats = sys.argv[3], sys.argv[4]
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
seen, rows = set(), []
for cores, run in runs:
    for r in run:
        key = (r['codec'], r['size'], r['threads'])
        if key in seen:
            continue  # the same encoder on both machines (VP8's one thread, a small VP9 stream)
        seen.add(key)
        rows.append((cores, r))
with open(out_prefix + '.csv', 'w', newline='') as f:
    w = csv.writer(f)
    w.writerow(['cores'] + list(rows[0][1].keys()))
    for cores, r in rows:
        w.writerow([cores] + list(r.values()))
out = ['# What a video encoder holds, and what the server counts for it', '',
       f'- Command: `bash bench/run_encoder_memory.sh --repeats {repeats}` (bench_stream_start: encoders made one after '
       'another with the', '  server\'s settings, each encoding its key frame and the frame after; image::videoThreadsFor\'s threads '
       'on a machine of 2 cores and of 16).',
       f'- Date: {datetime.date.today()}; machine: {cpu}, a virtual machine. The bytes do not depend on the machine, only on '
       'the codec, the size and the threads.',
       '- Held: what malloc had given out and not taken back once the encoder had encoded its two frames (glibc\'s '
       'mallinfo2, every', '  arena, blocks of their own mappings), the median of the repeats. Counted: '
       'image::videoEncoderBytes, what the server\'s', '  memory.video_mb counts for such an encoder (docs/server.md, '
       '"Budgets"). Resident: how much the process\'s resident set grew (pages', '  touched; freed memory is taken '
       'again first, so later rows grow less than they hold).', '',
       '| codec | size | threads | held MiB | counted MiB | counted / held | resident MiB |',
       '| --- | --- | ---: | ---: | ---: | ---: | ---: |']
for cores, r in rows:
    held, counted = float(r['held_mib']), float(r['estimate_mib'])
    out.append(f"| {r['codec']} | {r['size']} | {r['threads']} | {held:.1f} | {counted:.1f} | {counted / held:.2f} | "
               f"{r['resident_mib']} |")
out += ['', 'The model: VP8 (one thread, the server\'s) 0.5 MiB and 46 bytes a pixel; VP9 12 MiB with its first thread, '
        '7.5 MiB for each', 'further one, and 80 bytes a pixel. tests/image (Video.AnEncodersMemoryIsWhatTheServerCountsForIt) '
        'holds it within 15 % of', 'malloc\'s count for four encoders.', '']
open(out_prefix + '.md', 'w').write('\n'.join(out))
print('\n'.join(out))
PY
