#!/usr/bin/env bash
# Everything before a lent GPU's calls, in one command, here (no GPU needed; README.md says what each part is):
#
#   bash bench/gpu/prepare.sh [--browser] [--no-checks]
#
# Builds what the GPU kit carries; downloads the GL loaders into .gl/ (once); packs the GPU kit (pack.sh, zstd 19)
# and checks it from a clean folder (check_kit.sh). With --browser, for the steps in Chromium: builds the crowd's
# baseline (build_baseline.sh) and packs it into the GPU kit, packs the browser kit (pack_browser.sh) and runs both
# browser steps at tiny sizes from it (check_browserkit.sh). Then checks that each call carries at most 64 MiB (the
# working tree travels with every call) and prints the calls to make. About 2 minutes without --browser once built;
# with it, 6 more (the browser kit at zstd 19), and 5 more the first time (the baseline's build).
set -euo pipefail
cd "$(dirname "$0")/../.."

browser=0
checks=1
while [ $# -gt 0 ]; do
  case "$1" in
    --browser) browser=1; shift ;;
    --no-checks) checks=0; shift ;;
    -h | --help) sed -n '2,11p' "$0"; exit 0 ;;
    *) echo "prepare.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
die() { echo "prepare.sh: $*" >&2; exit 1; }
say() { echo "prepare.sh: $*"; }

say "building what the kit carries"
cmake --build build --target voxbrick bench_render test_render frame_golden bench_link_relay > /dev/null ||
  die "the build failed: cmake --build build --target voxbrick bench_render test_render frame_golden bench_link_relay"

if ! ls .gl/*.deb > /dev/null 2>&1; then
  say "downloading the GL loaders into .gl/"
  mkdir -p .gl /tmp/amd64/partial
  o=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64)
  apt-get "${o[@]}" update > /dev/null
  (cd .gl && apt-get "${o[@]}" download libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2 > /dev/null) ||
    die "could not download the GL loader packages into .gl/"
fi

if [ "$browser" = 1 ]; then
  say "building the crowd's baseline (bench/work/baseline)"
  baseline=$(bash bench/gpu/build_baseline.sh)
  say "packing the GPU kit with the baseline $baseline"
  bash bench/gpu/pack.sh --baseline "$baseline" | tail -1
  say "packing the browser kit"
  bash bench/gpu/pack_browser.sh | tail -1
else
  say "packing the GPU kit"
  bash bench/gpu/pack.sh | tail -1
fi

if [ "$checks" = 1 ]; then
  say "checking the GPU kit from a clean folder"
  bash bench/gpu/check_kit.sh | tail -1
  if [ "$browser" = 1 ]; then
    say "checking the browser kit: its parts one call at a time, then the browser steps at tiny sizes"
    bash bench/gpu/check_browserkit.sh | tail -1
  fi
fi

# What each call carries: the working tree (tracked files and untracked ones git does not ignore) and its carry.
mib() { awk -v b="$1" 'BEGIN { printf "%.1f", b / 1048576 }'; }
bytes() { du -cb "$@" 2> /dev/null | tail -1 | cut -f1; }
tree=$(git ls-files -co --exclude-standard -z | du -cb --files0-from=- 2> /dev/null | tail -1 | cut -f1)
limit=$((64 << 20))
check_call() {  # NAME PATH...: the tree and the paths within 64 MiB
  local name=$1 total
  shift
  total=$((tree + $(bytes "$@")))
  [ "$total" -le "$limit" ] || die "$name carries $(mib "$total") MiB with the tree, over 64 MiB: $*"
  say "$name: $(mib "$total") MiB with the tree ($(mib "$tree") MiB)"
}
echo
if [ "$browser" = 1 ]; then
  parts=($(cd bench/gpu/browserkit && ls part-*))
  for p in "${parts[@]}"; do check_call "the call carrying $p" "bench/gpu/browserkit/$p" bench/gpu/browserkit/SHA256SUMS; done
  check_call "the measuring call" bench/gpu/kit .gl bench/gpu/browserkit/SHA256SUMS
  echo
  echo "The calls, one after another without a pause (README.md, \"The browser steps\"):"
  for p in "${parts[@]}"; do
    echo "  run command='bash bench/gpu/stash_browserkit.sh' carry=[\"bench/gpu/browserkit/$p\", \"bench/gpu/browserkit/SHA256SUMS\"] timeout_s=60"
  done
  echo "  run command='for f in .gl/*.deb; do dpkg -x \$f /; done; ldconfig; MEASURE_STEPS=\"device crowd-browser browser-link\" bash bench/gpu/measure.sh'" \
    "carry=[\"bench/gpu/kit\", \".gl\", \"bench/gpu/browserkit/SHA256SUMS\"] timeout_s=520"
else
  check_call "the call" bench/gpu/kit .gl
  echo
  echo "The call (README.md, \"The call\"):"
  echo "  run command='for f in .gl/*.deb; do dpkg -x \$f /; done; ldconfig; bash bench/gpu/measure.sh'" \
    "carry=[\"bench/gpu/kit\", \".gl\"] timeout_s=540"
fi
