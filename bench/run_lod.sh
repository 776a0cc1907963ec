#!/usr/bin/env bash
# Level of detail on a large volume: warm frames at level 0 and at each --lod, their time and bricks per level, and
# each LOD frame's PSNR against the level-0 frame of the same view (what a user sees change). Writes
# bench/results/lod/lod-large.{csv,md}.
#
#   bash bench/run_lod.sh [--store DIR] [--spec synthetic:blobs,n=1024] [--lods 1,2,4,8] [--tfs grayscale,hot]
#                         [--size 512x512] [--orbit 30,20,2.5]
#
# The store is prepped (f32, no VDB) when it does not exist yet: the 1024³ blobs take about a minute and 3.9 GB.
set -euo pipefail
cd "$(dirname "$0")/.."
store=bench/work/blobs-1024.vbs
spec=synthetic:blobs,n=1024
lods=1,2,4,8
tfs=grayscale,hot
size=512x512
orbit=30,20,2.5
while [ $# -gt 0 ]; do
  case "$1" in
    --store) store=$2; shift 2 ;;
    --spec) spec=$2; shift 2 ;;
    --lods) lods=$2; shift 2 ;;
    --tfs) tfs=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --orbit) orbit=$2; shift 2 ;;
    *) echo "run_lod.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
[ -x "$bin" ] || { echo "run_lod.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
if [ ! -f "$store/store.json" ]; then
  mkdir -p "$(dirname "$store")"
  /usr/bin/time -f "prep: %e s wall, %M KB peak RSS" "$bin" prep "$spec" -o "$store" --no-vdb -q
fi
work=bench/work/lod-large
mkdir -p "$work" bench/results/lod
csv=bench/results/lod/lod-large.csv
echo "tf,lod,ms_total,ms_paging,ms_drawing,bricks_drawn,bricks_per_level,samples,psnr_vs_level0_db,max_abs_vs_level0,speedup" > "$csv"
for tf in ${tfs//,/ }; do
  for lod in 0 ${lods//,/ }; do
    png="$work/$tf-lod$lod.png"
    device=$("$bin" render "$store" --tf "$tf" --size "$size" --orbit "$orbit" --lod "$lod" --warm-up 1 \
      --stats "$work/$tf-lod$lod.json" -o "$png" 2>&1 | grep -v '^render: wrote' | head -1 | sed 's/^render: //')
    if [ "$lod" = 0 ]; then psnr=inf; maxabs=0; else
      line=$("$bin" compare "$work/$tf-lod0.png" "$png")
      psnr=$(sed -E 's/.*psnr ([^ ]+) dB.*/\1/' <<< "$line")
      maxabs=$(sed -E 's/.*max_abs ([^ ]+).*/\1/' <<< "$line")
    fi
    python3 - "$work/$tf-lod$lod.json" "$work/$tf-lod0.json" "$tf" "$lod" "$psnr" "$maxabs" >> "$csv" <<'EOF'
import json, sys
s, base = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
levels = " ".join(str(n) for n in s.get("bricks_per_level", []))
print(f"{sys.argv[3]},{sys.argv[4]},{s['ms']['total']:.1f},{s['ms']['paging']:.1f},{s['ms']['drawing']:.1f},"
      f"{s['bricks_drawn']},{levels},{s['samples']},{sys.argv[5]},{sys.argv[6]},{base['ms']['total'] / s['ms']['total']:.2f}")
EOF
    tail -1 "$csv"
  done
done
{
  echo "# Level of detail on a large volume"
  echo
  echo "Device: $device; $(nproc) cores. Store \`$store\` ($spec), $size, orbit $orbit, default budgets (1 GB host,"
  echo "1 GB GPU). Each frame: \`voxbrick render --warm-up 1\`, the second (warm) frame timed; PSNR of the LOD frame"
  echo "against the level-0 frame of the same view. Command: \`bash bench/run_lod.sh --lods $lods --tfs $tfs\`."
  echo
  echo "| transfer function | lod | ms (warm) | paging ms | drawing ms | bricks drawn | per level (0, 1, …) | samples (M) | PSNR vs level 0 (dB) | max abs | speed-up |"
  echo "|---|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|"
  tail -n +2 "$csv" | while IFS=, read -r tf lod ms paging drawing drawn levels samples psnr maxabs speedup; do
    echo "| $tf | $lod | $ms | $paging | $drawing | $drawn | $levels | $(python3 -c "print(f'{$samples/1e6:.1f}')") | $psnr | $maxabs | ${speedup}× |"
  done
} > bench/results/lod/lod-large.md
echo "wrote $csv and bench/results/lod/lod-large.md"
