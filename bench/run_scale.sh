#!/usr/bin/env bash
# Scale: a volume many times the budgets, prepped quantised to u8, then rendered under a 1 GB host cache and a
# 512 MB GPU atlas: prep throughput and peak RSS, a cold first frame, a warm orbit at a level of detail, bricks per
# level, and the PSNR of a LOD frame against the level-0 frame of the same view. Writes
# bench/results/scale.{csv,md}.
#
#   bash bench/run_scale.sh [--n 2048] [--views 36] [--lod 1] [--size 512x512] [--work bench/work/scale]
#                           [--keep] [--level0-frames 1]
#
# Level-0 frames of a 2048³ volume take minutes on llvmpipe, so only --level0-frames views (default 1) get one.
# The store is written without the OpenVDB grid (--no-vdb): at 2048² voxels a slice, one grid chunk alone needs
# more than the 1 GB --memory, and nothing at run time reads it. It is removed afterwards unless --keep.
set -euo pipefail
cd "$(dirname "$0")/.."
n=2048 views=36 lod=1 size=512x512 work=bench/work/scale keep=0 level0=1
host=1024 gpu=512
while [ $# -gt 0 ]; do
  case "$1" in
    --n) n=$2; shift 2 ;;
    --views) views=$2; shift 2 ;;
    --lod) lod=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --keep) keep=1; shift ;;
    --level0-frames) level0=$2; shift 2 ;;
    *) echo "run_scale.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
