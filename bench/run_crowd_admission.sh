#!/usr/bin/env bash
# Admission under a crowd that comes at once, two builds side by side in one run: for each round, a fresh server of
# each build in turn (2 render threads, the MRI) and CLIENTS `voxbrick load` clients dragging at 30 Hz that start
# together, in two scenarios:
#   cold  the crowd meets a server that has drawn nothing (its capacity not measured yet);
#   warm  4 clients drag for 3 s first (the capacity is measured), then the crowd comes.
# What it shows is whether the sessions the server lets drag each get the min_interactive_fps (5) the capacity is
# sized for, and how many it lets in: per client, its frames a second from its first frame (`voxbrick load`'s
# frames_per_s_since_first), the slowest and the median of those let in, Jain's index over them, latency, Busy
# replies, the measured capacity at the end and the render threads' busy share. The load is this tree's
# `voxbrick load` for both builds. Writes bench/results/server/crowd-admission.{csv,md}.
#
#   bash bench/run_crowd_admission.sh OLD_VOXBRICK NEW_VOXBRICK [--rounds 2] [--clients 80] [--duration 10] [--size 128]
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { sed -n 2,13p "$0"; exit 2; }
old=$1 new=$2
shift 2
rounds=2 clients=80 duration=10 size=128
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds=$2; shift 2 ;;
    --clients) clients=$2; shift 2 ;;
    --duration) duration=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    *) echo "run_crowd_admission.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
out=bench/results/server
work=bench/work/crowd-admission
mkdir -p "$out" "$work/data"
export VOXBRICK_CONFIG_DIR=$PWD/config
[ -f "$work/data/mri/store.json" ] || "$new" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$work/data/mri" -q

server=""
trap '[ -n "$server" ] && kill "$server" 2> /dev/null || true' EXIT
load() {  # PORT CLIENTS SECONDS JSON
  "$new" load "127.0.0.1:$1" --dataset mri --tf mri --step 0.75 --clients "$2" --drag 30 --interactive 50 \
    --provisional-encoding jpeg --duration "$3" --size "${size}x${size}" --json "$4" > /dev/null
}
csv=$out/crowd-admission.csv
{
  tree="$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- . ':!bench/results' || echo ' with uncommitted changes')"
  echo "# $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p' | head -1); source tree $tree; old $old, new $new"
  echo "# bash bench/run_crowd_admission.sh OLD NEW --rounds $rounds --clients $clients --duration $duration --size $size"
  echo "round,build,scenario,capacity,admitted,admitted_in_first_s,slowest_fps,median_fps,jain,frames_per_s,latency_p50_ms,latency_p99_ms,busy,errors,render_busy_share"
} > "$csv"
for r in $(seq 1 "$rounds"); do
  order="old new"; [ $((r % 2)) -eq 0 ] && order="new old"
  for scenario in cold warm; do
    for build in $order; do
      exe=$old; [ "$build" = new ] && exe=$new
      rm -f "$work/port"
      "$exe" serve --no-config --datasets "$work/data" --port 0 --port-file "$work/port" --render-threads 2 \
        --max-sessions 256 > "$work/$build.log" 2>&1 &
      server=$!
      for _ in $(seq 600); do [ -s "$work/port" ] && break; sleep 0.1; done
      port=$(cat "$work/port")
      [ "$scenario" = warm ] && load "$port" 4 3 "$work/warmup.json"
      load "$port" "$clients" "$duration" "$work/load.json"
      kill "$server"
      wait "$server" 2> /dev/null || true  # its status is that of the signal
      server=""
      python3 - "$work/load.json" "$r" "$build" "$scenario" >> "$csv" << 'EOF'
import json, statistics, sys
j = json.load(open(sys.argv[1]))
taken = [c for c in j['per_client'] if c['frames'] > 0]
rates = sorted(c['frames_per_s_since_first'] for c in taken if c['frames_per_s_since_first'] is not None)
jain = sum(rates) ** 2 / (len(rates) * sum(x * x for x in rates)) if rates else float('nan')
s, b = j['server'], j['server_before']
busy_share = (sum(s['render_busy_s']) - sum(b['render_busy_s'])) / (len(s['render_busy_s']) * (s['uptime_s'] - b['uptime_s']))
l = j['latency_ms']
print(','.join(str(x) for x in (sys.argv[2], sys.argv[3], sys.argv[4], s['sessions']['interactive_capacity'], len(taken),
      sum(1 for c in taken if c['first_frame_s'] < 1), f"{rates[0]:.2f}" if rates else '',
      f"{statistics.median(rates):.2f}" if rates else '', f"{jain:.3f}", f"{j['frames_per_s']:.1f}",
      f"{l['p50']:.1f}", f"{l['p99']:.1f}", j['busy'], j['errors'], f"{busy_share:.3f}")))
EOF
      echo "round $r $scenario $build: $(tail -1 "$csv")"
    done
  done
done
python3 - "$csv" > "$out/crowd-admission.md" << 'EOF'
import collections, csv, statistics, sys
lines = open(sys.argv[1]).read().splitlines()
head = [l[2:] for l in lines if l.startswith('# ')]
rows = list(csv.DictReader(l for l in lines if not l.startswith('#')))
print('# Admission under a crowd that comes at once\n')
print(f'- Run: {head[0]}')
print(f'- Command: `{head[1]}`')
print('- Each row: the median over rounds (each round\'s value in brackets). `admitted`: clients that got a frame; '
      '`slowest`/`median fps`: their frames a second from their first frame; the targets are ≥ 5 for every one '
      'admitted (min_interactive_fps) and Jain ≥ 0.9 over them.\n')
cols = ['capacity', 'admitted', 'admitted_in_first_s', 'slowest_fps', 'median_fps', 'jain', 'frames_per_s',
        'latency_p50_ms', 'latency_p99_ms', 'busy', 'errors', 'render_busy_share']
print('| scenario | build | ' + ' | '.join(cols) + ' |')
print('|---|---|' + '---:|' * len(cols))
groups = collections.defaultdict(list)
for r in rows: groups[(r['scenario'], r['build'])].append(r)
for key in sorted(groups, key=lambda k: (k[0], k[1] != 'old')):
    cells = []
    for c in cols:
        v = [float(r[c]) for r in groups[key] if r[c] not in ('', 'nan')]
        cells.append(f"{statistics.median(v):g} ({', '.join(f'{x:g}' for x in v)})" if v else '')
    print(f'| {key[0]} | {key[1]} | ' + ' | '.join(cells) + ' |')
EOF
cat "$out/crowd-admission.md"
