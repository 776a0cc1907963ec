#!/usr/bin/env bash
# Moving frames drawn at their video stream's size, measured two ways in one run:
# 1. What it costs in PSNR: the MRI's exact frames (`voxbrick render`) at SIZE² and at each stream scale's size, for
#    VIEWS views about it; each against the SIZE² frame after being shown at SIZE² (bilinear, centres aligned, as a
#    browser's canvas scales), beside the SIZE² frame shrunk to the stream's size by area (what a stream did with a
#    frame drawn at the scene's size) and shown alike. A frame at the stream's size is drawn at the level of detail of
#    the scene's size (--lod 1 times the scale: what the server draws) and, for comparison, at its own (--lod 1).
#    Scaling by Pillow (BOX to shrink, BILINEAR to grow): the same filters as image::scaleImage. Exact drawings, so
#    that the drawing's size and level are the only differences.
# 2. What it changes under a crowd: CLIENTS `voxbrick load --drag 30 --interactive 50` clients, each a VP9 stream of
#    SIZE², drawing for real on RENDER_THREADS threads, against a fresh `voxbrick serve` of each build (OLD: a build
#    whose moving frames are drawn at the scene's size, e.g. `bash bench/gpu/build_baseline.sh --commit 8997678 --dir
#    bench/work/base-8997678`; NEW: this one), rounds alternating which goes first. NEW's `voxbrick load` is the client
#    of both (it reports the drawings' and the streams' scales).
# Writes OUT.{csv,md} and OUT-psnr.csv, OUT bench/results/video/stream-drawing by default. --views 0 leaves out the
# PSNR; --serve-args "ARGS" gives both servers more options (e.g. "--replay-frames DIR --replay-draw-ms 10": frames
# drawn beforehand, to compare two builds' encoders alone); --note "TEXT" a line under the title saying what differs.
#
#   bash bench/run_stream_drawing.sh OLD_VOXBRICK [NEW_VOXBRICK] [--clients 16] [--size 1024] [--codec vp9]
#                                    [--render-threads 2] [--duration 20] [--rounds 3] [--views 6] [--out OUT]
#                                    [--serve-args ARGS] [--note TEXT]
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 1 ] || { sed -n 2,16p "$0" >&2; exit 2; }
old=$(realpath "$1")
shift
new=$(realpath build/voxbrick)
if [ $# -gt 0 ] && [ "${1#--}" = "$1" ]; then new=$(realpath "$1"); shift; fi
clients=16 size=1024 codec=vp9 renderThreads=2 duration=20 rounds=3 views=6 dest=bench/results/video/stream-drawing
serveArgs= note=
while [ $# -gt 0 ]; do
  case "$1" in
    --out) dest=$2; shift 2 ;;
    --serve-args) serveArgs=$2; shift 2 ;;
    --note) note=$2; shift 2 ;;
    --clients) clients=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --codec) codec=$2; shift 2 ;;
    --render-threads) renderThreads=$2; shift 2 ;;
    --duration) duration=$2; shift 2 ;;
    --rounds) rounds=$2; shift 2 ;;
    --views) views=$2; shift 2 ;;
    *) echo "run_stream_drawing.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
[ -x "$old" ] && [ -x "$new" ] || { echo "run_stream_drawing.sh: no voxbrick at $old or $new" >&2; exit 2; }
source bench/browser_bench.sh
work=bench/work/video
datasets=$work/datasets
mri_datasets "$work" "$new"
out=$work/stream-drawing
mkdir -p "$(dirname "$dest")" "$out"
stop_server_on_exit

# 1. PSNR: exact frames at the scene's size and at each scale's.
scales="0.75 0.5 0.375 0.25"
for ((v = 0; v < views; v++)); do
  az=$((v * 360 / views + 15))
  for s in 1 $scales; do
    side=$(python3 -c "print(max(1, round($size * $s)))")
    [ -f "$out/view$v-$side.png" ] ||
      "$new" render "$work/mri.vbs" -o "$out/view$v-$side.png" --size "${side}x${side}" --tf mri --orbit "$az,20" -q
    [ -f "$out/view$v-$side-scene-lod.png" ] ||
      "$new" render "$work/mri.vbs" -o "$out/view$v-$side-scene-lod.png" --size "${side}x${side}" --tf mri \
        --orbit "$az,20" --lod "$s" -q
  done
done
[ "$views" -gt 0 ] && /usr/bin/python3 - "$out" "$size" "$views" "$scales" "$dest-psnr.csv" <<'PY'
import csv, sys
import numpy as np
from PIL import Image
out, size, views, scales, csvPath = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4].split(), sys.argv[5]
def psnr(a, b):
    mse = ((np.asarray(a, float) - np.asarray(b, float)) ** 2).mean()
    return 10 * np.log10(255 ** 2 / mse) if mse > 0 else 99.0
rows = []
for v in range(views):
    full = Image.open(f'{out}/view{v}-{size}.png').convert('RGB')
    for s in scales:
        side = max(1, round(size * float(s)))
        shown = lambda path: Image.open(path).convert('RGB').resize((size, size), Image.BILINEAR)
        shrunk = full.resize((side, side), Image.BOX)
        rows.append({'view': v, 'scale': s, 'side': side,
                     'psnr_drawn_at_stream_size_db': round(psnr(shown(f'{out}/view{v}-{side}-scene-lod.png'), full), 2),
                     'psnr_drawn_at_stream_size_own_lod_db': round(psnr(shown(f'{out}/view{v}-{side}.png'), full), 2),
                     'psnr_drawn_full_then_shrunk_db': round(psnr(shrunk.resize((size, size), Image.BILINEAR), full), 2)})
