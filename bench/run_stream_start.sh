#!/usr/bin/env bash
# What starting a video stream costs the server, with glibc's malloc as it is and asking for transparent huge pages
# (GLIBC_TUNABLES=glibc.malloc.hugetlb=1, which `voxbrick serve` sets itself where the kernel grants them on request:
# cli/Allocator.cpp): bench_stream_start makes REPEATS encoders one after another (the server's settings) for 512²,
# 1024² and 1920x1080, VP8 and VP9, each with its key frame and the frame after. Writes
# bench/results/video/stream-start.{csv,md}.
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
cat bench/results/video/stream-start.md
