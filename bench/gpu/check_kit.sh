#!/usr/bin/env bash
# Checks a GPU kit from a clean directory with only its own libraries: unpacks it with the kit's own zstd, checks
# that every library of every program and module resolves to the kit or to glibc / the GL loaders, then runs
# `voxbrick --version`, one tiny prep (its grid written and read back by the kit's OpenVDB module) and render through
# whatever EGL the machine has (Mesa here, NVIDIA's there),
# and the OSMesa backend, which must report that it is unavailable (the kit's stub).
#
#   bash bench/gpu/check_kit.sh [--pack] [--build build] [--kit bench/gpu/kit] [--dir DIR] [--baseline PATH]
#
# --pack first packs a fresh kit (zstd level 3, into a temporary folder) from --build, so the check needs no kit made
# before (this is what ctest's gpukit.PackAndRun runs); its baseline (pack.sh --baseline) is PATH, or else the build's
# own voxbrick standing in for one. A kit's baseline must resolve its libraries in the kit and start. DIR (default a
# new temporary folder) is emptied first.
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"

build=build
kitdir=bench/gpu/kit
dir=
pack=0
baseline=
while [ $# -gt 0 ]; do
  case "$1" in
    --pack) pack=1; shift ;;
    --build) build=$2; shift 2 ;;
    --kit) kitdir=$2; shift 2 ;;
    --dir) dir=$2; shift 2 ;;
    --baseline) baseline=$2; shift 2 ;;
    -h | --help) sed -n '2,12p' "$0"; exit 0 ;;
    *) echo "check_kit.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
die() { echo "check_kit.sh: FAILED: $*" >&2; exit 1; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ "$pack" = 1 ]; then
  if [ -z "$baseline" ]; then
    mkdir -p "$tmp/baseline"
    cp "$build/voxbrick" "$tmp/baseline/voxbrick"
    git rev-parse HEAD > "$tmp/baseline/COMMIT" 2> /dev/null || echo unknown > "$tmp/baseline/COMMIT"
    baseline=$tmp/baseline/voxbrick
  fi
  bash bench/gpu/pack.sh --build "$build" --out "$tmp/kit" --level 3 --baseline "$baseline" > "$tmp/pack.log" 2>&1 ||
    die "pack.sh failed: $(cat "$tmp/pack.log")"
  kitdir=$tmp/kit
fi
[ -f "$kitdir/voxbrick-gpukit.tar.zst" ] || die "no kit at $kitdir/voxbrick-gpukit.tar.zst (run bench/gpu/pack.sh)"
[ -x "$kitdir/unzstd/zstd" ] || die "no $kitdir/unzstd/zstd (run bench/gpu/pack.sh)"
[ -n "$dir" ] || dir=$tmp/check
rm -rf "$dir"
mkdir -p "$dir"
cp -r "$kitdir/voxbrick-gpukit.tar.zst" "$kitdir/unzstd" "$dir/"
cd "$dir"

# Nothing of this shell's environment but the PATH to coreutils: the kit must bring the rest.
clean() { env -i PATH=/usr/bin:/bin HOME="$dir" "$@"; }
clean LD_LIBRARY_PATH="$dir/unzstd" ./unzstd/zstd -dcq voxbrick-gpukit.tar.zst | tar -xf - ||
  die "could not unpack the kit with its own zstd"
kit=$dir/voxbrick-gpukit
libs=$kit/lib:$kit/lib/cxx
run() { clean LD_LIBRARY_PATH="$libs" VOXBRICK_CONFIG_DIR="$kit/config" "$@"; }

# Every library from the kit, or glibc's, or a GL loader's (which the GPU machine brings).
system_ok='^(libc|libm|libpthread|libdl|librt|libresolv|libutil|libmvec|libanl|ld-linux-x86-64|linux-vdso|libEGL|libGL|libGLX|libOpenGL|libGLdispatch|libGLESv2)\.so'
bad=0
# voxbrick's modules, which its programs look for in lib/voxbrick/ (beside bin/; common/Modules.h).
for module in openvdb gdcm; do
  [ -e "$kit/lib/voxbrick/libvoxbrick_$module.so" ] || die "the kit lacks lib/voxbrick/libvoxbrick_$module.so"
