#!/usr/bin/env bash
# A drag in real Chromium, JPEG against vp8 and vp9, on loopback and over a 10 Mbit/s, 40 ms link, side by side in one
# run (bench/browser_link.mjs): preps the MRI if needed, then writes bench/results/video/browser-link.{csv,md,json}.
# Needs voxbrick built and the browser tests' packages (cd tests/browser && npm ci). Other options pass through to
# browser_link.mjs (--sizes 512x512,1024x1024,1920x1080 --encodings jpeg,vp8,vp9 --links loopback,relay --duration 10).
#
#   bash bench/run_browser_link.sh [options]
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
node bench/browser_link.mjs --datasets "$datasets" --out bench/results/video/browser-link "$@"
