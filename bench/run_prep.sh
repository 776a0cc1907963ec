#!/usr/bin/env bash
# Prep throughput against `zstd -1` on the same bytes, side by side in one run: raw f32 files of 512³ and 1024³ (the
# blobs field written as raw once, so that field evaluation is not measured), each prepped with its OpenVDB grid
# (the default, and --vdb-compression blosc as before), with --no-vdb, and compressed by `zstd -1` alone (to
# /dev/null, and to a file beside the store). MB/s = raw bytes / wall seconds; CPU = user + system seconds; peak RSS.
# Prep runs with --threads T and zstd with -TT, for each T of --threads. The phases prep reports (--timings) are kept
# too. With --base, an older voxbrick binary runs beside this build, and their stores are compared file by file
# (bench/store_digest.sh over every file). Writes bench/results/prep/prep.{csv,md} and prep-phases.csv.
#
#   bash bench/run_prep.sh [--base OLD_VOXBRICK] [--threads "2"] [--repeats 3] [--big-repeats 1] [--sizes "512 1024"]
#                          [--work bench/work/prep]
#
# Each prep writes a fresh store (the previous one is removed before the timing starts, as zstd's output file is).
# Runs alternate between tools so that load from other work hits them alike; medians of --repeats runs
# (--big-repeats for 1024³, about half a minute a run). --sizes 256 makes a quick smoke run.
set -euo pipefail
cd "$(dirname "$0")/.."
command="bash bench/run_prep.sh $*"
base="" repeats=3 big=1 work=bench/work/prep threads="2" sizes="512 1024"
while [ $# -gt 0 ]; do
  case "$1" in
    --base) base=$(realpath "$2"); shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --repeats) repeats=$2; shift 2 ;;
    --big-repeats) big=$2; shift 2 ;;
    --sizes) sizes=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    *) echo "run_prep.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
