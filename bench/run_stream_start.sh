#!/usr/bin/env bash
# What starting a video stream costs the server, with glibc's malloc as it is and asking for transparent huge pages
# (GLIBC_TUNABLES=glibc.malloc.hugetlb=1, which `voxbrick serve` sets itself where the kernel grants them on request:
# cli/Allocator.cpp): bench_stream_start makes REPEATS encoders one after another (the server's settings) for 512²,
# 1024² and 1920x1080, VP8 and VP9, each with its key frame and the frame after. Writes
# bench/results/video/stream-start.{csv,md}. Then what an encoder holds against what the server counts for it:
# encoders from 256² to 2048² with image::videoThreadsFor's threads on a machine of 2 cores and of 16, what malloc has
# given out for each (mallinfo2: every arena, blocks of their own mappings) beside image::videoEncoderBytes, which
# memory.video_mb counts. Writes bench/results/video/encoder-memory.{csv,md}.
#
#   bash bench/run_stream_start.sh [--repeats 5]
set -euo pipefail
cd "$(dirname "$0")/.."
repeats=5
while [ $# -gt 0 ]; do
  case "$1" in
    --repeats) repeats=$2; shift 2 ;;
    *) echo "run_stream_start.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
tool=build/bench/bench_stream_start
[ -x "$bin" ] && [ -x "$tool" ] || { echo "run_stream_start.sh: build voxbrick and bench_stream_start first" >&2; exit 2; }
work=bench/work/video
mkdir -p "$work" bench/results/video
[ -f "$work/mri.vbs/store.json" ] || "$bin" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$work/mri.vbs" -q
frame=$work/stream-start-frame.png
[ -f "$frame" ] || "$bin" render "$work/mri.vbs" --tf mri --orbit 0,20,2.5 --size 1920x1080 -o "$frame" > /dev/null
env -u GLIBC_TUNABLES "$tool" --csv "$work/stream-start-plain.csv" --repeats "$repeats" "$frame" > /dev/null
GLIBC_TUNABLES=glibc.malloc.hugetlb=1 "$tool" --csv "$work/stream-start-huge.csv" --repeats "$repeats" "$frame" > /dev/null
python3 - "$work/stream-start-plain.csv" "$work/stream-start-huge.csv" bench/results/video/stream-start "$repeats" <<'PY'
import csv, sys, datetime
plain, huge = (list(csv.DictReader(open(p))) for p in sys.argv[1:3])
out_prefix, repeats = sys.argv[3], sys.argv[4]
mode = open('/sys/kernel/mm/transparent_hugepage/enabled').read().strip()
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
with open(out_prefix + '.csv', 'w', newline='') as f:
    w = csv.writer(f)
    w.writerow(['malloc'] + list(plain[0].keys()))
    for name, rows in (('plain', plain), ('huge pages', huge)):
        for r in rows:
            w.writerow([name] + list(r.values()))
out = ['# What starting a video stream costs: glibc\'s malloc as it is, and on transparent huge pages', '',
       f'- Command: `bash bench/run_stream_start.sh --repeats {repeats}` (bench_stream_start: {repeats} encoders made one after',
       '  another in one process, the server\'s settings and threads, for each codec and size; a frame of the MRI scaled',
       '  to each size).',
       f'- Date: {datetime.date.today()}; machine: {cpu}, a virtual machine (page faults are dear here); the kernel\'s',
       f'  transparent huge pages: `{mode}`.',
       '- Plain: glibc\'s malloc as the server had it (cli/Allocator.cpp: blocks up to 32 MB kept for reuse, as here in',
       '  both). Huge pages:',
       '  GLIBC_TUNABLES=glibc.malloc.hugetlb=1, which `voxbrick serve` now sets itself where the mode is madvise.',
       '- ms: the encoder\'s construction (the first of the process, and the median), its key frame (first, median), the',
       '  frame after (median); MiB: the most the resident set grew while one encoder was made and encoded its two',
       '  frames (memory the encoders before it freed is taken again first: later rows grow less than they hold).', '',
       '| codec | size | threads | make ms, first / median: plain | huge pages | key frame ms, first / median: plain | huge pages | next frame ms: plain | huge pages | MiB: plain | huge pages |',
       '| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |']
for p, h in zip(plain, huge):
    out.append(f"| {p['codec']} | {p['size']} | {p['threads']} | {p['first_construct_ms']} / {p['construct_ms']} | "
               f"{h['first_construct_ms']} / {h['construct_ms']} | {p['first_key_ms']} / {p['key_ms']} | "
               f"{h['first_key_ms']} / {h['key_ms']} | {p['next_ms']} | {h['next_ms']} | {p['resident_mib']} | {h['resident_mib']} |")
open(out_prefix + '.md', 'w').write('\n'.join(out) + '\n')
PY
for cores in 2 16; do
  "$tool" --csv "$work/encoder-memory-$cores.csv" --repeats "$repeats" --cores "$cores" \
    --sizes 256x256,512x512,1024x1024,1920x1080,2048x2048 "$frame" > /dev/null
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
       f'- Command: `bash bench/run_stream_start.sh --repeats {repeats}` (its second part; bench_stream_start: encoders made '
       'one after another with the', '  server\'s settings, each encoding its key frame and the frame after; image::videoThreadsFor\'s threads '
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
PY
cat bench/results/video/stream-start.md
cat bench/results/video/encoder-memory.md