with open(csvPath, 'w', newline='') as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
    w.writeheader()
    w.writerows(rows)
PY

# 2. The crowd, each build on a fresh server.
for round in $(seq "$rounds"); do
  order="old new"
  [ $((round % 2)) -eq 0 ] && order="new old"
  for build in $order; do
    bin=$old
    [ "$build" = new ] && bin=$new
    # shellcheck disable=SC2086
    serve_in_background run_stream_drawing.sh "$out/serve-$build-$round.log" "$bin" --datasets "$datasets" \
      --render-threads "$renderThreads" $serveArgs
    crowd_drag "$new" "$out/$build-$round.json" "$clients" "$size" "$codec" "$duration"
  done
done
python3 - "$out" "$dest" "$clients" "$size" "$codec" "$renderThreads" "$duration" "$rounds" "$views" "$old" "$new" \
  "$serveArgs" "$note" <<'PY'
import csv, datetime, os, statistics, sys
sys.path.insert(0, 'bench')
from video_crowd import crowd_row, median_of, range_of, write_rows
out, dest, clients, size, codec, threads, duration, rounds, views, old, new, serveArgs, note = sys.argv[1:14]
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
def commit(binary):
    path = os.path.join(os.path.dirname(binary), 'COMMIT')
    return open(path).read().strip()[:7] if os.path.exists(path) else 'this build'
rows = []
for r in range(1, int(rounds) + 1):
    for build in ('old', 'new'):
        row = crowd_row(f'{out}/{build}-{r}.json')
        row['scaled_frames'] = sum(row['scaled_frames'].values())
        rows.append({'build': build, 'round': r, **row})
write_rows(dest + '.csv', rows)
med = lambda value, key: median_of(rows, 'build', value, key)
rng = lambda value, key: range_of(rows, 'build', value, key)
psnr = list(csv.DictReader(open(dest + '-psnr.csv'))) if int(views) > 0 else []
extra = f" --serve-args '{serveArgs}'" if serveArgs else ''
title = ('Moving frames drawn at their video stream\'s size' if int(views) > 0 else
         f'Two builds under a crowd of {codec} moving frames')
md = [f'# {title}', ''] + ([note, ''] if note else []) + [
      f'- Command: `bash bench/run_stream_drawing.sh OLD_VOXBRICK --clients {clients} --size {size} --codec {codec} '
      f'--render-threads {threads} --duration {duration} --rounds {rounds} --views {views} --out {dest}{extra}`;',
      f'  OLD is {commit(old)}, NEW {commit(new)}.',
      f'- Date: {datetime.date.today()}; machine: {cpu}, 2 cores, a shared virtual machine'
      f"{'' if serveArgs else ', llvmpipe drawing'}: the load "
      'clients decode every stream on the same', '  two cores, so rates and latencies are this machine\'s; compare '
      'the two builds only with each other.']
if psnr:
    md += ['', f'## What it costs in PSNR', '',
      f'The MRI\'s exact frames at {size}² and at each stream size, {views} views; each shown at {size}² (bilinear, '
      'centres aligned) against the', f'{size}² frame (`{os.path.basename(dest)}-psnr.csv`). Means over the views:', '',
      '| stream scale | side | drawn at the stream\'s size, the scene\'s level of detail (the server) dB | '
      'drawn at the stream\'s size, its own level dB | drawn at the scene\'s size, shrunk by area dB |',
      '| ---: | ---: | ---: | ---: | ---: |']
for s in dict.fromkeys(p['scale'] for p in psnr):
    sel = [p for p in psnr if p['scale'] == s]
    mean = lambda key: f"{statistics.mean(float(p[key]) for p in sel):.2f}"
    md.append(f"| {s} | {sel[0]['side']} | {mean('psnr_drawn_at_stream_size_db')} | "
              f"{mean('psnr_drawn_at_stream_size_own_lod_db')} | {mean('psnr_drawn_full_then_shrunk_db')} |")
drawing = f'`{serveArgs}`' if serveArgs else 'drawing for real'
md += ['', f'## Under a crowd', '',
       f'{clients} `voxbrick load --drag 30 --interactive 50 --provisional-encoding {codec}` clients at {size}², a '
       f'fresh `voxbrick serve --render-threads {threads}` of each build', f'for each round, {drawing}; medians '
       f'of {rounds} rounds (the range over rounds after each):', '',
       '| build | frames/s a client, slowest | fastest | Jain | latency p50 ms | p99 ms | render ms p50 | '
       'encode ms a frame | bytes a frame | frames sent smaller | size key frames | drawn at, p50 | sent at, p50 | '
       'errors |',
       '| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |']
for build in ('old', 'new'):
    md.append(f"| {build} ({commit(old if build == 'old' else new)}) | {med(build, 'fps_min')} "
              f"({rng(build, 'fps_min')}) | {med(build, 'fps_max')} | {med(build, 'jain')} | "
              f"{med(build, 'latency_p50_ms')} ({rng(build, 'latency_p50_ms')}) | {med(build, 'latency_p99_ms')} "
              f"({rng(build, 'latency_p99_ms')}) | {med(build, 'render_ms_p50')} | {med(build, 'encode_ms_mean')} | "
              f"{med(build, 'bytes_per_frame')} | {med(build, 'scaled_frames')} of {med(build, 'video_frames')} | "
              f"{med(build, 'size_key_frames')} | {med(build, 'drawn_scale_p50')} | {med(build, 'sent_scale_p50')} | "
              f"{sum(r['errors'] for r in rows if r['build'] == build)} |")
md.append('')
open(dest + '.md', 'w').write('\n'.join(md))
PY
cat "$dest.md"
