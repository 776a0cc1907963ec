#!/usr/bin/env bash
# The frame ray caster's two kernels side by side (`--raycaster fragment` against `--raycaster compute`, the same
# samples): the MRI (Debian's mricron-data ch2better, prepped once into bench/work/mri.vbs) at 512² and 1024² with
# the default settings, and, if it exists, the prepped 1024³ f32 field (bench/work/blobs-1024.vbs, made by
# bench/run_lod.sh) at 32² and 512² with --lod 1. Every frame is warm (`--warm-up 2`: bricks paged, programs built);
# the kernels alternate --reps times in one run so that both see the same background load, and each pair of frames is
# compared (max |diff| of the 8-bit images). Writes bench/results/render/raycaster.{csv,md}.
#
#   bash bench/run_raycaster.sh [--reps 3] [--blobs bench/work/blobs-1024.vbs] [--name raycaster]
set -euo pipefail
cd "$(dirname "$0")/.."
reps=3 blobs=bench/work/blobs-1024.vbs name=raycaster
while [ $# -gt 0 ]; do
  case "$1" in
    --reps) reps=$2; shift 2 ;;
    --blobs) blobs=$2; shift 2 ;;
    --name) name=$2; shift 2 ;;
    *) echo "run_raycaster.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=${VOXBRICK:-build/voxbrick}
[ -x "$bin" ] || { echo "run_raycaster.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
export VOXBRICK_CONFIG_DIR=${VOXBRICK_CONFIG_DIR:-$PWD/config}
mri=/usr/share/mricron/templates/ch2better.nii.gz
[ -f bench/work/mri.vbs/store.json ] || "$bin" prep "$mri" -o bench/work/mri.vbs -q
work=bench/work/raycaster
mkdir -p "$work" bench/results/render
csv=bench/results/render/$name.csv
echo "case,rep,raycaster,ms_total,ms_drawing,samples,fragments,batches,max_abs_vs_fragment" > "$csv"
cases=("mri-512|bench/work/mri.vbs|512|" "mri-1024|bench/work/mri.vbs|1024|")
if [ -f "$blobs/store.json" ]; then
  cases+=("blobs-1024-lod1-32|$blobs|32|--lod 1" "blobs-1024-lod1-512|$blobs|512|--lod 1")
else
  echo "run_raycaster.sh: no $blobs; the MRI only" >&2
fi
device=""
for c in "${cases[@]}"; do
  IFS='|' read -r label store size extra <<< "$c"
  for ((r = 0; r < reps; ++r)); do
    for k in fragment compute; do
      # shellcheck disable=SC2086 # $extra is options
      out=$("$bin" render "$store" --size "${size}x$size" $extra --raycaster "$k" --warm-up 2 \
        --stats "$work/$k.json" -o "$work/$k.png" 2>&1) || { echo "$out" >&2; exit 1; }
      [ -n "$device" ] || device=$(grep -m1 '^render: [^w]' <<< "$out" | sed 's/^render: //')
      diff=0
      [ "$k" = compute ] && diff=$("$bin" compare "$work/fragment.png" "$work/compute.png" | sed 's/.*max_abs //')
      python3 - "$work/$k.json" "$label" "$r" "$k" "$diff" >> "$csv" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
assert s["raycaster"] == sys.argv[4], "the frame was drawn by " + s["raycaster"]
print(f"{sys.argv[2]},{sys.argv[3]},{sys.argv[4]},{s['ms']['total']:.1f},{s['ms']['drawing']:.1f},{s['samples']},"
      f"{s['fragments']},{s['batches']},{sys.argv[5]}")
PY
      tail -1 "$csv"
    done
  done
done
python3 - "$csv" "$device" "$reps" "$name" > "bench/results/render/$name.md" <<'PY'
import csv, datetime, os, statistics, subprocess, sys
rows = list(csv.DictReader(open(sys.argv[1])))
device, reps, name = sys.argv[2:5]
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "unknown CPU")
print("# The frame ray caster: fragment kernel against compute kernel\n")
print(f"Device: {device}; {cpu}, {os.cpu_count()} cores. {datetime.date.today()}. "
      f"`bash bench/run_raycaster.sh --reps {reps} --name {name}`: warm frames (`voxbrick render --warm-up 2`, default "
      f"settings: step 0.75, ert 0.999, sub-block 8, lod 1 unless the case says), the kernels alternated {reps} times "
      "in one run; `max |diff|` is the largest difference between the two kernels' 8-bit frames of a repetition.\n")
print("| case | kernel | median ms (total) | median ms (drawing) | samples | fragments (rays) | batches | "
      "compute / fragment (drawing) | max \\|diff\\| |")
print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
for case in dict.fromkeys(r["case"] for r in rows):
    med = {}
    for k in ("fragment", "compute"):
        sel = [r for r in rows if r["case"] == case and r["raycaster"] == k]
        med[k] = statistics.median(float(r["ms_drawing"]) for r in sel)
        total = statistics.median(float(r["ms_total"]) for r in sel)
        ratio = f"{med[k] / med['fragment']:.2f}" if k == "compute" else ""
        diff = max(float(r["max_abs_vs_fragment"]) for r in sel) if k == "compute" else ""
        print(f"| {case} | {k} | {total:.1f} | {med[k]:.1f} | {sel[0]['samples']} | {sel[0]['fragments']} | "
              f"{sel[0]['batches']} | {ratio} | {diff} |")
PY
cat "bench/results/render/$name.md"
