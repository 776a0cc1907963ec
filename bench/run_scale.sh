#!/usr/bin/env bash
# Scale: a volume many times the budgets, prepped quantised to u8, then rendered under a 1 GB host cache and a
# 512 MB GPU atlas: prep throughput and peak RSS, a cold first frame (coarse to fine: the provisional frame and its
# stand-ins, then the exact one), a warm orbit at a level of detail, bricks per level, the PSNR of a LOD frame
# against the level-0 frame of the same view, and the cold first frame from the real server under the same budgets
# (provisional and exact, as the client receives them). Writes bench/results/lod/scale.{csv,md}.
#
#   bash bench/run_scale.sh [--n 2048] [--views 36] [--lod 1] [--size 512x512] [--work bench/work/scale]
#                           [--keep] [--level0-frames 1] [--reuse-prep]
#
# --reuse-prep keeps a store (and its prep timing) left in --work by an earlier run with --keep, or by the same
# prep command run by hand with its `/usr/bin/time -v` output in WORK/prep.time.
# Level-0 frames of a 2048³ volume take minutes on llvmpipe, so only --level0-frames views (default 1) get one.
# The store is written without the OpenVDB grid (--no-vdb): at 2048² voxels a slice, one grid chunk alone needs
# more than the 1 GB --memory, and nothing at run time reads it. It is removed afterwards unless --keep.
set -euo pipefail
cd "$(dirname "$0")/.."
n=2048 views=36 lod=1 size=512x512 work=bench/work/scale keep=0 level0=1 reuse=0
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
    --reuse-prep) reuse=1; keep=1; shift ;;
    *) echo "run_scale.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=${VOXBRICK_BIN:-build/voxbrick}  # a copy, to keep rebuilding while it runs
