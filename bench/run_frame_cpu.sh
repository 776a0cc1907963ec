#!/usr/bin/env bash
# A warm frame's work on the CPU, the ray caster's cell table kept between frames against one filled every frame
# (bench_frame_cpu, both paths in one run, the frames checked identical), then whole frames of this build against an
# older one (BASELINE: a build directory of the commit before, its `voxbrick`), taking turns, on the MRI and the
# 1024³ field. Writes bench/results/render/frame-cpu-*.{csv,md} and frame-cpu-ab.{csv,md}.
#
#   bash bench/run_frame_cpu.sh [--baseline DIR] [--views 24] [--rounds 7]
#
# The 1024³ blobs (f32, 3.9 GB stored) are prepped into bench/work when missing (about half a minute on 2 cores).
# The field's transfer function is a ramp from 0 at the window's low end, window [0.001, 1.34]: about 10 750 of its
# 32 768 level-0 bricks drawn, as many as a 2000 MB atlas of floats holds (llvmpipe allocates no larger 3D texture
# here); then window [1e-7, 1.34] with a half-float atlas: 22 655 bricks, as many as 1 780 MB of halves hold.
set -euo pipefail
cd "$(dirname "$0")/.."
baseline="" views=24 rounds=7
while [ $# -gt 0 ]; do
  case "$1" in
    --baseline) baseline=$2; shift 2 ;;
    --views) views=$2; shift 2 ;;
    --rounds) rounds=$2; shift 2 ;;
    *) echo "run_frame_cpu.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
tool=build/bench/bench_frame_cpu
[ -x "$tool" ] || { echo "run_frame_cpu.sh: build the benchmarks first (build/bench/bench_frame_cpu)" >&2; exit 2; }
mkdir -p bench/work bench/results/render
field=bench/work/blobs-1024.vbs
mri=bench/work/mri.vbs
[ -f "$field/store.json" ] || "$bin" prep synthetic:blobs,n=1024 -o "$field" --no-vdb -q
[ -f "$mri/store.json" ] || "$bin" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$mri" -q
ramp=bench/work/ramp.json
echo '{"points": [[0, 1, 1, 1, 0], [1, 1, 1, 1, 0.05]]}' > "$ramp"
out=bench/results/render

# The CPU's part of warm frames, both paths side by side (a small drag: 1° a view).
"$tool" --store "$field" --size 32 --views "$views" --degrees "$views" --lod 0 --tf "$ramp" --window 0.001,1.34 \
  --gpu-budget 2000 --host-budget 3000 --out "$out" --name frame-cpu-field-32
"$tool" --store "$field" --size 32 --views "$views" --degrees "$views" --lod 0 --tf "$ramp" --window 1e-7,1.34 \
  --gpu-budget 2000 --host-budget 4000 --atlas-format half --out "$out" --name frame-cpu-field-32-half
"$tool" --store "$field" --size 512 --views "$views" --degrees "$views" --lod 1 --tf hot --gpu-budget 1000 \
  --host-budget 2000 --out "$out" --name frame-cpu-field-512
"$tool" --store "$mri" --size 512 --views "$views" --degrees "$views" --lod 1 --tf mri --gpu-budget 512 \
  --host-budget 512 --out "$out" --name frame-cpu-mri-512

# Whole warm frames against the baseline build, taking turns (`voxbrick render --warm-up 2`: the third frame of one
# renderer, the same view).
[ -n "$baseline" ] || exit 0
csv=$out/frame-cpu-ab.csv
echo "# $(date -u +%Y-%m-%d), $(nproc) cores; baseline $baseline ($(git -C "$baseline/.." rev-parse --short HEAD 2> /dev/null || echo '?')), this build $(git rev-parse --short HEAD)" > "$csv"
echo "case,round,build,ms_total,ms_drawing,ms_outside" >> "$csv"
run() {  # case build-binary size dataset extra...
  local name=$1 exe=$2 size=$3 data=$4; shift 4
  "$exe" render "$data" -o bench/work/ab.png --size "${size}x${size}" --warm-up 2 --stats bench/work/ab.json -q "$@" > /dev/null
  python3 -c "import json,sys; s=json.load(open('bench/work/ab.json'))['ms']; print('%.3f,%.3f,%.3f' % (s['total'], s['drawing'], s['total'] - s['drawing'] - s['readback']))"
}
for r in $(seq 1 "$rounds"); do
  for c in "mri-512 512 $mri --tf mri" "mri-1024 1024 $mri --tf mri" \
           "field-32-lod0 32 $field --lod 0 --tf $ramp --window 0.001,1.34 --gpu-budget 2000 --host-cache 3000"; do
    set -- $c
    name=$1 size=$2 data=$3; shift 3
    for b in baseline this; do
      exe=$bin; [ "$b" = baseline ] && exe=$baseline/voxbrick
      echo "$name,$r,$b,$(run "$name" "$exe" "$size" "$data" "$@")" >> "$csv"
    done
  done
done
python3 - "$csv" > "$out/frame-cpu-ab.md" << 'EOF'
import csv, statistics, sys
rows = [r for r in csv.reader(l for l in open(sys.argv[1]) if not l.startswith('#'))][1:]
head = open(sys.argv[1]).readline().lstrip('# ').strip()
print(f"Warm frames (`voxbrick render --warm-up 2`, the third frame of one renderer), this build against the baseline, taking turns; {head}. Medians, ms; outside = total − drawing − readback.\n")
print("| case | baseline total | this total | ratio | baseline outside | this outside |")
print("|---|---:|---:|---:|---:|---:|")
for case in dict.fromkeys(r[0] for r in rows):
    m = lambda b, i: statistics.median(float(r[i]) for r in rows if r[0] == case and r[2] == b)
    print(f"| {case} | {m('baseline', 3):.1f} | {m('this', 3):.1f} | {m('this', 3) / m('baseline', 3):.2f} | {m('baseline', 5):.1f} | {m('this', 5):.1f} |")
EOF
echo "wrote $csv and $out/frame-cpu-ab.md"
