#!/usr/bin/env bash
# Prep throughput, side by side: MB/s of raw input (bytes / wall time) for threads 1 and 2, for this build and
# (with --base) a previous voxbrick binary, on synthetic fields and on files; `zstd -1` alone on the same raw bytes;
# the CPU time of field evaluation, of the brick path and of the OpenVDB grid apart; and a check that both binaries
# write the same store (bench/store_digest.sh over every file). Writes bench/results/prep.{csv,md}.
#
#   bash bench/run_prep.sh [--base OLD_VOXBRICK] [--repeats 3] [--big-repeats 1] [--work bench/work/prep]
#
# Runs alternate between binaries and thread counts so that load from other work hits them alike; medians of
# --repeats runs (--big-repeats for the 1024³ field, about a minute a run).
set -euo pipefail
cd "$(dirname "$0")/.."
base="" repeats=3 big=1 work=bench/work/prep
while [ $# -gt 0 ]; do
  case "$1" in
    --base) base=$(realpath "$2"); shift 2 ;;
    --repeats) repeats=$2; shift 2 ;;
    --big-repeats) big=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    *) echo "run_prep.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
new=build/voxbrick
[ -x "$new" ] && [ -x build/bench/bench_store ] || { echo "run_prep.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
mkdir -p "$work" bench/results
bins=(new)
[ -n "$base" ] && bins=(base new)
binary() { if [ "$1" = base ]; then echo "$base"; else echo "$new"; fi; }
mri=/usr/share/mricron/templates/ch2better.nii.gz
raw=$work/blobs-512.raw
[ -f "$raw" ] || build/bench/bench_store --make-raw "$raw" --spec blobs,n=512 > /dev/null

csv=bench/results/prep.csv
echo "tool,input,threads,run,wall_s,cpu_s,peak_rss_mb,raw_mb,mb_per_s" > "$csv"
timed() {  # timed TOOL INPUT THREADS RUN RAW_BYTES COMMAND...: one run, one CSV row
  local tool=$1 input=$2 threads=$3 run=$4 bytes=$5
  shift 5
  /usr/bin/time -f "%e %U %S %M" -o "$work/time" "$@" > /dev/null
  read -r wall user sys rss < "$work/time"
  python3 - "$tool" "$input" "$threads" "$run" "$wall" "$user" "$sys" "$rss" "$bytes" <<'EOF' | tee -a "$csv"
import csv, sys
tool, name, threads, run, wall, user, system, rss, size = sys.argv[1:]
w, b = float(wall), float(size)
csv.writer(sys.stdout, lineterminator="\n").writerow(
    [tool, name, threads, run, f"{w:.2f}", f"{float(user) + float(system):.2f}", int(rss) // 1024, f"{b / 1e6:.0f}",
     f"{b / 1e6 / w:.1f}"])
EOF
}
prep() {  # prep BIN INPUT_NAME THREADS RUN RAW_BYTES ARGS...
  local bin=$1 name=$2 threads=$3 run=$4 bytes=$5
  shift 5
  timed "prep-$bin" "$name" "$threads" "$run" "$bytes" "$(binary "$bin")" prep "$@" --threads "$threads" \
    -o "$work/out.vbs" --force -q
}

# 1. The same store from both binaries, threads 1 and 2 (with and without the grid, several chunks).
if [ -n "$base" ]; then
  identical=""
  for input in "synthetic:blobs,n=256" "synthetic:sparse,n=256 --vdb-chunk 40" "$mri" \
               "$raw --dims 512,512,512 --type f32 --no-vdb --brick 16"; do
    for bin in base new; do
      for t in 1 2; do
        # shellcheck disable=SC2086
        "$(binary $bin)" prep $input --threads $t -o "$work/id-$bin-$t.vbs" --force -q > /dev/null
        bash bench/store_digest.sh "$work/id-$bin-$t.vbs" > "$work/id-$bin-$t.sha"
      done
    done
    same=yes
    for f in base-2 new-1 new-2; do cmp -s "$work/id-base-1.sha" "$work/id-$f.sha" || same=no; done
    identical+="| \`$input\` | $(wc -l < "$work/id-base-1.sha") | $same |"$'\n'
    rm -rf "$work"/id-*.vbs
  done
fi

# 2. Throughput, alternating binaries and threads.
for ((r = 1; r <= repeats; ++r)); do
  for bin in "${bins[@]}"; do
    for t in 1 2; do
      prep "$bin" "synthetic:blobs,n=512" "$t" "$r" $((512 ** 3 * 4)) "synthetic:blobs,n=512"
      prep "$bin" "raw f32 512³ (blobs)" "$t" "$r" $((512 ** 3 * 4)) "$raw" --dims 512,512,512 --type f32
      prep "$bin" "raw f32 512³ (blobs), --no-vdb" "$t" "$r" $((512 ** 3 * 4)) "$raw" --dims 512,512,512 \
        --type f32 --no-vdb
      prep "$bin" "MRI ch2better.nii.gz (u8, gzip)" "$t" "$r" $((301 * 370 * 316)) "$mri"
    done
  done
  for t in 1 2; do
    timed zstd "raw f32 512³ (blobs)" "$t" "$r" $((512 ** 3 * 4)) zstd -1 -T"$t" -c -f "$raw"
  done
  # CPU time of the parts, apart: the field alone (written to /dev/null) and the brick path alone.
  timed "blobs field only" "synthetic:blobs,n=512" 2 "$r" $((512 ** 3 * 4)) \
    build/bench/bench_store --make-raw /dev/null --spec blobs,n=512
done
for ((r = 1; r <= big; ++r)); do
  for bin in "${bins[@]}"; do
    for t in 1 2; do
      prep "$bin" "synthetic:blobs,n=1024" "$t" "$r" $((1024 ** 3 * 4)) "synthetic:blobs,n=1024"
    done
  done
done
rm -rf "$work/out.vbs"

python3 - "$csv" "${identical:-}" "$(nproc)" "$(uptime | sed 's/.*load average: //')" "$repeats" "$big" \
  > bench/results/prep.md <<'EOF'
import collections, csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
identical, cores, load, repeats, big = sys.argv[2:7]
runs = collections.defaultdict(list)
for r in rows: runs[(r["input"], r["tool"], r["threads"])].append(r)
def med(key, field):
    return statistics.median(float(r[field]) for r in runs[key]) if runs.get(key) else None
inputs = list(dict.fromkeys(r["input"] for r in rows))
tools = list(dict.fromkeys(r["tool"] for r in rows))
print("# Prep throughput\n")
print(f"MB/s = raw input bytes / wall time, median of {repeats} runs ({big} for the 1024³ field); CPU = user + "
      f"system seconds. {cores} cores shared with other work (load average at the end: {load}).\n")
print("| input | tool | MB/s, 1 thread | MB/s, 2 threads | wall s, 1 / 2 | CPU s, 1 / 2 | peak RSS MB |")
print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
for i in inputs:
    for t in tools:
        if not runs.get((i, t, "1")) and not runs.get((i, t, "2")): continue
        f = lambda th, field, fmt: (fmt % med((i, t, th), field)) if runs.get((i, t, th)) else ""
        print(f"| {i} | {t} | {f('1', 'mb_per_s', '%.1f')} | {f('2', 'mb_per_s', '%.1f')} | "
              f"{f('1', 'wall_s', '%.1f')} / {f('2', 'wall_s', '%.1f')} | {f('1', 'cpu_s', '%.1f')} / "
              f"{f('2', 'cpu_s', '%.1f')} | {f('2', 'peak_rss_mb', '%.0f') or f('1', 'peak_rss_mb', '%.0f')} |")
if identical:
    print("\nThe same store from both binaries and both thread counts (`bench/store_digest.sh`: SHA-256 of every "
          "file, OpenVDB's random file UUID masked):\n")
    print("| input and options | files | identical |\n| --- | ---: | --- |")
    print(identical.rstrip())
EOF
cat bench/results/prep.md
