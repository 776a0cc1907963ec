#!/usr/bin/env bash
# Packs the browser kit: what the benchmarks in Chromium (bench/crowd.mjs, bench/browser_link.mjs) need on a GPU
# machine that reaches no package registry and has neither Chromium nor node: Debian's Chromium (the files headless
# Chromium reads), node, tests/browser's packages (puppeteer-core), the DejaVu fonts, and every shared library these
# load but glibc's own, into one zstd archive cut into parts small enough to travel one a device call beside the
# working tree (each call carries at most 64 MiB in all). bench/gpu/README.md ("The browser steps") has the calls.
#
#   bash bench/gpu/pack_browser.sh [--out bench/gpu/browserkit] [--level 19] [--part-mib 48]
#
# Writes OUT/part-0, OUT/part-1, … (cat them in order for the archive), OUT/SHA256SUMS (the archive's and each
# part's) and OUT/MANIFEST.txt. In the kit (voxbrick-browserkit/): bin/chromium, a wrapper that runs chromium/chromium
# with the kit's libraries and fonts; bin/node; node_modules/; lib/ (libstdc++ and libgcc_s left out: the GPU kit
# brings them where the machine's are older, and measure.sh decides); fonts/ with fonts.conf.
# Libraries Chromium opens at run time rather than links (NSS's modules, Wayland's client) are packed too;
# check_browserkit.sh finds any other by reading the running browser's memory maps.
set -euo pipefail
cd "$(dirname "$0")/../.."
export PATH=$PATH:/usr/sbin:/sbin  # ldconfig

out=bench/gpu/browserkit
level=19
part_mib=48
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out=$2; shift 2 ;;
    --level) level=$2; shift 2 ;;
    --part-mib) part_mib=$2; shift 2 ;;
    -h | --help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "pack_browser.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
die() { echo "pack_browser.sh: $*" >&2; exit 1; }
for tool in ldd tar zstd split sha256sum node; do
  command -v "$tool" > /dev/null || die "needs '$tool' on the PATH"
done
[[ "$part_mib" =~ ^[0-9]+$ ]] && [ "$part_mib" -ge 1 ] && [ "$part_mib" -le 60 ] ||
  die "--part-mib must be 1..60 (a part travels beside the working tree in a 64 MiB call), not '$part_mib'"
chromium_dir=/usr/lib/chromium
[ -x "$chromium_dir/chromium" ] || die "no $chromium_dir/chromium: Debian's chromium is not installed (scripts/setup.sh)"
[ -d tests/browser/node_modules/puppeteer-core ] || die "no tests/browser/node_modules: run 'cd tests/browser && npm ci'"
fonts=/usr/share/fonts/truetype/dejavu
[ -f "$fonts/DejaVuSans.ttf" ] || die "no $fonts/DejaVuSans.ttf (Debian's fonts-dejavu-core)"
nss=/usr/lib/x86_64-linux-gnu/nss

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
kit=$tmp/voxbrick-browserkit
mkdir -p "$kit/bin" "$kit/chromium/locales" "$kit/lib" "$kit/fonts" "$kit/gio-modules"

# Chromium: the binary, its crash handler, ICU data, V8 snapshots, resource packs, one locale, and the GL/Vulkan
# libraries it opens from its own folder (ANGLE, SwiftShader). The validation layer and the mock driver stay behind.
for f in chromium chrome_crashpad_handler icudtl.dat resources.pak chrome_100_percent.pak chrome_200_percent.pak \
  snapshot_blob.bin v8_context_snapshot.bin libEGL.so libGLESv2.so libvk_swiftshader.so vk_swiftshader_icd.json \
  libvulkan.so.1; do
  [ -e "$chromium_dir/$f" ] && cp -L "$chromium_dir/$f" "$kit/chromium/"
