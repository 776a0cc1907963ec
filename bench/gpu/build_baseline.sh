#!/usr/bin/env bash
# Builds the crowd's baseline for the GPU kit: `voxbrick` from an earlier commit, by default 7d708e5 (the server before
# the fair scheduler, the baseline of bench/results/crowd/crowd.md), in a git worktree under bench/work/, with a file
# COMMIT beside the binary naming the commit. Prints the binary's path, for `bench/gpu/pack.sh --baseline PATH`.
#
#   bash bench/gpu/build_baseline.sh [--commit REV] [--dir bench/work/baseline]
#
# Only the `voxbrick` target, Release, no tests: about 5 minutes on 2 cores from nothing (2026-12-05); an existing
# build of the same commit is reused.
set -euo pipefail
cd "$(dirname "$0")/../.."

commit=7d708e5
dir=bench/work/baseline
while [ $# -gt 0 ]; do
  case "$1" in
    --commit) commit=$2; shift 2 ;;
    --dir) dir=$2; shift 2 ;;
    -h | --help) sed -n '2,9p' "$0"; exit 0 ;;
    *) echo "build_baseline.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done

die() { echo "build_baseline.sh: $*" >&2; exit 1; }
[ -n "$dir" ] || die "--dir names no folder"
full=$(git rev-parse --verify --quiet "$commit^{commit}") || die "no commit '$commit' in this repository"
src=$dir/src
if [ -d "$src" ] && [ "$(git -C "$src" rev-parse HEAD 2> /dev/null)" != "$full" ]; then
  git worktree remove --force "$src" 2> /dev/null || rm -rf "$src"
fi
if [ ! -d "$src" ]; then
  git worktree prune
  git worktree add --detach --force "$src" "$full" > /dev/null
fi
cmake -S "$src" -B "$src/build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DVOXBRICK_BUILD_TESTS=OFF \
  -DVOXBRICK_ALL_BENCH_IN_ALL=OFF > "$dir/configure.log" 2>&1 || die "configuring failed: $dir/configure.log"
cmake --build "$src/build" --target voxbrick --parallel "$(nproc)" > "$dir/build.log" 2>&1 ||
  die "building failed: the end of $dir/build.log: $(tail -5 "$dir/build.log")"
mkdir -p "$dir/bin"
cp "$src/build/voxbrick" "$dir/bin/voxbrick"
echo "$full" > "$dir/bin/COMMIT"
"$dir/bin/voxbrick" --version > /dev/null || die "the built $dir/bin/voxbrick does not start"
echo "$dir/bin/voxbrick"
