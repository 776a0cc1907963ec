#!/usr/bin/env bash
# Ray-driven against octree residency (`--residency rays` against `--residency octree`) on a sparse 8192³ volume
# read live from a .vdb that bench_residency writes (an opaque shell around translucent balls, and the same balls in
# the open), ray-cast at 256² under a 1 GiB atlas: per frame of a still camera (8) and a short drag (8 frames of 2°),
# the bricks the octree wanted, each mode's bricks paged, the bricks the rays requested and never reached, frame
# times, and the PSNR of the rays mode's frame against the octree mode's. The .vdb (about 60 MB) is removed after.
# Writes bench/results/render/residency.{csv,md}.
#
#   bash bench/run_residency.sh [--n 8192] [--size 256] [--still 8] [--drag 8]
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BENCH_RESIDENCY:-build/bench/bench_residency}
[ -x "$bin" ] || { echo "run_residency.sh: build bench_residency first (-DVOXBRICK_BUILD_BENCH=ON)" >&2; exit 2; }
export VOXBRICK_CONFIG_DIR=${VOXBRICK_CONFIG_DIR:-$PWD/config}
mkdir -p bench/results/render
out=bench/results/render/residency
{
  echo "# Ray-driven against octree residency"
  echo
  echo "\`bash bench/run_residency.sh $*\` on $(uname -n), $(nproc) cores, $(date -u +%Y-%m-%d):"
  echo "$(glxinfo -B 2>/dev/null | grep -m1 'OpenGL renderer' || echo 'llvmpipe (EGL)')."
  echo
} > "$out.md.head"
"$bin" --dir "${TMPDIR:-/tmp}/voxbrick-residency-$$" --gpu-budget 1024 --csv "$out.csv" --md "$out.md.body" "$@"
cat "$out.md.head" "$out.md.body" > "$out.md"
rm -f "$out.md.head" "$out.md.body"
