#!/usr/bin/env bash
# The distributed mode measured (docs/distributed.md): the MPI compositor's ms and bytes per frame at 512², 1024² and
# 2048² for 1 to 4 ranks (oversubscribed on one machine: the cost of compositing, not a speed-up), a volume 4x one
# rank's host budget drawn by 4 ranks with each rank's peak host cache, and the cost model fitted to the compositing
# figures and projected (mpi_model.py). Writes bench/results/mpi/mpi.csv, mpi-budget.json and mpi.md.
#   bash bench/run_mpi.sh [--build build] [--smoke]     (--smoke: small sizes, few repeats, labelled as such)
set -euo pipefail
cd "$(dirname "$0")/.."
build=build smoke=0
while [ $# -gt 0 ]; do
  case $1 in
    --build) build=$2; shift 2 ;;
    --smoke) smoke=1; shift ;;
    *) echo "run_mpi.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
mpirun=(mpirun --oversubscribe --allow-run-as-root)
sizes=512,1024,2048 repeat=10 volume=256 budget=16
if [ $smoke -eq 1 ]; then sizes=256,512 repeat=3 volume=128 budget=2; fi
out=bench/results/mpi
mkdir -p "$out"
export VOXBRICK_CONFIG_DIR=$PWD/config

echo "ranks,size,encoding,ms_median,ms_max_rank,bytes_total,bytes_max_rank" > "$out/mpi.csv"
for n in 1 2 3 4; do
  "${mpirun[@]}" -n $n "$build/bench/bench_composite" --sizes $sizes --repeat $repeat | tail -n +2 >> "$out/mpi.csv"
done

# A volume of f32 voxels at least 4x one rank's host budget, drawn by 4 ranks, each within its budget.
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$build/voxbrick" prep "synthetic:blobs,n=$volume" --brick 32 --no-vdb -q -o "$work/big" > /dev/null
"${mpirun[@]}" -n 4 "$build/voxbrick" render "$work/big" --mpi --host-cache $budget --size 512x512 --tf mri -q \
  -o "$work/big.png" --stats "$out/mpi-budget.json" > /dev/null
/usr/bin/python3 bench/mpi_model.py --csv "$out/mpi.csv" --budget "$out/mpi-budget.json" \
  --volume-bytes $((volume * volume * volume * 4)) --smoke $smoke --cores "$(nproc)" > "$out/mpi.md"
echo "run_mpi: wrote $out/mpi.csv, $out/mpi-budget.json and $out/mpi.md"
