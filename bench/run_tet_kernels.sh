#!/usr/bin/env bash
# The mesh ray caster's two kernels side by side (Scene::raycaster fragment against compute), taking turns: warm
# frames (`voxbrick render --warm-up 2`) of a synthetic ball mesh, tf hot, at each size, ROUNDS times; the two
# kernels' last frames compared. Writes bench/results/tets/raycaster-kernels.{csv,md}.
#
#   bash bench/run_tet_kernels.sh [--n 40] [--sizes 512,1024] [--rounds 5]
set -euo pipefail
cd "$(dirname "$0")/.."
n=40 sizes=512,1024 rounds=5
while [ $# -gt 0 ]; do
  case "$1" in
    --n) n=$2; shift 2 ;;
    --sizes) sizes=$2; shift 2 ;;
    --rounds) rounds=$2; shift 2 ;;
    *) echo "run_tet_kernels.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
work=bench/work/tet-kernels
out=bench/results/tets
mkdir -p "$work" "$out"
mesh=$work/ball-$n
[ -d "$mesh" ] || "$bin" prep "synthetic-mesh:ball,n=$n" -q -o "$mesh"
tets=$("$bin" info "$mesh" | awk '$1 == "tets" {print $2}')
csv=$out/raycaster-kernels.csv
echo "# $(date -u +%Y-%m-%d), $(nproc) cores, $(git rev-parse --short HEAD); bash bench/run_tet_kernels.sh --n $n --sizes $sizes --rounds $rounds; ball of $tets tets" > "$csv"
echo "size,round,kernel,ms_total,ms_drawing" >> "$csv"
for r in $(seq 1 "$rounds"); do
  for size in ${sizes//,/ }; do
    for k in fragment compute; do
      "$bin" render "$mesh" --tf hot --visibility raycast --raycaster "$k" --size "${size}x${size}" --warm-up 2 -q \
        --stats "$work/stats.json" -o "$work/$k-$size.png" > /dev/null
      python3 -c "import json; s = json.load(open('$work/stats.json')); assert s['raycaster'] == '$k'; print('$size,$r,$k,%.2f,%.2f' % (s['ms']['total'], s['ms']['drawing']))" >> "$csv"
    done
  done
done
{
  python3 - "$csv" << 'PY'
import csv, statistics, sys
lines = open(sys.argv[1]).read().splitlines()
rows = list(csv.DictReader(lines[1:]))
print(f"The mesh ray caster's fragment and compute kernels, warm frames taking turns; {lines[0].lstrip('# ')}. Medians, ms.\n")
print("| size | fragment drawing | compute drawing | compute / fragment |")
print("|---|---:|---:|---:|")
for size in dict.fromkeys(r['size'] for r in rows):
    m = lambda k: statistics.median(float(r['ms_drawing']) for r in rows if r['size'] == size and r['kernel'] == k)
    print(f"| {size}² | {m('fragment'):.1f} | {m('compute'):.1f} | {m('compute') / m('fragment'):.2f} |")
PY
  echo
  for size in ${sizes//,/ }; do
    echo "- ${size}²: $("$bin" compare "$work/fragment-$size.png" "$work/compute-$size.png")"
  done
} > "$out/raycaster-kernels.md"
cat "$out/raycaster-kernels.md"
