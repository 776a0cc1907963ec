#!/usr/bin/env bash
# Interactive frames through the real server: a scripted drag of --views cameras (one full turn) sent --hz a second
# with "interactive": true and a time budget, on the MRI and on the 1024³ field, at --size. For every interactive
# frame drawn: its time against its budget (within 1.5x passes), its PSNR against the exact frame of its view (drawn
# after the drag), and the time from the last camera to the exact frame the server sends once the camera rests
# (bench_drag). Writes bench/results/interactive/interactive-DATASET.csv and bench/results/interactive/interactive.md.
#
#   bash bench/run_interactive.sh [--size 512] [--views 36] [--hz 20] [--budget 100] [--field-n 1024]
#                                 [--gpu-budget MB] [--host-cache MB]
#
# Needs a build with -DVOXBRICK_BUILD_BENCH=ON (bench_drag). The stores are prepped when they do not exist yet, under
# bench/work (the 1024³ blobs take about a minute and 3.9 GB, as for run_lod.sh). A smoke test: --size 128 --views 6
# --field-n 128.
set -euo pipefail
cd "$(dirname "$0")/.."
size=512 views=36 hz=20 budget=100 fieldN=1024 gpu=1024 host=1024
while [ $# -gt 0 ]; do
  case "$1" in
    --size) size=$2; shift 2 ;;
    --views) views=$2; shift 2 ;;
    --hz) hz=$2; shift 2 ;;
    --budget) budget=$2; shift 2 ;;
    --field-n) fieldN=$2; shift 2 ;;
    --gpu-budget) gpu=$2; shift 2 ;;
    --host-cache) host=$2; shift 2 ;;
    *) echo "run_interactive.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick drag=build/bench/bench_drag
[ -x "$bin" ] && [ -x "$drag" ] || { echo "run_interactive.sh: build with -DVOXBRICK_BUILD_BENCH=ON first" >&2; exit 2; }
mri=/usr/share/mricron/templates/ch2better.nii.gz
datasets=bench/work/interactive
mkdir -p "$datasets" bench/results/interactive
[ -f bench/work/mri.vbs/store.json ] || "$bin" prep "$mri" -o bench/work/mri.vbs -q
field=bench/work/blobs-$fieldN.vbs
[ -f "$field/store.json" ] || "$bin" prep "synthetic:blobs,n=$fieldN" -o "$field" --no-vdb -q
ln -sfn "$(realpath bench/work/mri.vbs)" "$datasets/mri"
ln -sfn "$(realpath "$field")" "$datasets/blobs$fieldN"

portFile=$(mktemp) log=$(mktemp)
"$bin" serve --datasets "$datasets" --port 0 --port-file "$portFile" --render-threads 1 --gpu-budget "$gpu" \
  --host-cache "$host" --log-level info > "$log" 2>&1 &
server=$!
trap 'kill $server 2>/dev/null; wait $server 2>/dev/null; rm -f "$portFile" "$log"' EXIT
for _ in $(seq 100); do [ -s "$portFile" ] && break; sleep 0.1; done
address=127.0.0.1:$(cat "$portFile")

rows=""
status=0
for dataset in mri "blobs$fieldN"; do
  out=$("$drag" --address "$address" --dataset "$dataset" --size "$size" --views "$views" --hz "$hz" \
    --budget "$budget" --out bench/results/interactive --name "interactive-$dataset") || status=1
  echo "$out"
  rows+="$out"$'\n'
  rm -f "bench/results/interactive/interactive-$dataset.md"
done
{
  echo "# Interactive frames through the server: a scripted drag"
  echo
  echo "\`bash bench/run_interactive.sh --size $size --views $views --hz $hz --budget $budget --field-n $fieldN" \
    "--gpu-budget $gpu --host-cache $host\`, $(date -u +%Y-%m-%d), on $(uname -n):" \
    "$(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'), $(nproc) cores, the server's one render thread on" \
    "$(grep -m1 'render threads:' "$log" | sed 's/.*render threads: 1 x //')."
  echo
  echo "One session sends $views cameras of a full turn, $hz a second without waiting, each \`\"interactive\": true\`"
  echo "with \`\"time_budget_ms\": $budget\`; Renders replaced while waiting are answered Superseded. A frame passes"
  echo "when the server's time for it (\`interactive.actual_ms\`: planning, drawing, scaling up) is at most 1.5x the"
  echo "budget. PSNR against the exact frame of the same view, drawn after the drag. The last column is the time from"
  echo "the last camera to the exact frame the server sends once the camera rests (PROTOCOL.md, Session 8). Per frame:"
  echo "\`bench/results/interactive/interactive-DATASET.csv\`."
  echo
  echo "| dataset | cameras | interactive frames | within 1.5x budget | superseded | worst PSNR dB | median PSNR dB | last camera to exact frame ms |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- |"
  printf "%s" "$rows"
} > bench/results/interactive/interactive.md
cat bench/results/interactive/interactive.md
exit $status
