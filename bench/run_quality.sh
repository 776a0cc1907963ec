#!/usr/bin/env bash
# Quality by target, measured: calibrates each bench dataset (ml, sparse, mri) with `voxbrick bench --calibrate`,
# then judges `--quality psnr:X` frames against the reference and times `--quality ms:N` frames, at the default camera
# and orbit views other than the calibration's. Writes bench/results/quality/quality.{csv,md}.
#
#   bash bench/run_quality.sh [--datasets ml,sparse,mri] [--size 512x512] [--psnr 30,40,50] [--ms 100,200,500,1000]
#
# Stores, tables and reference frames stay in bench/work/quality (delete a store's quality.json to calibrate again).
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x build/voxbrick ] || { echo "run_quality.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
export VOXBRICK_CONFIG_DIR="${VOXBRICK_CONFIG_DIR:-$PWD/config}"
exec python3 bench/quality_bench.py "$@"
