#!/usr/bin/env bash
# Packs a GPU kit: the built voxbrick, bench_render, test_render (and frame_golden) and voxbrick's modules, with every
# shared library they need except glibc's own and the GL loaders, a stub libOSMesa, the configuration directory and the demo MRI, into
# one zstd archive that bench/gpu/measure.sh unpacks on a GPU machine.
#
#   bash bench/gpu/pack.sh [--build build] [--out bench/gpu/kit] [--level 19] [--baseline PATH]
#
# Writes OUT/voxbrick-gpukit.tar.zst and OUT/unzstd/ (a zstd binary and its libraries, for a machine without zstd).
# --baseline PATH: a voxbrick built from an earlier commit (bench/gpu/build_baseline.sh; a file COMMIT beside it names
# the commit) goes into the kit as baseline/voxbrick, with its libraries: the crowd-browser step runs each scenario on
# it too, so that the GPU's table holds the earlier server's figures beside this build's.
# Left out, and why:
#   - glibc (libc, libm, libpthread, libdl, librt, libresolv, libutil, libmvec, ld-linux): the GPU machine's own;
#   - the GL loaders (libEGL, libGL, libGLX, libOpenGL, libGLdispatch, libGLESv2): from the .gl debs there, which
#     dispatch to NVIDIA's EGL driver;
#   - libOSMesa (Mesa's, which pulls in LLVM, about 100 MB): replaced by bench/gpu/osmesa_stub.c, built here, whose
#     entry points fail cleanly, so the OSMesa backend reports no context and EGL is used;
#   - libcurl: voxbrick loads it only to fetch from a DICOMweb service (brickstore/ingest/dicomweb), which no step
#     does; such a fetch on the GPU machine would fail, naming libcurl.so.4.
# libstdc++ and libgcc_s go into lib/cxx/: measure.sh uses them only where the machine's own are older.
set -euo pipefail
cd "$(dirname "$0")/../.."

build=build
out=bench/gpu/kit
level=19
baseline=
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --level) level=$2; shift 2 ;;
    --baseline) baseline=$2; shift 2 ;;
    -h | --help) sed -n '2,19p' "$0"; exit 0 ;;
    *) echo "pack.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done

die() { echo "pack.sh: $*" >&2; exit 1; }
for tool in ldd readelf cc tar zstd sha256sum; do
  command -v "$tool" > /dev/null || die "needs '$tool' on the PATH"
done
mri=/usr/share/mricron/templates/ch2better.nii.gz
[ -f "$mri" ] || die "the demo MRI $mri is missing (Debian's mricron-data)"
[ -d config/tf ] && [ -f config/server.toml ] || die "config/ (tf/, scenes/, server.toml) is missing"

binaries=("$build/voxbrick" "$build/bench/bench_render" "$build/tests/test_render")
for b in "${binaries[@]}"; do
  [ -x "$b" ] || die "$b is not built (cmake --build $build --target voxbrick bench_render test_render frame_golden)"
done
# frame_golden when it is built and small (its committed digests hold for llvmpipe only; on a GPU it writes and
# checks its own frames).
golden="$build/bench/frame_golden"
if [ -x "$golden" ] && [ "$(stat -c %s "$golden")" -lt $((16 << 20)) ]; then binaries+=("$golden"); fi
# The link relay when it is built (the video-link step).
if [ -x "$build/bench/bench_link_relay" ]; then binaries+=("$build/bench/bench_link_relay"); fi
if [ -n "$baseline" ]; then
  [ -x "$baseline" ] || die "--baseline $baseline is not an executable"
  [ -f "$(dirname "$baseline")/COMMIT" ] || die "--baseline: no COMMIT beside $baseline names its commit"
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
kit=$tmp/voxbrick-gpukit
mkdir -p "$kit/bin" "$kit/lib/cxx" "$kit/data"

# The stub, with the soname voxbrick opens (render/gl/OsMesaContext.cpp loads libOSMesa when an OSMesa context is first
# made, rather than linking it), and every entry point it looks up there.
osmesa_source=render/gl/OsMesaContext.cpp
soname=$(sed -n 's/.*kOsMesaLibrary = "\(libOSMesa[^"]*\)".*/\1/p' "$osmesa_source")
[ -n "$soname" ] || die "$osmesa_source names no kOsMesaLibrary: nothing to stub"
grep -aq "$soname" "$build/voxbrick" || die "$build/voxbrick does not open $soname (is it built from this tree?)"
cc -shared -fPIC -O2 -Wall -Werror -Wl,-soname,"$soname" -o "$kit/lib/$soname" bench/gpu/osmesa_stub.c
for sym in $(grep -o 'resolve(handle, "OSMesa[A-Za-z]*"' "$osmesa_source" | grep -o 'OSMesa[A-Za-z]*'); do
  readelf --dyn-syms -W "$kit/lib/$soname" | awk '$7 != "UND" {print $8}' | grep -qx "$sym" ||
    die "$osmesa_source looks up $sym, which bench/gpu/osmesa_stub.c does not define"
done

