#!/usr/bin/env bash
# Checks the browser kit the way the GPU machine will use it, here: its parts stashed as separate calls would leave
# them (bench/gpu/stash_browserkit.sh, one part a call; a damaged part refused by name), then measure.sh's browser
# steps at tiny sizes (MEASURE_QUICK=1: crowd-browser, browser-link) with a clean environment, the GPU kit's voxbrick
# and the browser kit's node and Chromium. While they run, every shared library the kit's Chromium and node processes
# have mapped is read from /proc: each must come from the kits or glibc. A library from anywhere else is one the GPU
# machine would lack.
#
#   bash bench/gpu/check_browserkit.sh [--pack] [--smoke] [--build build] [--dir DIR] [--baseline PATH]
#
# --pack first packs both kits afresh (zstd level 3) into DIR, the GPU kit with the baseline voxbrick PATH when given
# (pack.sh --baseline); otherwise bench/gpu/kit and bench/gpu/browserkit are checked. A GPU kit that carries a baseline
# must give crowd-browser's table a baseline row for every scenario. --smoke, in place of measure.sh's steps: the parts unpacked and bench/gpu/browserkit_smoke.mjs run (the
# kit's node drives its Chromium through puppeteer-core; text in the kit's fonts; WebCodecs decodes vp8 and vp9), with
# the same look at the libraries (ctest's browserkit.PackAndSmoke: about 30 s). DIR (default a new temporary folder) is
# emptied first. Without --smoke about 90 s on 2 cores.
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
cd "$here"

build=build
dir=
pack=0
smoke=0
baseline=
while [ $# -gt 0 ]; do
  case "$1" in
    --pack) pack=1; shift ;;
    --smoke) smoke=1; shift ;;
    --build) build=$2; shift 2 ;;
    --dir) dir=$2; shift 2 ;;
    --baseline) baseline=$2; shift 2 ;;
    -h | --help) sed -n '2,19p' "$0"; exit 0 ;;
    *) echo "check_browserkit.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
die() { echo "check_browserkit.sh: FAILED: $*" >&2; exit 1; }

tmp=$(mktemp -d)
[ -n "$dir" ] || dir=$tmp/check
trap 'rm -rf "$tmp"' EXIT
rm -rf "$dir"
mkdir -p "$dir"
kitdir=bench/gpu/kit
bkdir=bench/gpu/browserkit
if [ "$pack" = 1 ]; then
  if [ "$smoke" = 0 ]; then
    bash bench/gpu/pack.sh --build "$build" --out "$dir/kit" --level 3 ${baseline:+--baseline "$baseline"} \
      > "$dir/pack.log" 2>&1 ||
      die "pack.sh failed: $(tail -3 "$dir/pack.log")"
    kitdir=$dir/kit
  fi
  bash bench/gpu/pack_browser.sh --out "$dir/browserkit" --level 3 >> "$dir/pack.log" 2>&1 ||
    die "pack_browser.sh failed: $(tail -3 "$dir/pack.log")"
  bkdir=$dir/browserkit
fi
[ "$smoke" = 1 ] || [ -f "$kitdir/voxbrick-gpukit.tar.zst" ] || die "no GPU kit at $kitdir (bench/gpu/pack.sh)"
[ -f "$bkdir/SHA256SUMS" ] || die "no browser kit at $bkdir (bench/gpu/pack_browser.sh)"
bkdir=$(cd "$bkdir" && pwd)

# The calls before the measuring one: each carries one part (and SHA256SUMS) and stashes it; the stash lives in /tmp
# there, so here the stash script runs on a copy of the tree whose /tmp is this check's folder.
parts=($(cd "$bkdir" && ls part-*))
[ "${#parts[@]}" -ge 1 ] || die "$bkdir holds no parts"
stash=/tmp/voxbrick-browserkit-parts
[ ! -e "$stash" ] || mv "$stash" "$tmp/stash-before"
restore() { rm -rf "$stash"; [ ! -e "$tmp/stash-before" ] || mv "$tmp/stash-before" "$stash"; rm -rf "$tmp"; }
trap restore EXIT
# A damaged part is refused by name.
rm -rf "$dir/carry" && mkdir -p "$dir/carry"
cp "$bkdir/SHA256SUMS" "$dir/carry/"
head -c 1000 "$bkdir/${parts[-1]}" > "$dir/carry/${parts[-1]}"
if bash bench/gpu/stash_browserkit.sh --from "$dir/carry" 2> "$dir/damaged.log"; then
  die "stash_browserkit.sh took a damaged ${parts[-1]}"
fi
grep -q "${parts[-1]} arrived damaged" "$dir/damaged.log" || die "a damaged part was refused without its name: $(cat "$dir/damaged.log")"
# One call a part, as README.md's calls; then the measuring call carries SHA256SUMS and no part.
for p in "${parts[@]}"; do
  rm -rf "$dir/carry" && mkdir -p "$dir/carry"
  cp "$bkdir/SHA256SUMS" "$bkdir/$p" "$dir/carry/"
  bash bench/gpu/stash_browserkit.sh --from "$dir/carry" | tee "$dir/stash.log" || die "stash_browserkit.sh failed on $p"
done
grep -q "still to come: none" "$dir/stash.log" || die "the stash does not hold every part: $(cat "$dir/stash.log")"
rm -rf "$dir/carry" && mkdir -p "$dir/carry"
cp "$bkdir/SHA256SUMS" "$dir/carry/"

