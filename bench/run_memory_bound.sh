#!/usr/bin/env bash
# Converts a 4 GiB raw volume (1024^3 float32 Gaussian blobs) with --memory 640 and records the peak resident set
# size that prep reports (getrusage ru_maxrss of the prep process). Writes bench/results/prep/memory_bound.txt.
set -euo pipefail
cd "$(dirname "$0")/.."
work=${WORK:-bench/work}
mkdir -p "$work" bench/results/prep
raw="$work/blobs-1024.raw"
[ -f "$raw" ] || ./build/bench/bench_store --make-raw "$raw" --spec blobs,n=1024
ls -l "$raw"
{
  echo "# voxbrick prep of a $(stat -c %s "$raw")-byte raw file, $(date -u +%Y-%m-%d), $(nproc) cores"
  echo "# command: voxbrick prep $raw --dims 1024,1024,1024 --type f32 --memory 640 -q -o $work/big.vbs --force"
  ./build/voxbrick prep "$raw" --dims 1024,1024,1024 --type f32 --memory 640 -q -o "$work/big.vbs" --force
  ./build/voxbrick info "$work/big.vbs" | sed -n '3,4p;8,20p'
} | tee bench/results/prep/memory_bound.txt
rm -rf "$work/big.vbs" "$raw"
