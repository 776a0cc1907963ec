#!/usr/bin/env bash
# Before/after timing of two renderer builds, alternated so that drift of a shared machine falls on both:
#   bash bench/run_ab.sh BEFORE/bench_render AFTER/bench_render OUT_DIR ROUNDS [bench_render options...]
# e.g. bash bench/run_ab.sh /tmp/old/bench_render build/bench/bench_render bench/work/ab 3 \
#        --work bench/work --size 512 --views 12 --step 1 --datasets sparse-256,mri-ch2better \
#        --configs 'vertex slicer, skip|cpu slicer, skip'
# Writes OUT_DIR/{before,after}-ROUND.{csv,md,log} and OUT_DIR/summary.md: per dataset and setting, the median over
# rounds of each run's median frame time, every run's value, and after / before.
set -euo pipefail
[ $# -ge 4 ] || { sed -n 2,8p "$0"; exit 2; }
before=$1 after=$2 out=$3 rounds=$4
shift 4
cd "$(dirname "$0")/.."
export VOXBRICK_CONFIG_DIR=$PWD/config
mkdir -p "$out"
for r in $(seq "$rounds"); do
  for side in before after; do
    bin=$before
    [ "$side" = after ] && bin=$after
    "$bin" --out "$out" --name "$side-$r" "$@" > "$out/$side-$r.log" 2>&1
    echo "$side-$r done"
  done
done
python3 - "$out" > "$out/summary.md" <<'PY'
import collections, glob, math, statistics, sys
out = sys.argv[1]
rows = collections.defaultdict(list)
for side in ("before", "after"):
    for f in sorted(glob.glob(f"{out}/{side}-[0-9]*.csv")):
        for line in open(f).read().strip().split("\n")[1:]:
            p = line.split(",")  # setting names hold commas: the 12 numeric columns are counted from the right
            rows[(p[0], ",".join(p[1:-12]), side)].append(float(p[-7]))
print("| dataset | setting | before: median ms (each run) | after: median ms (each run) | after / before |")
print("| --- | --- | ---: | ---: | ---: |")
ratios = []
for d, c in sorted({(d, c) for d, c, _ in rows}):
    b, a = rows[(d, c, "before")], rows[(d, c, "after")]
    ratios.append(statistics.median(a) / statistics.median(b))
    runs = lambda v: ", ".join(f"{x:.1f}" for x in v)
    print(f"| {d} | {c} | {statistics.median(b):.1f} ({runs(b)}) | {statistics.median(a):.1f} ({runs(a)}) | {ratios[-1]:.3f} |")
print(f"\ngeometric mean of after / before: {math.exp(sum(map(math.log, ratios)) / len(ratios)):.3f}")
PY
cat "$out/summary.md"
