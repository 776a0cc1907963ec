#!/usr/bin/env bash
# Atlas uploads, direct against staged (a fenced ring of pixel-unpack buffers), on a frame that re-pages its bricks
# every time (the atlas budget far below the frame's bricks): warm frames (`--warm-up 1`), the two alternated
# --reps times in one run so that both see the same background load. The staged run gets 8 MB more budget, its
# ring's (BrickAtlas::kStagingBytes), so that both atlases have the same slots and the frames must be equal. Writes
# bench/results/render/uploads.{csv,md}.
#
#   bash bench/run_uploads.sh [--store bench/work/blobs-1024.vbs] [--lod 2] [--gpu-budget 64] [--reps 5]
#                             [--size 512x512] [--tf hot]
set -euo pipefail
cd "$(dirname "$0")/.."
store=bench/work/blobs-1024.vbs lod=2 gpu=64 reps=5 size=512x512 tf=hot
while [ $# -gt 0 ]; do
  case "$1" in
    --store) store=$2; shift 2 ;;
    --lod) lod=$2; shift 2 ;;
    --gpu-budget) gpu=$2; shift 2 ;;
    --reps) reps=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --tf) tf=$2; shift 2 ;;
    *) echo "run_uploads.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
[ -x "$bin" ] || { echo "run_uploads.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
[ "$gpu" -ge 56 ] || { echo "run_uploads.sh: --gpu-budget at least 56 (MB), so that the ring is a whole 8 MB" >&2; exit 2; }
[ -f "$store/store.json" ] || { echo "run_uploads.sh: no store $store (bench/run_lod.sh preps the 1024³ blobs)" >&2; exit 2; }
export VOXBRICK_CONFIG_DIR=${VOXBRICK_CONFIG_DIR:-$PWD/config}
work=bench/work/uploads
mkdir -p "$work" bench/results/render
csv=bench/results/render/uploads.csv
echo "rep,uploads,ms_total,ms_paging,ms_drawing,bricks_paged_in,batches" > "$csv"
device=""
for ((r = 0; r < reps; ++r)); do
  for u in direct staged; do
    budget=$gpu
    [ "$u" = staged ] && budget=$((gpu + 8))
    out=$("$bin" render "$store" --size "$size" --tf "$tf" --lod "$lod" --gpu-budget "$budget" --uploads "$u" \
      --warm-up 1 --stats "$work/$u.json" -o "$work/$u.png" 2>&1)
    [ -n "$device" ] || device=$(grep -m1 '^render: [^w]' <<< "$out" | sed 's/^render: //')
    python3 - "$work/$u.json" "$r" "$u" >> "$csv" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
print(f"{sys.argv[2]},{sys.argv[3]},{s['ms']['total']:.1f},{s['ms']['paging']:.1f},{s['ms']['drawing']:.1f},"
      f"{s['bricks_paged_in']},{s['batches']}")
PY
    tail -1 "$csv"
  done
  "$bin" compare "$work/direct.png" "$work/staged.png" | grep -q "max_abs 0$" \
    || { echo "run_uploads.sh: staged and direct frames differ" >&2; exit 1; }
done
python3 - "$csv" "$device" "$store" "$lod" "$gpu" "$size" "$tf" "$reps" > bench/results/render/uploads.md <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
device, store, lod, gpu, size, tf, reps = sys.argv[2:9]
print("# Atlas uploads: direct against staged\n")
print(f"Device: {device}. `bash bench/run_uploads.sh --store {store} --lod {lod} --gpu-budget {gpu} --reps {reps}` "
      f"({size}, `{tf}`): a warm frame whose bricks do not fit the atlas, so it re-pages them every time; the two "
      f"alternated {reps} times in one run; staged with 8 MB more budget for its ring, so that both atlases have the "
      f"same slots. Frames equal in every repetition.\n")
print("| uploads | median ms | median paging ms | median drawing ms | bricks paged in | batches |")
print("|---|---:|---:|---:|---:|---:|")
med = {}
for u in ("direct", "staged"):
    r = [x for x in rows if x["uploads"] == u]
    med[u] = statistics.median(float(x["ms_total"]) for x in r)
    print(f"| {u} | {med[u]:.0f} | {statistics.median(float(x['ms_paging']) for x in r):.0f} | "
          f"{statistics.median(float(x['ms_drawing']) for x in r):.0f} | {r[0]['bricks_paged_in']} | {r[0]['batches']} |")
print(f"\nStaged / direct: {med['staged'] / med['direct']:.2f}× the time.")
PY
cat bench/results/render/uploads.md