done
for program in "$kit"/bin/* "$kit"/lib/voxbrick/* $([ ! -e "$kit/baseline/voxbrick" ] || echo "$kit/baseline/voxbrick"); do
  while read -r line; do
    name=${line%% *}
    path=$(awk '{for (i = 1; i < NF; ++i) if ($i == "=>") print $(i + 1)}' <<< "$line")
    if [ "$path" = "not" ]; then
      echo "  $(basename "$program"): $name not found" >&2; bad=1
    elif [ -n "$path" ] && [[ "$path" != "$kit"/* ]] && ! [[ "$name" =~ $system_ok ]]; then
      echo "  $(basename "$program"): $name from $path, outside the kit" >&2; bad=1
    fi
  done < <(run ldd "$program")
done
[ "$bad" = 0 ] || die "libraries resolve outside the kit (above)"
echo "check_kit.sh: every library of $(ls "$kit/bin" "$kit/lib/voxbrick" | grep -v -e ':$' -e '^$' | tr '\n' ' ')$([ ! -e "$kit/baseline/voxbrick" ] || echo 'baseline/voxbrick ')resolves to the kit, glibc or a GL loader"

version=$(run "$kit/bin/voxbrick" --version) || die "voxbrick --version failed"
echo "check_kit.sh: $version"
if [ -e "$kit/baseline/voxbrick" ]; then
  [ -s "$kit/baseline/COMMIT" ] || die "the kit's baseline comes without baseline/COMMIT"
  base_version=$(run "$kit/baseline/voxbrick" --version) || die "the kit's baseline/voxbrick --version failed"
  echo "check_kit.sh: baseline $base_version ($(cut -c1-7 "$kit/baseline/COMMIT"))"
fi

# With its grid (vdb/): the kit's OpenVDB module writes it, and reads it back below.
run "$kit/bin/voxbrick" prep synthetic:sparse,n=32 --brick 16 -q -o "$dir/sparse" > "$dir/prep.log" 2>&1 ||
  die "voxbrick prep failed: $(cat "$dir/prep.log")"
run "$kit/bin/voxbrick" info "$dir/sparse/vdb/level0-z00000.vdb" > "$dir/info.log" 2>&1 ||
  die "voxbrick info of the store's grid failed (the OpenVDB module): $(cat "$dir/info.log")"
grep -q "read live" "$dir/info.log" || die "voxbrick info did not read the grid live: $(cat "$dir/info.log")"
echo "check_kit.sh: the OpenVDB module wrote and read $(basename "$dir")/sparse/vdb/level0-z00000.vdb"
run "$kit/bin/voxbrick" render "$dir/sparse" --size 32x32 --tf sparse --stats "$dir/frame.json" -o "$dir/frame.png" \
  > "$dir/render.log" 2>&1 || die "voxbrick render failed (no EGL context?): $(cat "$dir/render.log")"
[ -s "$dir/frame.png" ] && [ -s "$dir/frame.json" ] || die "voxbrick render wrote no frame: $(cat "$dir/render.log")"
renderer=$(sed -n 's/^render: \(.*\)$/\1/p' "$dir/render.log" | grep -v '^wrote' | head -1)
echo "check_kit.sh: rendered 32x32 on ${renderer:-(renderer not printed)}"

# The stub: the OSMesa backend must fail cleanly, saying so.
if run "$kit/bin/voxbrick" render "$dir/sparse" --size 32x32 --backend osmesa -o "$dir/osmesa.png" \
  > "$dir/osmesa.log" 2>&1; then
  die "--backend osmesa rendered: the kit carries Mesa's libOSMesa, not the stub"
fi
grep -q "OSMesa" "$dir/osmesa.log" || die "--backend osmesa failed without naming OSMesa: $(cat "$dir/osmesa.log")"
echo "check_kit.sh: --backend osmesa reports: $(grep -m1 'OSMesa' "$dir/osmesa.log" | sed 's/^ *//')"
grep -q "stand-in" "$dir/osmesa.log" || die "--backend osmesa did not name the kit's stand-in: $(cat "$dir/osmesa.log")"

# The GL tests that loop over backends: their EGL cases run, their OSMesa cases skip naming the stand-in, none fails.
filter='Context.*:SlicerShader.MatchesExactPolygonsOnDegenerateCases:Zellmann/SlicerVariant.TilesTheVertexProgramsPolygonsOnDegenerateCases/*:FilterProbe.*'
run "$kit/bin/test_render" --gtest_filter="$filter" > "$dir/test_render.log" 2>&1 ||
  die "test_render ($filter) failed: $(grep -E 'FAILED|Failure' "$dir/test_render.log" | head -5)"
skipped=$(grep -c '^\[  SKIPPED \].*([0-9]* ms)$' "$dir/test_render.log" || true)
[ "$skipped" -gt 0 ] && grep -q "did not run: libOSMesa here is the GPU kit's stand-in" "$dir/test_render.log" ||
  die "test_render skipped no OSMesa case naming the stand-in: $(tail -5 "$dir/test_render.log")"
echo "check_kit.sh: test_render: $(sed -n 's/^\[  PASSED  \] \(.*\)\.$/\1/p' "$dir/test_render.log") passed, $skipped skipped (OSMesa cases: the stand-in)"
echo "check_kit.sh: ok ($(du -k "$dir/voxbrick-gpukit.tar.zst" | cut -f1) KiB archive, $(du -sk "$kit" | cut -f1) KiB unpacked)"