# Reads, while process $1 runs, the libraries mapped by every process whose program is in the unpacked browser kit.
watch_maps() {
  : > "$dir/maps.txt"
  while kill -0 "$1" 2> /dev/null; do
    for exe in /proc/[0-9]*/exe; do
      target=$(readlink "$exe" 2> /dev/null) || continue
      [[ "$target" == "$dir/work/voxbrick-browserkit/"* ]] || continue
      grep -o '/[^ ]*\.so[.0-9]*$' "${exe%/exe}/maps" 2> /dev/null | sed "s|^|$(basename "$target") |" >> "$dir/maps.txt" || true
    done
    sleep 0.3
  done
}
mkdir -p "$dir/work" "$dir/out"
if [ "$smoke" = 1 ]; then
  # The parts as measure.sh joins them, in order, from the stash.
  files=()
  for p in "${parts[@]}"; do files+=("$stash/$p"); done
  cat "${files[@]}" | zstd -dcq --long=27 | tar -C "$dir/work" -xf - || die "the stashed parts do not unpack"
  bk=$dir/work/voxbrick-browserkit
  smoke_js=$here/bench/gpu/browserkit_smoke.mjs
  (cd "$bk" && env -i PATH=/usr/bin:/bin HOME="$dir" CHROME="$bk/bin/chromium" "$bk/bin/node" "$smoke_js" \
    > "$dir/smoke.json" 2> "$dir/smoke.log") &
  run=$!
  watch_maps "$run"
  wait "$run" || die "browserkit_smoke.mjs failed: $(tail -5 "$dir/smoke.log")"
  grep -q '"vp8":true' "$dir/smoke.json" && grep -q '"vp09.00.10.08":true' "$dir/smoke.json" ||
    die "the kit's Chromium does not decode vp8 and vp9 with WebCodecs: $(cat "$dir/smoke.json")"
  grep -qE '"textWidth":[1-9]' "$dir/smoke.json" || die "the kit's Chromium laid out no text: $(cat "$dir/smoke.json")"
  # The browser's own processes, as the smoke script read them before it closed the browser.
  "$bk/bin/node" -e 'for (const f of JSON.parse(require("fs").readFileSync(process.argv[1])).libraries) console.log("chromium " + f)' \
    "$dir/smoke.json" >> "$dir/maps.txt"
  grep -q '^chromium ' "$dir/maps.txt" || die "the smoke script read no library of the browser's processes"
  what="the kit's node drove its Chromium ($(sed 's/,"libraries".*/}/' "$dir/smoke.json"))"
else
  # measure.sh's browser steps, tiny, with nothing of this shell's environment but the PATH.
  env -i PATH=/usr/bin:/bin HOME="$dir" OUT="$dir/out" MEASURE_QUICK=1 MEASURE_ALLOW_SOFTWARE=1 \
    MEASURE_STEPS="device crowd-browser browser-link" MEASURE_WORK="$dir/work" MEASURE_KIT="$kitdir" \
    MEASURE_BROWSERKIT="$dir/carry" bash bench/gpu/measure.sh > "$dir/measure.out" 2>&1 &
  run=$!
  watch_maps "$run"
  wait "$run" && rc=0 || rc=$?
  [ "$rc" = 0 ] || die "measure.sh's browser steps failed (exit $rc): $(tail -15 "$dir/measure.out")"
  grep -q "browser kit: .*parts" "$dir/measure.out" || die "measure.sh did not unpack the browser kit"
  grep -qE '^\| crowd-browser \| ok' "$dir/out/summary.md" && grep -qE '^\| browser-link \| ok' "$dir/out/summary.md" ||
    die "a browser step did not end ok: $(cat "$dir/out/summary.md")"
  what="crowd-browser and browser-link ran (tiny)"
  # A kit with a baseline: each scenario's row on it too (the CSV's first two columns, quoted: scenario, server).
  # (the listing whole first: grep -q leaving early would end tar by SIGPIPE, a failed pipeline under pipefail)
  listing=$(zstd -dcq "$kitdir/voxbrick-gpukit.tar.zst" | tar -tf -)
  if grep -qx 'voxbrick-gpukit/baseline/voxbrick' <<< "$listing"; then
    csv=$dir/work/results/crowd-browser/crowd.csv
    for scenario in A B "B'"; do
      for server in "this build" baseline; do
        grep -qF "\"$scenario\",\"$server\"," "$csv" 2> /dev/null ||
          die "crowd-browser has no row for scenario $scenario on $server: $(cat "$csv" 2> /dev/null || echo 'no crowd.csv')"
      done
    done
    what="$what, every crowd scenario on this build and on the baseline ($(sed -n 's/^baseline: //p' "$dir/work/voxbrick-gpukit/MANIFEST.txt"))"
  fi
fi
sort -u "$dir/maps.txt" -o "$dir/maps.txt"
[ -s "$dir/maps.txt" ] || die "no library of the kit's Chromium or node was seen mapped (did they run?)"
glibc='/(libc|libm|libpthread|libdl|librt|libresolv|libutil|libmvec|libanl|ld-linux-x86-64|libstdc\+\+|libgcc_s)\.so[.0-9]*$'
outside=$(awk '{print $2}' "$dir/maps.txt" | grep -v "^$dir/work/" | grep -vE "$glibc" | sort -u || true)
[ -z "$outside" ] || die "the kit's processes mapped libraries from outside the kits: $(echo $outside)"
echo "check_browserkit.sh: ${#parts[@]} parts stashed and unpacked; $what;" \
  "$(awk '{print $1}' "$dir/maps.txt" | sort -u | tr '\n' ' ')mapped $(awk '{print $2}' "$dir/maps.txt" | sort -u | wc -l)" \
  "libraries, none from outside the kits but glibc and the C++ runtime"