new=build/voxbrick
[ -x "$new" ] && [ -x build/bench/bench_store ] || { echo "run_prep.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
mkdir -p "$work" bench/results/prep
load_start=$(uptime | sed 's/.*load average: //')
mri=/usr/share/mricron/templates/ch2better.nii.gz
for n in $sizes; do
  [ -f "$work/blobs-$n.raw" ] || build/bench/bench_store --make-raw "$work/blobs-$n.raw" --spec "blobs,n=$n" > /dev/null
done

csv=bench/results/prep/prep.csv phases=bench/results/prep/prep-phases.csv
echo "tool,input,threads,run,wall_s,cpu_s,peak_rss_mb,raw_mb,mb_per_s" > "$csv"
echo "tool,input,threads,run,phase,wall_s,cpu_s" > "$phases"
timed() {  # timed TOOL INPUT THREADS RUN RAW_BYTES COMMAND...: one run, one CSV row; its stdout kept in $work/out
  # (or sent to $stdout_to when set)
  local tool=$1 input=$2 t=$3 run=$4 bytes=$5
  shift 5
  sync  # the previous run's dirty pages are not this run's to write
  /usr/bin/time -f "%e %U %S %M" -o "$work/time" "$@" > "${stdout_to:-$work/out}"
  read -r wall user sys rss < "$work/time"
  python3 - "$tool" "$input" "$t" "$run" "$wall" "$user" "$sys" "$rss" "$bytes" <<'EOF' | tee -a "$csv"
import csv, sys
tool, name, threads, run, wall, user, system, rss, size = sys.argv[1:]
w, b = float(wall), float(size)
csv.writer(sys.stdout, lineterminator="\n").writerow(
    [tool, name, threads, run, f"{w:.2f}", f"{float(user) + float(system):.2f}", int(rss) // 1024, f"{b / 1e6:.0f}",
     f"{b / 1e6 / w:.1f}"])
EOF
}
prep() {  # prep BINARY TOOL INPUT_NAME THREADS RUN RAW_BYTES ARGS...
  local bin=$1 tool=$2 name=$3 t=$4 run=$5 bytes=$6
  shift 6
  local timings=()
  [ "$bin" = "$new" ] && timings=(--timings)
  # The previous run's store is removed first, untimed, as zstd's output is: with --force prep would otherwise
  # unlink it inside the timing (GBs of page cache truncated, up to a sixth of a 512^3 prep's CPU).
  rm -rf "$work/out.vbs"
  timed "$tool" "$name" "$t" "$run" "$bytes" "$bin" prep "$@" --threads "$t" -o "$work/out.vbs" --force -q \
    "${timings[@]}"
  python3 - "$tool" "$name" "$t" "$run" "$work/out" >> "$phases" <<'EOF'
import csv, re, sys
tool, name, threads, run, out = sys.argv[1:]
w = csv.writer(sys.stdout, lineterminator="\n")
for line in open(out):
    m = re.match(r"prep:   (.+?)\s+([\d.]+) s wall\s+([\d.]+) s CPU", line)
    if m: w.writerow([tool, name, threads, run, m.group(1), m.group(2), m.group(3)])
EOF
}

# 1. The stores of both binaries, threads 1 and 2, with the default options: threads must never change a byte;
#    against the base, the files that differ are listed.
identical=""
if [ -n "$base" ]; then
  first=$(echo "$sizes" | cut -d' ' -f1)
  for input in "synthetic:blobs,n=256" "synthetic:sparse,n=256 --vdb-chunk 40" "$mri" \
               "$work/blobs-$first.raw --dims $first,$first,$first --type f32 --no-vdb --brick 16"; do
    digest() {  # digest NAME BINARY ARGS...
      local name=$1 bin=$2
      shift 2
      rm -rf "$work/id.vbs"
      # shellcheck disable=SC2086
      "$bin" prep $input "$@" -o "$work/id.vbs" -q > /dev/null
      bash bench/store_digest.sh "$work/id.vbs" > "$work/id-$name.sha"
    }
    digest base-1 "$base" --threads 1
    digest base-2 "$base" --threads 2
    digest new-1 "$new" --threads 1
    digest new-2 "$new" --threads 2
    differing() {  # differing A B: "yes" when two digests match, else "no: " and the files that differ
      local files
      files=$({ diff "$work/id-$1.sha" "$work/id-$2.sha" || true; } | awk '/^>/ {sub("^\\./", "", $3); print $3}' |
        paste -sd' ' | sed 's/ /, /g')
      if [ -z "$files" ]; then echo yes; else echo "no: $files"; fi
    }
    alike="base $(differing base-1 base-2), this build $(differing new-1 new-2)"
    same=$(differing base-1 new-1)
    identical+="| \`$input\` | $(wc -l < "$work/id-base-1.sha") | $alike | $same |"$'\n'
  done
  rm -rf "$work/id.vbs" "$work"/id-*.sha
fi

# 2. Throughput, tools alternating within each repeat.
for n in $sizes; do
  raw=$work/blobs-$n.raw bytes=$((n ** 3 * 4)) name="raw f32 $n³ (blobs)"
  reps=$repeats
  [ "$n" -ge 1024 ] && reps=$big
  for ((r = 1; r <= reps; ++r)); do
    for t in $threads; do
      # Every tool starts with the input in the page cache (read once more, untimed): none of them pays for reading
      # it from the disk after another's writes pushed it out.
      warm() { cat "$raw" > /dev/null; }
      warm; prep "$new" prep "$name" "$t" "$r" "$bytes" "$raw" --dims "$n,$n,$n" --type f32
      [ -n "$base" ] && { warm; prep "$base" prep-base "$name" "$t" "$r" "$bytes" "$raw" --dims "$n,$n,$n" --type f32; }
      warm; prep "$new" "prep --vdb-compression blosc" "$name" "$t" "$r" "$bytes" "$raw" --dims "$n,$n,$n" --type f32 \
        --vdb-compression blosc
      warm; prep "$new" "prep --no-vdb" "$name" "$t" "$r" "$bytes" "$raw" --dims "$n,$n,$n" --type f32 --no-vdb
      warm; stdout_to=/dev/null timed "zstd -1 to /dev/null" "$name" "$t" "$r" "$bytes" zstd -1 -T"$t" -c -f "$raw"
      warm; timed "zstd -1 to a file" "$name" "$t" "$r" "$bytes" zstd -1 -T"$t" -q -f "$raw" -o "$work/out.zst"
      rm -f "$work/out.zst"
    done
  done
done
for ((r = 1; r <= repeats; ++r)); do
  for t in $threads; do
    prep "$new" prep "MRI ch2better.nii.gz (u8, gzip)" "$t" "$r" $((301 * 370 * 316)) "$mri"
  done
done
rm -rf "$work/out.vbs" "$work/out"

python3 - "$csv" "$phases" "$identical" "$(nproc)" "$load_start" "$(uptime | sed 's/.*load average: //')" \
  "$repeats" "$big" "$command" "$(date -u +%Y-%m-%dT%H:%MZ)" "$(uname -r)" \
  > bench/results/prep/prep.md <<'EOF'
import collections, csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
phase_rows = list(csv.DictReader(open(sys.argv[2])))
identical, cores, load_start, load, repeats, big, command, date, kernel = sys.argv[3:12]
runs = collections.defaultdict(list)
for r in rows: runs[(r["input"], r["tool"], r["threads"])].append(r)
med = lambda key, field: statistics.median(float(r[field]) for r in runs[key])
inputs = list(dict.fromkeys(r["input"] for r in rows))
tools = list(dict.fromkeys(r["tool"] for r in rows))
threads = list(dict.fromkeys(r["threads"] for r in rows))
print("# Prep throughput\n")
print(f"`{command}`, finished {date}, on the {cores}-core development machine (Linux {kernel}, a virtual machine; "
      f"llvmpipe plays no part here).\n")
loaded = max(float(x) for x in (load_start + ", " + load).replace(",", " ").split()) > 2
if loaded:
    print(f"**A loaded run** (load average {load_start} at the start, {load} at the end, on {cores} cores): wall "
          f"times, and so MB/s, are inflated by other work, prep's more than zstd's; compare CPU seconds.\n")
print(f"MB/s = raw input bytes / wall seconds, median of {repeats} runs ({big} for 1024³); CPU = user + system "
      f"seconds, all threads; prep with `--threads T`, zstd with `-TT`. {cores} cores (load average {load_start} at "
      f"the start, {load} at the end). The raw files are the blobs field written once as raw f32, so no field is "
      f"evaluated; each run starts after `sync`, prep's with the previous store removed (untimed, as zstd's output "
      f"file is). The ratios are against `zstd -1` to /dev/null.\n")
print("| input | tool | threads | MB/s | MB/s ratio | wall s | CPU s | CPU ratio | peak RSS MiB |")
print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
for i in inputs:
    for th in threads:
        ref = (i, "zstd -1 to /dev/null", th)
        for t in tools:
            k = (i, t, th)
            if k not in runs: continue
            ratio = f"{med(k, 'mb_per_s') / med(ref, 'mb_per_s'):.2f}" if ref in runs else ""
            cpu = f"{med(k, 'cpu_s') / med(ref, 'cpu_s'):.2f}" if ref in runs else ""
            print(f"| {i} | {t} | {th} | {med(k, 'mb_per_s'):.1f} | {ratio} | {med(k, 'wall_s'):.2f} | "
                  f"{med(k, 'cpu_s'):.2f} | {cpu} | {med(k, 'peak_rss_mb'):.0f} |")
prs = collections.defaultdict(list)
for r in phase_rows: prs[(r["input"], r["tool"], r["threads"], r["phase"])].append(r)
if prs:
    print("\nWhere prep's time goes (`--timings`, medians; CPU is the whole process's while the phase ran):\n")
    print("| input | tool | threads | phase | wall s | CPU s |\n| --- | --- | ---: | --- | ---: | ---: |")
    for (i, t, th, p), rs in prs.items():
        print(f"| {i} | {t} | {th} | {p} | {statistics.median(float(r['wall_s']) for r in rs):.2f} | "
              f"{statistics.median(float(r['cpu_s']) for r in rs):.2f} |")
if identical:
    print("\nStores from the base binary and this build with the default options, threads 1 and 2 "
          "(`bench/store_digest.sh`: SHA-256 of every file, OpenVDB's random file UUID masked): whether 1 and 2 "
          "threads give the same files (they must), and whether this build writes what the base does (where not, "
          "the files that differ):\n")
    print("| input and options | files | threads 1 and 2 alike | same as the base |\n| --- | ---: | --- | --- |")
    print(identical.rstrip())
EOF
cat bench/results/prep/prep.md