[ -x "$bin" ] || { echo "run_scale.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
export VOXBRICK_CONFIG_DIR=${VOXBRICK_CONFIG_DIR:-$PWD/config}
mkdir -p "$work" bench/results
store=$work/blobs-$n-u8.vbs
spec=synthetic:blobs,n=$n
raw_mb=$(( n * n * n * 4 / 1000000 ))
need_mb=$(( n * n * n / 1000000 + 1000 ))  # about one byte a voxel stored, and room to spare
free_mb=$(df -Pm "$work" | awk 'NR == 2 { print $4 }')
[ "$free_mb" -gt "$need_mb" ] || { echo "run_scale.sh: $free_mb MB free in $work, want $need_mb" >&2; exit 1; }

# Prep: two passes over the field (its exact range first, then the store).
prep_cmd=("$bin" prep "$spec" --quantise u8 --no-vdb -o "$store" --force -q)
echo "${prep_cmd[*]}"
/usr/bin/time -v "${prep_cmd[@]}" > "$work/prep.out" 2> "$work/prep.time"
cat "$work/prep.out"
prep_s=$(awk -F': ' '/Elapsed \(wall clock\)/ { n = split($2, t, ":"); s = 0; for (i = 1; i <= n; ++i) s = s * 60 + t[i]; print s }' "$work/prep.time")
prep_cpu=$(awk -F': ' '/User time/ { u = $2 } /System time/ { s = $2 } END { print u + s }' "$work/prep.time")
prep_rss_mb=$(awk -F': ' '/Maximum resident/ { print int($2 / 1024) }' "$work/prep.time")
stored_mb=$(python3 -c "import json,sys; print(round(json.load(open(sys.argv[1]))['bytes_stored'] / 1e6))" "$store/store.json")
"$bin" info "$store" | sed -n '3,20p' > "$work/info.txt"
cat "$work/info.txt"

render() {  # render NAME LOD WARMUP AZIMUTH: one frame in a fresh process, its stats and peak RSS
  /usr/bin/time -f "%M" -o "$work/$1.rss" "$bin" render "$store" --size "$size" --orbit "$4,20,2.5" --lod "$2" \
    --warm-up "$3" --host-budget "$host" --gpu-budget "$gpu" --stats "$work/$1.json" -o "$work/$1.png" -q
}
row() {  # row NAME KIND LOD AZIMUTH [REFERENCE_PNG]
  local psnr=""
  [ -n "${5:-}" ] && psnr=$("$bin" compare "$5" "$work/$1.png" | sed -E 's/.*psnr ([^ ]+) dB.*/\1/')
  python3 - "$work/$1.json" "$2" "$3" "$4" "$(cat "$work/$1.rss")" "$psnr" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
levels = " ".join(str(v) for v in s.get("bricks_per_level", []))
# bricks_standin: left empty until the renderer reports stand-ins (coarse-to-fine streaming).
print(f"{sys.argv[2]},{sys.argv[3]},{sys.argv[4]},{s['ms']['total']:.0f},{s['ms']['paging']:.0f},"
      f"{s['ms']['drawing']:.0f},{s['bricks_drawn']},{s['bricks_paged_in']},{s['bricks_evicted']},{levels},,"
      f"{int(sys.argv[5]) // 1024},{sys.argv[6]}")
EOF
}

csv=bench/results/scale.csv
frames=$work/frames.csv
echo "frame,lod,azimuth,ms_total,ms_paging,ms_drawing,bricks_drawn,bricks_paged_in,bricks_evicted,bricks_per_level,bricks_standin,peak_rss_mb,psnr_vs_level0_db" > "$frames"
render first "$lod" 0 0
row first first "$lod" 0 >> "$frames"
for ((v = 0; v < views; ++v)); do
  az=$(( v * 360 / views ))
  render "view$v" "$lod" 1 "$az"  # the timed frame is the second of the process: warm cache and atlas
  row "view$v" warm "$lod" "$az" >> "$frames"
  tail -1 "$frames"
done
for ((v = 0; v < level0; ++v)); do
  az=$(( v * 360 / views ))
  render "level0-$v" 0 0 "$az"
  row "view$v" "warm vs level 0" "$lod" "$az" "$work/level0-$v.png" >> "$frames"
  row "level0-$v" level0 0 "$az" >> "$frames"
  tail -2 "$frames"
done

{
  echo "# prep: $spec quantised to u8, --no-vdb, $(nproc) cores, $(date -u +%Y-%m-%d)"
  echo "n,raw_f32_mb,prep_s,prep_cpu_s,prep_mb_per_s,peak_rss_mb,stored_mb"
  echo "$n,$raw_mb,$prep_s,$prep_cpu,$(python3 -c "print(round($raw_mb / $prep_s, 1))"),$prep_rss_mb,$stored_mb"
  echo "# frames: ${size}, --host-budget $host --gpu-budget $gpu, each in a fresh process"
  cat "$frames"
} > "$csv"

python3 - "$csv" "$work/info.txt" "${prep_cmd[*]}" "$host" "$gpu" "$size" "$views" "$lod" > bench/results/scale.md <<'EOF'
import csv, statistics, sys
lines = open(sys.argv[1]).read().splitlines()
prep = dict(zip(lines[1].split(","), lines[2].split(",")))
frames = list(csv.DictReader(lines[4:]))
warm = [f for f in frames if f["frame"] == "warm"]
first = next(f for f in frames if f["frame"] == "first")
level0 = [f for f in frames if f["frame"] == "level0"]
compared = [f for f in frames if f["frame"] == "warm vs level 0"]
host, gpu, size, views, lod = sys.argv[4:9]
print(f"# Scale: a {prep['n']}³ field quantised to u8 under a {host} MB host cache and a {gpu} MB GPU atlas\n")
print(f"Prep: `{sys.argv[3]}` (machine: see bench/README.md; other work shared the cores).\n")
print("| n | raw f32 | prep wall | prep CPU | MB/s (raw f32 / wall) | peak RSS | stored |")
print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
print(f"| {prep['n']} | {prep['raw_f32_mb']} MB | {prep['prep_s']} s | {float(prep['prep_cpu_s']):.0f} s | "
      f"{prep['prep_mb_per_s']} | {prep['peak_rss_mb']} MB | {prep['stored_mb']} MB |\n")
print("```\n" + open(sys.argv[2]).read().rstrip() + "\n```\n")
ms = [float(f["ms_total"]) for f in warm]
print(f"Frames at {size}, `--lod {lod}`, each view in a fresh process (`voxbrick render`):\n")
print("| frame | ms | paged in | evicted | bricks per level | stand-ins | peak RSS |")
print("| --- | ---: | ---: | ---: | --- | ---: | ---: |")
print(f"| first (cold) | {first['ms_total']} | {first['bricks_paged_in']} | {first['bricks_evicted']} | "
      f"{first['bricks_per_level']} | {first['bricks_standin'] or 'n/a'} | {first['peak_rss_mb']} MB |")
if ms:
    print(f"| warm orbit, {len(ms)} views: median (min–max) | {statistics.median(ms):.0f} ({min(ms):.0f}–{max(ms):.0f}) "
          f"| | | | | {max(int(f['peak_rss_mb']) for f in warm)} MB (max) |")
for f, c in zip(level0, compared):
    print(f"| level 0, azimuth {f['azimuth']} | {f['ms_total']} | {f['bricks_paged_in']} | {f['bricks_evicted']} | "
          f"{f['bricks_per_level']} | | {f['peak_rss_mb']} MB |")
    print(f"\nLOD {lod} against level 0 at azimuth {c['azimuth']}: PSNR {c['psnr_vs_level0_db']} dB.")
EOF
cat bench/results/scale.md
[ "$keep" = 1 ] || rm -rf "$store"
