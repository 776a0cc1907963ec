#!/usr/bin/env bash
# Interactive frames under `voxbrick serve --mpi`, two builds side by side in one run: CLIENTS `voxbrick load --drag 30
# --interactive BUDGET` clients dragging the MRI at SIZE² (moving frames as CODEC, exact ones as PNG) against
# `mpirun -n RANKS` servers of OLD and NEW (rounds alternating which goes first), and NEW as one process beside them.
# NEW's `voxbrick load` is the client of all (it reports the drawings' scale and their predicted and actual ms). What
# it shows: whether the interactive ladder under sort-last draws what its budget allows (a rate measured from rank
# 0's part alone predicts a whole frame RANKS times too dear). Writes OUT.{csv,md}, OUT
# bench/results/mpi/interactive-ab by default.
#
#   bash bench/run_mpi_interactive.sh OLD_VOXBRICK [NEW_VOXBRICK] [--ranks 2] [--clients 1] [--size 512]
#                                     [--budget 50] [--codec jpeg] [--duration 10] [--rounds 3] [--out OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 1 ] || { sed -n 2,11p "$0" >&2; exit 2; }
old=$(realpath "$1")
shift
new=$(realpath build/voxbrick)
if [ $# -gt 0 ] && [ "${1#--}" = "$1" ]; then new=$(realpath "$1"); shift; fi
ranks=2 clients=1 size=512 budget=50 codec=jpeg duration=10 rounds=3 dest=bench/results/mpi/interactive-ab
while [ $# -gt 0 ]; do
  case "$1" in
    --ranks) ranks=$2; shift 2 ;;
    --clients) clients=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --budget) budget=$2; shift 2 ;;
    --codec) codec=$2; shift 2 ;;
    --duration) duration=$2; shift 2 ;;
    --rounds) rounds=$2; shift 2 ;;
    --out) dest=$2; shift 2 ;;
    *) echo "run_mpi_interactive.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
[ -x "$old" ] && [ -x "$new" ] || { echo "run_mpi_interactive.sh: no voxbrick at $old or $new" >&2; exit 2; }
source bench/browser_bench.sh
work=bench/work/mpi-interactive
mri_datasets "$work" "$new"
mkdir -p "$(dirname "$dest")" "$work/runs"
export OMPI_MCA_pml=ob1  # as the tests: the one-machine layer, without probing the network ones
stop_server_on_exit

# `serve LOG EXE [mpi]`: a server of EXE on a free port, across RANKS ranks with `mpi`; sets `pid` and `port`.
serve() {
  local log=$1 exe=$2
  if [ "${3:-}" = mpi ]; then
    mpirun --oversubscribe --allow-run-as-root -n "$ranks" "$exe" serve --mpi --port 0 --datasets "$work/datasets" \
      > "$log" 2>&1 &
  else
    "$exe" serve --port 0 --datasets "$work/datasets" --render-threads 1 > "$log" 2>&1 &
  fi
  pid=$!
  listening_port run_mpi_interactive.sh "$log" 30
}
drag() {  # drag JSON: the clients against `port`, then the server stopped
  "$new" load "127.0.0.1:$port" --dataset mri --tf mri --clients "$clients" --size "${size}x${size}" --drag 30 \
    --interactive "$budget" --encoding png --provisional-encoding "$codec" --duration "$duration" --json "$1" > /dev/null
  stop_server
}

for round in $(seq "$rounds"); do
  order="old new one"
  [ $((round % 2)) -eq 0 ] && order="new old one"
  for build in $order; do
    case $build in
      old) serve "$work/runs/serve-old-$round.log" "$old" mpi ;;
      new) serve "$work/runs/serve-new-$round.log" "$new" mpi ;;
      one) serve "$work/runs/serve-one-$round.log" "$new" ;;
    esac
    drag "$work/runs/$build-$round.json"
  done
done

python3 - "$work/runs" "$dest" "$ranks" "$clients" "$size" "$budget" "$codec" "$duration" "$rounds" "$old" "$new" <<'PY'
import csv, datetime, json, os, statistics, sys
runs, dest, ranks, clients, size, budget, codec, duration, rounds, old, new = sys.argv[1:12]
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
def commit(binary):
    path = os.path.join(os.path.dirname(binary), 'COMMIT')
    return open(path).read().strip()[:7] if os.path.exists(path) else 'this build'
def get(d, *keys):
    for k in keys:
        d = d.get(k) if isinstance(d, dict) else None
    return d
rows = []
for r in range(1, int(rounds) + 1):
    for build in ('old', 'new', 'one'):
        j = json.load(open(f'{runs}/{build}-{r}.json'))
        rows.append({'build': build, 'round': r, 'frames_per_s': j['frames_per_s'],
                     'latency_p50_ms': j['latency_ms']['p50'], 'latency_p99_ms': j['latency_ms']['p99'],
                     'budget_ms_p50': get(j, 'time_budget_ms', 'p50'),
                     'drawn_scale_p50': get(j, 'drawn_scale', 'p50'),
                     'predicted_ms_p50': get(j, 'interactive_ms', 'predicted_p50'),
                     'actual_ms_p50': get(j, 'interactive_ms', 'actual_p50'),
                     'errors': j['errors']})
with open(dest + '.csv', 'w', newline='') as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
    w.writeheader()
    w.writerows(rows)
def med(build, key):
    values = [r[key] for r in rows if r['build'] == build and r[key] is not None]
    return f'{statistics.median(values):.3g}' if values else ''
label = {'old': f'OLD ({commit(old)}), {ranks} ranks', 'new': f'NEW ({commit(new)}), {ranks} ranks',
         'one': f'NEW ({commit(new)}), one process, 1 render thread'}
md = ['# Interactive frames across MPI ranks', '',
      f'- Command: `bash bench/run_mpi_interactive.sh OLD_VOXBRICK --ranks {ranks} --clients {clients} --size {size} '
      f'--budget {budget} --codec {codec} --duration {duration} --rounds {rounds} --out {dest}`; OLD is '
      f'{commit(old)}, NEW {commit(new)}.',
      f'- Date: {datetime.date.today()}; machine: {cpu}, 2 cores, a shared virtual machine, llvmpipe drawing; every '
      f'rank and the load client on the same two cores: compare the rows only with each other.',
      f'- {clients} `voxbrick load --drag 30 --interactive {budget}` client(s) dragging the MRI at {size}², moving '
      f'frames as {codec}, for {duration} s against a fresh server each; medians of {rounds} rounds. Predicted and '
      'actual ms: the frames\' `interactive.predicted_ms` and `actual_ms` (under MPI, NEW\'s actual is the whole '
      'frame\'s, drawing and compositing; OLD\'s was rank 0\'s own drawing).', '',
      '| server | frames/s | latency p50 ms | p99 ms | budget ms | drawn at, p50 | predicted ms p50 | actual ms p50 | '
      'errors |', '| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |']
for build in ('old', 'new', 'one'):
    md.append(f"| {label[build]} | {med(build, 'frames_per_s')} | {med(build, 'latency_p50_ms')} | "
              f"{med(build, 'latency_p99_ms')} | {med(build, 'budget_ms_p50')} | {med(build, 'drawn_scale_p50')} | "
              f"{med(build, 'predicted_ms_p50')} | {med(build, 'actual_ms_p50')} | "
              f"{sum(r['errors'] for r in rows if r['build'] == build)} |")
md.append('')
open(dest + '.md', 'w').write('\n'.join(md))
PY
cat "$dest.md"