done
[ -x "$kit/chromium/chromium" ] && [ -f "$kit/chromium/icudtl.dat" ] || die "$chromium_dir lacks chromium or icudtl.dat"
cp "$chromium_dir/locales/en-US.pak" "$kit/chromium/locales/"
cp "$(readlink -f "$(command -v node)")" "$kit/bin/node"
cp -r tests/browser/node_modules "$kit/node_modules"
cp "$fonts"/*.ttf "$kit/fonts/"
cat > "$kit/fonts/fonts.conf" << 'EOF'
<?xml version="1.0"?>
<!DOCTYPE fontconfig SYSTEM "fonts.dtd">
<fontconfig>
  <dir prefix="relative">.</dir>
  <cachedir>/tmp/voxbrick-browserkit-fontconfig</cachedir>
  <alias><family>sans-serif</family><prefer><family>DejaVu Sans</family></prefer></alias>
  <alias><family>serif</family><prefer><family>DejaVu Serif</family></prefer></alias>
  <alias><family>monospace</family><prefer><family>DejaVu Sans Mono</family></prefer></alias>
</fontconfig>
EOF
# Libraries opened by name at run time rather than linked: NSS's modules (beside libnss3 in lib/, where NSS looks
# first) and Wayland's client library (check_browserkit.sh saw Chromium map it).
[ -d "$nss" ] && cp -L "$nss"/*.so "$kit/lib/"
for name in libwayland-client.so.0; do
  path=$(ldconfig -p | awk -v n="$name" '$1 == n && /x86-64/ && !found {print $NF; found = 1}')
  [ -n "$path" ] && cp -L "$path" "$kit/lib/$name"
done

# Every library these link (ldd follows the closure), glibc's own and the C++ runtime aside.
skip='^(libc|libm|libpthread|libdl|librt|libresolv|libutil|libmvec|libanl|ld-linux-x86-64|ld-linux|linux-vdso|libstdc\+\+|libgcc_s)\.so'
packed=()
for b in "$kit/chromium/chromium" "$kit/chromium/chrome_crashpad_handler" "$kit/chromium/libGLESv2.so" \
  "$kit/chromium/libEGL.so" "$kit/chromium/libvk_swiftshader.so" "$kit/bin/node" "$kit"/lib/*.so; do
  [ -e "$b" ] || continue
  while read -r name arrow path _; do
    [ "$arrow" = "=>" ] || continue
    [[ "$name" =~ $skip ]] && continue
    [ "$path" != "not" ] || die "$b: $name not found"
    [ -e "$kit/chromium/$name" ] && continue  # Chromium's own, found beside it
    if [ ! -e "$kit/lib/$name" ]; then
      cp "$(readlink -f "$path")" "$kit/lib/$name"
      packed+=("$name")
    fi
  done < <(ldd "$b")
done

# The wrapper: Chromium with the kit's libraries first (then the caller's, such as the GPU kit's C++ runtime), the
# kit's fonts, and any switches in VOXBRICK_CHROMIUM_FLAGS.
cat > "$kit/bin/chromium" << 'EOF'
#!/bin/sh
here=$(cd "$(dirname "$0")/.." && pwd)
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export FONTCONFIG_FILE="$here/fonts/fonts.conf"
# GIO's modules (dconf and the like) are the machine's plug-ins: none here, and settings kept in memory.
export GIO_MODULE_DIR="$here/gio-modules" GSETTINGS_BACKEND=memory
export HOME="${HOME:-/tmp}"
# shellcheck disable=SC2086
exec "$here/chromium/chromium" ${VOXBRICK_CHROMIUM_FLAGS:-} "$@"
EOF
chmod +x "$kit/bin/chromium"

{
  echo "voxbrick browser kit"
  echo "made: $(date -u +%Y-%m-%dT%H:%M:%SZ) on $(uname -srm)"
  echo "commit: $(git rev-parse HEAD 2> /dev/null || echo unknown)"
  echo "glibc: $(ldd --version | head -1)"
  echo "chromium: $("$kit/bin/chromium" --version 2> /dev/null || echo 'unknown')"
  echo "node: $("$kit/bin/node" --version)"
  echo "puppeteer-core: $(sed -n 's/^ *"version": *"\([^"]*\)".*/\1/p' "$kit/node_modules/puppeteer-core/package.json" | head -1)"
  echo "libraries: ${#packed[@]} linked, NSS modules $(cd "$kit/lib" && ls | grep -cE '^lib(softokn3|freebl|nssckbi)' || true)"
} > "$kit/MANIFEST.txt"

mkdir -p "$out"
rm -f "$out"/part-* "$out/SHA256SUMS" "$out/MANIFEST.txt"
tar -C "$tmp" -cf - voxbrick-browserkit | zstd -q -T0 -"$level" $([ "$level" -gt 19 ] && echo --ultra) --long=27 \
  -o "$tmp/archive.tar.zst"
split -b "${part_mib}M" -d -a 1 "$tmp/archive.tar.zst" "$out/part-"
cp "$kit/MANIFEST.txt" "$out/MANIFEST.txt"
{
  echo "$(sha256sum < "$tmp/archive.tar.zst" | cut -d' ' -f1)  archive"
  (cd "$out" && sha256sum part-*)
} > "$out/SHA256SUMS"
echo "pack_browser.sh: $out: $(ls "$out" | grep -c '^part-') parts of at most $part_mib MiB," \
  "$(du -k "$tmp/archive.tar.zst" | cut -f1) KiB in all (unpacked $(du -sk "$kit" | cut -f1) KiB," \
  "${#packed[@]} libraries)"
