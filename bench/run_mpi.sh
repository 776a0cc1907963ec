#!/usr/bin/env bash
# The distributed mode measured (docs/distributed.md): the MPI compositor's ms and bytes per frame at 512², 1024² and
# 2048² for 1 to 4 ranks (oversubscribed on one machine: the cost of compositing, not a speed-up), beside the
# baseline compositor (binary swap, main before radix-k) run interleaved on the same partial frames; radix-k's
# factorisations for 2 to 8 ranks; the pixels and bytes of 8 and 64 ranks counted; a volume 4x one rank's host
# budget drawn by 4 ranks with each rank's peak host cache; and the cost model fitted to the compositing figures and
# projected (mpi_model.py). Writes bench/results/mpi/mpi.csv, mpi-factors.csv, mpi-counts.csv, mpi-budget.json and
# mpi.md.
#   bash bench/run_mpi.sh [--build build] [--baseline-build DIR | --baseline-exe PATH] [--smoke]
#     --baseline-build DIR: a configured build directory of the baseline tree (e.g. `git worktree add /tmp/base main`,
#       then cmake there); its bench_composite is built from this tree's bench/bench_composite.cpp (copied over the
#       baseline's, which it builds against either compositor) so that both draw the same partial frames.
#     --baseline-exe PATH: a bench_composite built that way already.
#     --smoke: small sizes, few repeats, labelled as such.
# The two bench_composite print a digest of their inputs; mpi_model.py refuses rows whose digests differ.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build smoke=0 baseline=""
while [ $# -gt 0 ]; do
  case $1 in
    --build) build=$2; shift 2 ;;
    --baseline-build)
      dir=$(cd "$2" && pwd)
      source_dir=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$dir/CMakeCache.txt")
      if [ -z "$source_dir" ]; then echo "run_mpi.sh: $2 is no configured CMake build directory" >&2; exit 2; fi
      if ! cmp -s bench/bench_composite.cpp "$source_dir/bench/bench_composite.cpp"; then
        echo "run_mpi.sh: copying bench/bench_composite.cpp into the baseline tree $source_dir" >&2
        cp bench/bench_composite.cpp "$source_dir/bench/bench_composite.cpp"
      fi
      nice ninja -C "$dir" bench_composite > /dev/null
      baseline=$dir/bench/bench_composite
      shift 2 ;;
    --baseline-exe) baseline=$2; shift 2 ;;
    --smoke) smoke=1; shift ;;
    *) echo "run_mpi.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
if [ -n "$baseline" ] && [ ! -x "$baseline" ]; then echo "run_mpi.sh: no baseline executable $baseline" >&2; exit 2; fi
# This tree's tools, built now: the test build leaves the benchmark tools out of its default target.
nice ninja -C "$build" bench_composite voxbrick > /dev/null
mpirun=(mpirun --oversubscribe --allow-run-as-root)
sizes=(512 1024 2048) factor_sizes=1024,2048 repeat=10 volume=256 budget=16 count_size=1024
if [ $smoke -eq 1 ]; then sizes=(256 512) factor_sizes=512 repeat=3 volume=128 budget=2 count_size=256; fi
out=bench/results/mpi
mkdir -p "$out"
export VOXBRICK_CONFIG_DIR=$PWD/config
load_start=$(cut -d' ' -f1-3 /proc/loadavg)
header="impl,ranks,size,encoding,factors,ms_median,ms_max,ms_composite_median,bytes_total,bytes_max_rank,active_share,union_share,inputs,footprint_share,handled_max_rank"

# Baseline and radix-k interleaved: for each rank count and size, one after the other (which goes first alternates).
echo "$header" > "$out/mpi.csv"
for n in 1 2 3 4; do
  for size in "${sizes[@]}"; do
    runs=("$build/bench/bench_composite")
    if [ -n "$baseline" ]; then
      if [ $((n % 2)) -eq 1 ]; then runs=("$baseline" "${runs[0]}"); else runs+=("$baseline"); fi
    fi
    for exe in "${runs[@]}"; do
      "${mpirun[@]}" -n $n "$exe" --sizes "$size" --repeat $repeat | tail -n +2 >> "$out/mpi.csv"
    done
  done
done

# Radix-k's factorisations (every ordered one) for 2 to 8 ranks: what radixFactors' table records.
echo "$header" > "$out/mpi-factors.csv"
for n in 2 3 4 5 6 7 8; do
  "${mpirun[@]}" -n $n "$build/bench/bench_composite" --sizes $factor_sizes --repeat $repeat --factors all \
    --variants footprint | tail -n +2 >> "$out/mpi-factors.csv"
done

# The pixels and bytes of 8 and 64 ranks, counted (their times on two cores mean nothing): what the projection
# scales to larger frames.
echo "$header" > "$out/mpi-counts.csv"
for n in 8 64; do
  "${mpirun[@]}" -n $n "$build/bench/bench_composite" --sizes $count_size --repeat 1 | tail -n +2 >> "$out/mpi-counts.csv"
done

# A volume of f32 voxels at least 4x one rank's host budget, drawn by 4 ranks, each within its budget.
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$build/voxbrick" prep "synthetic:blobs,n=$volume" --brick 32 --no-vdb -q -o "$work/big" > /dev/null
"${mpirun[@]}" -n 4 "$build/voxbrick" render "$work/big" --mpi --host-cache $budget --size 512x512 --tf mri -q \
  -o "$work/big.png" --stats "$out/mpi-budget.json" > /dev/null
radix_factors=$("$build/bench/bench_composite" --print-factors 1,2,3,4,5,6,7,8,64,512 | tr '\n' ' ') ||
  { echo "run_mpi: bench_composite --print-factors failed" >&2; exit 1; }
command="bash bench/run_mpi.sh${baseline:+ --baseline-build BUILD_OF_MAIN}$([ $smoke -eq 1 ] && echo ' --smoke' || true)"
/usr/bin/python3 bench/mpi_model.py --csv "$out/mpi.csv" --factors "$out/mpi-factors.csv" --counts "$out/mpi-counts.csv" \
  --radix-factors "$radix_factors" \
  --budget "$out/mpi-budget.json" --volume-bytes $((volume * volume * volume * 4)) --smoke $smoke \
  --cores "$(nproc)" --command "$command" --machine "${VOXBRICK_MACHINE:-2-core VM, llvmpipe, no GPU}" \
  --load "$load_start at the start, $(cut -d' ' -f1-3 /proc/loadavg) at the end" > "$out/mpi.md"
echo "run_mpi: wrote $out/mpi.csv, $out/mpi-factors.csv, $out/mpi-counts.csv, $out/mpi-budget.json and $out/mpi.md"
