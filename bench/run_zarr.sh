#!/usr/bin/env bash
# OME-Zarr read live against its prepped store: an N³ u16 volume with a 5-level pyramid written by Debian's
# python3-zarr (tests/support/zarr_fixture.py: the test suite's writer), once with blosc-lz4 (shuffle) chunks and once
# with zstd chunks. For each: the first frame live (a fresh process: open, the pass over the chunks, the frame) and
# prepped (a fresh process), the warm frame of each (after --warm-up 2), prep's time, and chunk decode MB/s through
# voxbrick (decodeZarrChunk) against the codec library called directly on the same bytes (bench_zarr_decode).
# Writes bench/results/zarr/zarr.{csv,md} (headed SMOKE RUN with --smoke).
#
#   bash bench/run_zarr.sh [--n 1024] [--chunk 64] [--size 512x512] [--smoke]
#
# --smoke: N = 256, a proof that the script works, not a measurement. The 1024³ run needs about 2 GB per Zarr,
# 2 GB per store and a quiet machine.
set -euo pipefail
cd "$(dirname "$0")/.."
n=1024
chunk=64
size=512x512
label=zarr
smoke=0
while [ $# -gt 0 ]; do
  case "$1" in
    --n) n=$2; shift 2 ;;
    --chunk) chunk=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --smoke) n=256; smoke=1; shift ;;
    *) echo "run_zarr.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
tool=build/bench/bench_zarr_decode
[ -x "$bin" ] && [ -x "$tool" ] || { echo "run_zarr.sh: build voxbrick and bench_zarr_decode first" >&2; exit 2; }
work=bench/work/zarr-$n
mkdir -p "$work" bench/results/zarr
csv=bench/results/zarr/$label.csv
md=bench/results/zarr/$label.md
scene=(--size "$size" --tf hot -q)

seconds() { local s; s=$(date +%s.%N); "$@" > /dev/null; printf '%.2f' "$(echo "$(date +%s.%N) - $s" | bc)"; }
frame_ms() { /usr/bin/python3 -c "import json,sys; print('%.1f' % json.load(open(sys.argv[1]))['ms']['total'])" "$1"; }

echo "codec,n,chunk,write_s,prep_s,first_live_s,first_prepped_s,warm_live_ms,warm_prepped_ms,frames_equal,voxbrick_decode_mbps,library_decode_mbps,level0_read_mbps" > "$csv"
decode_rows=()
for codec in blosc-lz4 zstd; do
  case $codec in
    blosc-lz4) comp='{"id": "blosc", "cname": "lz4", "shuffle": 1}' ;;
    zstd) comp='{"id": "zstd", "level": 3}' ;;
  esac
  zarr=$work/$codec.ome.zarr
  spec="{\"out\": \"$zarr\", \"shape\": [$n, $n, $n], \"levels\": 5, \"chunks\": [$chunk, $chunk, $chunk], \"dtype\": \"<u2\", \"compressor\": $comp}"
  if [ ! -f "$zarr/.zattrs" ]; then
    write_s=$(seconds /usr/bin/python3 tests/support/zarr_fixture.py "$spec")
  else
    write_s=
  fi
  rm -rf "$work/$codec.store"
  prep_s=$(seconds "$bin" prep "$zarr" --no-vdb -q -o "$work/$codec.store")
  first_live=$(seconds "$bin" render "$zarr" "${scene[@]}" -o "$work/$codec-live.png")
  first_prepped=$(seconds "$bin" render "$work/$codec.store" "${scene[@]}" -o "$work/$codec-prepped.png")
  "$bin" render "$zarr" "${scene[@]}" --warm-up 2 --stats "$work/live.json" -o "$work/$codec-live-warm.png"
  "$bin" render "$work/$codec.store" "${scene[@]}" --warm-up 2 --stats "$work/prepped.json" -o "$work/$codec-prepped-warm.png"
  equal=no
  cmp -s "$work/$codec-live.png" "$work/$codec-prepped.png" && equal=yes
  row=$("$tool" "$zarr" --repeats 3)
  decode_rows+=("$row")
  IFS=, read -r _ _ _ _ _ _ ours lib region <<< "$row"
  echo "$codec,$n,$chunk,$write_s,$prep_s,$first_live,$first_prepped,$(frame_ms "$work/live.json"),$(frame_ms "$work/prepped.json"),$equal,$ours,$lib,$region" >> "$csv"
done

{
  if [ "$smoke" = 1 ]; then
    echo "# OME-Zarr live against prepped: SMOKE RUN (${n}³, a loaded shared machine; proves the script, not a measurement)"
    echo
    echo "The figures below only show that every step runs and that the live and prepped frames are the same; the"
    echo "measurement is \`bash bench/run_zarr.sh\` (1024³) on a quiet machine, which replaces this file."
  else
    echo "# OME-Zarr live against prepped (${n}³ u16, 5 levels, chunks ${chunk}³)"
  fi
  echo
  echo "\`bash bench/run_zarr.sh$([ "$smoke" = 1 ] && echo ' --smoke')\` on $(date -u +%Y-%m-%d), $(nproc) cores,"
  echo "frames ${size} with the hot preset on $("$bin" render "$work/blosc-lz4.store" --size 8x8 -o "$work/x.png" 2>&1 | sed -n 's/^render: \(.*\)$/\1/p' | head -1)."
  echo "First frame: a fresh process (live: open, the pass over the chunks, the frame). Warm: after --warm-up 2, the"
  echo "frame's own ms. Decode: MB/s of decoded chunk bytes on one thread, level 0; voxbrick = decodeZarrChunk (checks,"
  echo "then the codec), library = the codec's own call on the same bytes into a ready buffer; level read = level 0 cut"
  echo "in slabs through ZarrChunks (file reads, decode, copy) in MB/s of voxels."
  echo
  echo "| codec | write s | prep s | first frame live s | first frame prepped s | warm live ms | warm prepped ms | same frame | decode MB/s voxbrick | decode MB/s library | level read MB/s |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  tail -n +2 "$csv" | while IFS=, read -r codec _ _ w p fl fp wl wp eq ours lib region; do
    echo "| $codec | ${w:-(cached)} | $p | $fl | $fp | $wl | $wp | $eq | $ours | $lib | $region |"
  done
} > "$md"
cat "$md"
