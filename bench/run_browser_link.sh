#!/usr/bin/env bash
# A drag in real Chromium, JPEG against vp8 and vp9, on loopback and over a 10 Mbit/s, 40 ms link, side by side in one
# run (bench/browser_link.mjs): preps the MRI if needed, then writes bench/results/video/browser-link.{csv,md,json}.
# Needs voxbrick built and the browser tests' packages (cd tests/browser && npm ci). Other options pass through to
# browser_link.mjs (--sizes 512x512,1024x1024,1920x1080 --encodings jpeg,vp8,vp9 --links loopback,relay --duration 10).
# A run asking for fewer rows than its results file holds stops before it starts, naming those it would lose:
# --out PREFIX writes elsewhere (bench/work/, say), --replace writes over them.
#
#
# --replay-draw-ms MS: the server draws nothing (`voxbrick serve --replay-frames`): each frame is one drawn here
# beforehand by `voxbrick orbit` (the page's camera and scene, 2° apart; bench/work/video/replay, made once) and takes
# MS ms, a GPU's drawing time; everything else a frame goes through is measured. --out then defaults to
# bench/results/video/browser-link-replay.
#
#   bash bench/run_browser_link.sh [--replay-draw-ms MS] [options]
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/voxbrick
[ -x "$bin" ] || { echo "run_browser_link.sh: build voxbrick first" >&2; exit 2; }
[ -d tests/browser/node_modules/puppeteer-core ] ||
  { echo "run_browser_link.sh: run 'cd tests/browser && npm ci' first" >&2; exit 2; }
work=bench/work/video
datasets=$work/datasets
mkdir -p "$datasets" bench/results/video
[ -f "$work/mri.vbs/store.json" ] ||
  "$bin" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$work/mri.vbs" -q
[ -e "$datasets/mri" ] || ln -s ../mri.vbs "$datasets/mri"
export VOXBRICK_EXE=$PWD/$bin VOXBRICK_CONFIG_DIR=$PWD/config
export VOXBRICK_BENCH_COMMAND="bash bench/run_browser_link.sh${*:+ $*}"
# The options this script reads; the rest pass through.
drawMs=
sizes=512x512,1024x1024,1920x1080
pass=()
while [ $# -gt 0 ]; do
  case "$1" in
    --replay-draw-ms) drawMs=$2; shift 2 ;;
    --sizes) sizes=$2; pass+=("$1" "$2"); shift 2 ;;
    *) pass+=("$1"); shift ;;
  esac
done
if [ -z "$drawMs" ]; then
  exec node bench/browser_link.mjs --datasets "$datasets" --out bench/results/video/browser-link "${pass[@]}"
fi
# The replayed frames: the page's scene (bench/drag_common.mjs ORBIT: elevation 20, 2.5 radii, its drag starting at
# azimuth 0; transfer function mri, unshaded) turned 2° a frame, the page's 2° a move.
replay=$work/replay
for size in ${sizes//,/ }; do
  [ -f "$replay/$size/f179.png" ] && continue
  mkdir -p "$replay/$size"
  "$bin" orbit "$work/mri.vbs" --tf mri --orbit 0,20,2.5 --frames 180 --size "$size" -o "$replay/$size/f%03d.png" -q
done
python3 - "$replay" <<'PY'
import json, os, sys
root = sys.argv[1]
frames = [{"file": f"{size}/f{i:03d}.png", "azimuth": 2.0 * i, "elevation": 20.0}
          for size in sorted(os.listdir(root)) if os.path.isdir(os.path.join(root, size))
          for i in range(180) if os.path.isfile(os.path.join(root, size, f"f{i:03d}.png"))]
json.dump({"frames": frames}, open(os.path.join(root, "replay.json"), "w"), indent=1)
PY
node bench/browser_link.mjs --datasets "$datasets" --out bench/results/video/browser-link-replay --replay "$replay" \
  --replay-draw-ms "$drawMs" "${pass[@]}"