# Libraries: ldd with the stub first on the path, so the closure is the kit's (no LLVM).
skip='^(libc|libm|libpthread|libdl|librt|libresolv|libutil|libmvec|libanl|ld-linux-x86-64|ld-linux|linux-vdso|libEGL|libGL|libGLX|libOpenGL|libGLdispatch|libGLESv2)\.so'
packed=()
# Copies program $1 to folder $2 of the kit, and every library it needs that the kit lacks.
pack_program() {
  cp "$1" "$2"
  while read -r name arrow path _; do
    [ "$arrow" = "=>" ] || continue
    [[ "$name" =~ $skip ]] && continue
    [ "$name" = "$soname" ] && continue
    [ "$path" != "not" ] || die "$1: $name not found"
    dest=$kit/lib
    case "$name" in libstdc++.so.* | libgcc_s.so.*) dest=$kit/lib/cxx ;; esac
    if [ ! -e "$dest/$name" ]; then
      cp "$(readlink -f "$path")" "$dest/$name"
      packed+=("$name <- $(readlink -f "$path")")
    fi
  done < <(LD_LIBRARY_PATH="$kit/lib" ldd "$1")
}
for b in "${binaries[@]}"; do pack_program "$b" "$kit/bin/"; done
# voxbrick's modules (common/Modules.h: OpenVDB's and GDCM's code, loaded on first use), where a program in bin/
# looks for them: lib/voxbrick/.
modules=("$build"/modules/libvoxbrick_*.so)
[ -e "${modules[0]}" ] || die "$build/modules holds no module (cmake --build $build --target voxbrick builds them)"
mkdir -p "$kit/lib/voxbrick"
for m in "${modules[@]}"; do pack_program "$m" "$kit/lib/voxbrick/"; done
if [ -n "$baseline" ]; then
  mkdir -p "$kit/baseline"
  cp "$(dirname "$baseline")/COMMIT" "$kit/baseline/COMMIT"
  pack_program "$baseline" "$kit/baseline/voxbrick"
fi

cp -r config "$kit/config"
cp "$mri" "$kit/data/"
# test_render runs `voxbrick` through the absolute path compiled into it (VOXBRICK_EXE, from the build files: the
# binary may hold it only in pieces); measure.sh puts the kit's voxbrick there.
cat "$build/build.ninja" "$build/tests/CMakeFiles/test_render.dir/flags.make" 2> /dev/null |
  sed -n 's/.*-DVOXBRICK_EXE=\\"\([^"\\]*\)\\".*/\1/p' | sort -u \
  > "$kit/TEST_VOXBRICK_PATH" || true
[ "$(wc -l < "$kit/TEST_VOXBRICK_PATH")" = 1 ] ||
  die "found no single VOXBRICK_EXE in $build/build.ninja: $(tr '\n' ' ' < "$kit/TEST_VOXBRICK_PATH")"
[ "$(cat "$kit/TEST_VOXBRICK_PATH")" -ef "$build/voxbrick" ] ||
  die "VOXBRICK_EXE in $build/build.ninja is $(cat "$kit/TEST_VOXBRICK_PATH"), not $build/voxbrick"

{
  echo "voxbrick GPU kit"
  echo "made: $(date -u +%Y-%m-%dT%H:%M:%SZ) on $(uname -srm)"
  echo "commit: $(git rev-parse HEAD 2>/dev/null || echo unknown)$(git diff --quiet HEAD 2>/dev/null || echo ' (with local changes)')"
  echo "glibc: $(ldd --version | head -1)"
  echo "binaries: $(cd "$kit/bin" && ls | tr '\n' ' ')"
  echo "modules: lib/voxbrick/ ($(cd "$kit/lib/voxbrick" && ls | tr '\n' ' '))"
  [ -z "$baseline" ] || echo "baseline: baseline/voxbrick, $(cat "$kit/baseline/COMMIT")"
  echo "stub: lib/$soname from bench/gpu/osmesa_stub.c"
  echo "libraries:"
  printf '  %s\n' "${packed[@]}"
  echo "config: config/ ($(cd "$kit/config" && find . -type f | sort | tr '\n' ' '))"
  echo "data: data/$(basename "$mri") (sha256 $(sha256sum "$mri" | cut -c1-16)…)"
} > "$kit/MANIFEST.txt"

mkdir -p "$out"
rm -rf "$out/unzstd" "$out/voxbrick-gpukit.tar.zst"
tar -C "$tmp" -cf - voxbrick-gpukit | zstd -q -T0 -"$level" $([ "$level" -gt 19 ] && echo --ultra) \
  -o "$out/voxbrick-gpukit.tar.zst"

# A zstd that runs without the machine's: the binary and its libraries (glibc aside).
mkdir -p "$out/unzstd"
cp "$(readlink -f "$(command -v zstd)")" "$out/unzstd/zstd"
while read -r name arrow path _; do
  [ "$arrow" = "=>" ] || continue
  [[ "$name" =~ $skip ]] && continue
  cp "$(readlink -f "$path")" "$out/unzstd/$name"
done < <(ldd "$out/unzstd/zstd")

echo "pack.sh: $out/voxbrick-gpukit.tar.zst, $(du -k "$out/voxbrick-gpukit.tar.zst" | cut -f1) KiB" \
  "(unpacked $(du -sk "$kit" | cut -f1) KiB: ${#packed[@]} libraries, $(ls "$kit/bin" | wc -l) programs);" \
  "$out/unzstd: $(du -sk "$out/unzstd" | cut -f1) KiB"
