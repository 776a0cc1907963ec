#!/usr/bin/env bash
# The bottom of the interactive ladder (render/core/Interactive.cpp), where a crowd's frames end up: each rung as
# interactiveScene draws it, the ladder's and the rungs that could take their place, timed (drawing and scaling up)
# and against the exact frame (bench_interactive --rungs), on the MRI at 1024² and 512² (the crowd's scene: transfer
# function mri, step 1) and on a 512³ field of blobs at 1024². Writes bench/results/interactive/ladder-bottom-*.{md,csv}.
#
#   bash bench/run_ladder_bottom.sh [--views 4] [--repeats 3]
set -euo pipefail
cd "$(dirname "$0")/.."
views=4 repeats=3
while [ $# -gt 0 ]; do
  case "$1" in
    --views) views=$2; shift 2 ;;
    --repeats) repeats=$2; shift 2 ;;
    *) echo "run_ladder_bottom.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
tool=build/bench/bench_interactive
[ -x "$bin" ] && [ -x "$tool" ] || { echo "run_ladder_bottom.sh: build voxbrick and bench_interactive first" >&2; exit 2; }
source bench/browser_bench.sh
mri_datasets bench/work/video "$bin"
blobs=bench/work/interactive/blobs512.vbs
[ -f "$blobs/store.json" ] || "$bin" prep synthetic:blobs,n=512 -o "$blobs" -q
# The ladder's rungs from 0.35 of the sides down before and after the level-of-detail rungs were measured dominated,
# and the candidates beside them.
rungs=0.35:3:1,0.3:3:1,0.25:3:1,0.25:4:1,0.18:4:1,0.18:4:2,0.125:4:2,0.125:6:4,0.18:6:1,0.125:4:1,0.125:6:1
rungs=$rungs,0.09:4:1,0.09:6:1,0.0625:6:1,0.0625:6:2,0.0625:6:4
out=bench/results/interactive
"$tool" --store bench/work/video/mri.vbs --size 1024 --views "$views" --repeats "$repeats" --tf mri --step 1 \
  --out "$out" --name ladder-bottom-mri-1024 --rungs "$rungs"
"$tool" --store bench/work/video/mri.vbs --size 512 --views "$views" --repeats "$repeats" --tf mri --step 1 \
  --out "$out" --name ladder-bottom-mri-512 --rungs "$rungs"
"$tool" --store "$blobs" --size 1024 --views "$views" --repeats "$repeats" --out "$out" \
  --name ladder-bottom-blobs512-1024 --rungs "$rungs"