[ -x "$bin" ] || { echo "run_scale.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
export VOXBRICK_CONFIG_DIR=${VOXBRICK_CONFIG_DIR:-$PWD/config}
mkdir -p "$work" bench/results/lod
store=$work/blobs-$n-u8.vbs
spec=synthetic:blobs,n=$n
raw_mb=$(( n * n * n * 4 / 1000000 ))
need_mb=$(( n * n * n / 1000000 + 1000 ))  # about one byte a voxel stored, and room to spare
# Prep: two passes over the field (its exact range first, then the store).
prep_cmd=("$bin" prep "$spec" --quantise u8 --no-vdb -o "$store" --force -q)
if [ "$reuse" = 1 ] && [ -f "$store/store.json" ] && [ -f "$work/prep.time" ]; then
  echo "reusing $store and its prep timing ($work/prep.time)"
else
  free_mb=$(df -Pm "$work" | awk 'NR == 2 { print $4 }')
  [ "$free_mb" -gt "$need_mb" ] || { echo "run_scale.sh: $free_mb MB free in $work, want $need_mb" >&2; exit 1; }
  echo "${prep_cmd[*]}"
  /usr/bin/time -v "${prep_cmd[@]}" > "$work/prep.out" 2> "$work/prep.time"
  cat "$work/prep.out"
fi
prep_s=$(awk -F': ' '/Elapsed \(wall clock\)/ { n = split($2, t, ":"); s = 0; for (i = 1; i <= n; ++i) s = s * 60 + t[i]; print s }' "$work/prep.time")
prep_cpu=$(awk -F': ' '/User time/ { u = $2 } /System time/ { s = $2 } END { print u + s }' "$work/prep.time")
prep_rss_mb=$(awk -F': ' '/Maximum resident/ { print int($2 / 1024) }' "$work/prep.time")
stored_mb=$(python3 -c "import json,sys; print(round(json.load(open(sys.argv[1]))['bytes_stored'] / 1e6))" "$store/store.json")
"$bin" info "$store" | sed -n '3,20p' > "$work/info.txt"
cat "$work/info.txt"

render() {  # render NAME LOD WARMUP AZIMUTH [OPTION...]: one frame in a fresh process, its stats and peak RSS
  local name=$1 level=$2 warm=$3 az=$4
  shift 4
  /usr/bin/time -f "%M" -o "$work/$name.rss" "$bin" render "$store" --size "$size" --orbit "$az,20,2.5" \
    --lod "$level" --warm-up "$warm" --host-cache "$host" --gpu-budget "$gpu" --stats "$work/$name.json" \
    -o "$work/$name.png" -q "$@"
}
row() {  # row NAME KIND LOD AZIMUTH [REFERENCE_PNG]
  local psnr=""
  [ -n "${5:-}" ] && psnr=$("$bin" compare "$5" "$work/$1.png" | sed -E 's/.*psnr ([^ ]+) dB.*/\1/')
  python3 - "$work/$1.json" "$2" "$3" "$4" "$(cat "$work/$1.rss")" "$psnr" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
levels = " ".join(str(v) for v in s.get("bricks_per_level", []))
# A progressive frame: the provisional frame's time and stand-ins; else empty.
p = s.get("provisional_frame")
provisional = f"{p['ms']['total']:.0f},{p['bricks_standin']}" if p else ","
print(f"{sys.argv[2]},{sys.argv[3]},{sys.argv[4]},{s['ms']['total']:.0f},{s['ms']['paging']:.0f},"
      f"{s['ms']['drawing']:.0f},{s['bricks_drawn']},{s['bricks_paged_in']},{s['bricks_evicted']},{levels},"
      f"{provisional},{int(sys.argv[5]) // 1024},{sys.argv[6]}")
EOF
}

csv=bench/results/lod/scale.csv
frames=$work/frames.csv
echo "frame,lod,azimuth,ms_total,ms_paging,ms_drawing,bricks_drawn,bricks_paged_in,bricks_evicted,bricks_per_level,provisional_ms,bricks_standin,peak_rss_mb,psnr_vs_level0_db" > "$frames"
sync && echo 3 > /proc/sys/vm/drop_caches 2>/dev/null || true  # cold: from the disk, where the system allows it
render first "$lod" 0 0 --progressive
row first first "$lod" 0 >> "$frames"
tail -1 "$frames"
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

# The real server, cold, under the same budgets (one render thread): a progressive request's provisional frame and
# the exact one, timed by the client from sending the request.
served=$work/served
port_file=$work/server.port
rm -f "$port_file"
"$bin" serve --datasets "$work" --port 0 --port-file "$port_file" \
  --render-threads 1 --host-cache "$host" --gpu-budget "$gpu" --log-level warn > "$work/server.log" 2>&1 &
server_pid=$!
trap 'kill "$server_pid" 2>/dev/null || true' EXIT
for _ in $(seq 100); do [ -s "$port_file" ] && break; sleep 0.1; done
sync && echo 3 > /proc/sys/vm/drop_caches 2>/dev/null || true
"$bin" request "127.0.0.1:$(cat "$port_file")" --dataset "$(basename "$store")" --size "$size" --orbit "0,20,2.5" \
  --lod "$lod" --progressive --timeout 1200 --stats "$served.json" -o "$served.png" | tee "$work/request.out"
server_rss_mb=$(awk '/^VmHWM/ { print int($2 / 1024) }' "/proc/$server_pid/status")  # peak RSS so far
kill -TERM "$server_pid"
wait "$server_pid" || true
trap - EXIT
server_provisional_ms=$(sed -nE 's/.*provisional frame \(([0-9]+) bricks stood in\) at ([0-9.]+) ms.*/\2/p' "$work/request.out" | head -1)
server_standins=$(sed -nE 's/.*provisional frame \(([0-9]+) bricks stood in\).*/\1/p' "$work/request.out" | head -1)
server_exact_ms=$(sed -nE 's/.*bytes as [a-z]+\) in ([0-9.]+) ms.*/\1/p' "$work/request.out")

{
  echo "# prep: $spec quantised to u8, --no-vdb, $(nproc) cores, $(date -u +%Y-%m-%d)"
  echo "n,raw_f32_mb,prep_s,prep_cpu_s,prep_mb_per_s,peak_rss_mb,stored_mb"
  echo "$n,$raw_mb,$prep_s,$prep_cpu,$(python3 -c "print(round($raw_mb / $prep_s, 1))"),$prep_rss_mb,$stored_mb"
  echo "# frames: ${size}, --host-cache $host --gpu-budget $gpu, each in a fresh process"
  cat "$frames"
  echo "# server: voxbrick serve --render-threads 1 --host-cache $host --gpu-budget $gpu; request --progressive, cold"
  echo "provisional_ms,bricks_standin,exact_ms,server_peak_rss_mb"
  echo "${server_provisional_ms:-},${server_standins:-},${server_exact_ms:-},$server_rss_mb"
} > "$csv"

python3 - "$csv" "$work/info.txt" "${prep_cmd[*]}" "$host" "$gpu" "$size" "$views" "$lod" > bench/results/lod/scale.md <<'EOF'
import csv, statistics, sys
lines = open(sys.argv[1]).read().splitlines()
prep = dict(zip(lines[1].split(","), lines[2].split(",")))
end = next(i for i, l in enumerate(lines) if l.startswith("# server"))
frames = list(csv.DictReader(lines[4:end]))
server = dict(zip(lines[end + 1].split(","), lines[end + 2].split(",")))
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
if first["provisional_ms"]:
    print(f"| first (cold), provisional | {first['provisional_ms']} | | | | {first['bricks_standin']} | |")
print(f"| first (cold), exact | {first['ms_total']} | {first['bricks_paged_in']} | {first['bricks_evicted']} | "
      f"{first['bricks_per_level']} | | {first['peak_rss_mb']} MB |")
if ms:
    print(f"| warm orbit, {len(ms)} views: median (min–max) | {statistics.median(ms):.0f} ({min(ms):.0f}–{max(ms):.0f}) "
          f"| | | | | {max(int(f['peak_rss_mb']) for f in warm)} MB (max) |")
for f, c in zip(level0, compared):
    print(f"| level 0, azimuth {f['azimuth']} | {f['ms_total']} | {f['bricks_paged_in']} | {f['bricks_evicted']} | "
          f"{f['bricks_per_level']} | | {f['peak_rss_mb']} MB |")
    print(f"\nLOD {lod} against level 0 at azimuth {c['azimuth']}: PSNR {c['psnr_vs_level0_db']} dB.")
peak = max(int(f["peak_rss_mb"]) for f in frames)
print(f"\nPeak RSS of any render process: {peak} MB against {host} MB of host cache + {gpu} MB of atlas (on llvmpipe "
      f"the atlas is host memory too): {peak - int(host) - int(gpu)} MB above the two budgets.\n")
print("The real server (`voxbrick serve --render-threads 1` with the same budgets), cold, one progressive request "
      "(`voxbrick request --progressive`, azimuth 0), timed by the client:\n")
print("| provisional frame | stand-ins | exact frame | server peak RSS |")
print("| ---: | ---: | ---: | ---: |")
print(f"| {server['provisional_ms'] or 'none'} ms | {server['bricks_standin'] or '—'} | {server['exact_ms']} ms | "
      f"{server['server_peak_rss_mb']} MB |")
EOF
cat bench/results/lod/scale.md
[ "$keep" = 1 ] || rm -rf "$store"
