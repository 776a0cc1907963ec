#!/usr/bin/env bash
# The service under hostile clients, against the real server on loopback: 64 well-behaved clients for --duration
# seconds alone, then again beside 64 never-speaking sockets, 16 trickling ones, 8 never-reading sessions, clients
# that abandon heavy renders and clients rendering a corrupt dataset (each a `voxbrick load --faults` process).
# Reports the good clients' errors and latencies in both runs, the faults' outcomes, and the server's RSS before,
# at its peak and after. Results: bench/results/server/hostile-{alone,faults}.json and bench/results/server/hostile.md.
#
#   bash bench/run_hostile.sh [--duration 60]
set -euo pipefail
cd "$(dirname "$0")/.."
duration=60
while [ $# -gt 0 ]; do
  case "$1" in
    --duration) duration=$2; shift 2 ;;
    *) echo "run_hostile.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
out=bench/results/server
work=bench/work/hostile
mkdir -p "$out" "$work"
export VOXBRICK_CONFIG_DIR=$PWD/config
bin=build/voxbrick
[ -f "$work/sparse/store.json" ] || "$bin" prep synthetic:sparse,n=256 --no-vdb -q -o "$work/sparse"
if [ ! -f "$work/bad/store.json" ]; then  # a copy of the sparse field with every brick damaged
  cp -r "$work/sparse" "$work/bad"
  python3 - "$work/bad/bricks.bin" <<'PY'
import os, sys
with open(sys.argv[1], "r+b") as f:
    size = os.path.getsize(sys.argv[1])
    for at in range(512, size - 8, 2048):
        f.seek(at); b = f.read(8); f.seek(at); f.write(bytes(255 - x for x in b))
PY
fi

server=
start() {
  rm -f "$work/port"
  # A Hello deadline of 2 s and a read timeout of 5 s (the defaults are 5 and 30): the faults that wait them out
  # come round more often within the run.
  "$bin" serve --datasets "$work" --port 0 --port-file "$work/port" --render-threads 2 --max-sessions 256 --hello-timeout 2 \
    --read-timeout 5 --log-level warn > "$work/server.log" 2>&1 &
  server=$!
  for _ in $(seq 600); do [ -s "$work/port" ] && break; sleep 0.1; done
  port=$(cat "$work/port")
}
stop() { kill -TERM "$server"; wait "$server" || true; server=; }
trap '[ -n "$server" ] && kill "$server" 2>/dev/null || true' EXIT
rss_mb() { awk '/^VmRSS/ { print int($2 / 1024) }' "/proc/$server/status"; }
load() { "$bin" load "127.0.0.1:$port" --dataset sparse --tf sparse "$@"; }

start
load --clients 64 --duration "$duration" --size 128x128 --json "$out/hostile-alone.json" > "$work/alone.out"
rss_alone=$(rss_mb)
stop

start
# A warm-up of the good clients alone first: "before" is the server's working state (contexts, caches), not its
# empty start.
load --clients 64 --duration 10 --size 128x128 > "$work/warm-up.out"
rss_start=$(rss_mb)
pids=()
for spec in "64 silent" "16 trickle" "8 unread" "4 abandon" "2 corrupt --corrupt-dataset bad"; do
  set -- $spec
  n=$1 kind=$2
  shift 2
  load --clients 0 --fault-clients "$n" --faults "$kind" "$@" --duration "$duration" --json "$work/fault-$kind.json" \
    > "$work/fault-$kind.out" 2>&1 &
  pids+=($!)
done
load --clients 64 --duration "$duration" --size 128x128 --json "$out/hostile-faults.json" > "$work/faults.out"
for pid in "${pids[@]}"; do wait "$pid" || true; done
sleep 5  # the last faults' sessions close; freed memory goes back
rss_after=$(rss_mb)
stop

python3 - "$out" "$work" "$duration" "$rss_start" "$rss_after" "$rss_alone" > "$out/hostile.md" <<'PY'
import json, os, sys
out, work, duration = sys.argv[1], sys.argv[2], sys.argv[3]
rss_start, rss_after, rss_alone = int(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6])
alone = json.load(open(os.path.join(out, "hostile-alone.json")))
faults = json.load(open(os.path.join(out, "hostile-faults.json")))
print("# The service under hostile clients\n")
print(f"`bash bench/run_hostile.sh --duration {duration}`: the real server on loopback (two render threads, 256 sessions, Hello "
      "deadline 2 s, read timeout 5 s, other limits at their defaults), the sparse field (256³) at 128², `sparse`; "
      "64 well-behaved clients asking one frame at a time, measured by the clients. Machine: 2 shared cores, "
      "llvmpipe.\n")
print("| run | frames | errors | p50 ms | p99 ms | max ms |")
print("|---|---:|---:|---:|---:|---:|")
for name, j in (("64 good clients alone", alone), ("the same beside the faults", faults)):
    lat = j["latency_ms"]
    print(f"| {name} | {j['frames']} | {j['errors']} | {lat['p50']:.0f} | {lat['p99']:.0f} | {lat['max']:.0f} |")
ratio = faults["latency_ms"]["p99"] / alone["latency_ms"]["p99"] if alone["latency_ms"]["p99"] else float("nan")
print(f"\np99 beside the faults / alone: **{ratio:.2f}×** (goal ≤ 2×); good clients' errors beside the faults: "
      f"**{faults['errors']}** (goal 0).\n")
print("| fault (clients) | done | not answered as documented |")
print("|---|---:|---:|")
for kind, n in (("silent", 64), ("trickle", 16), ("unread", 8), ("abandon", 4), ("corrupt", 2)):
    try:
        f = json.load(open(os.path.join(work, f"fault-{kind}.json")))["faults"].get(kind, {"done": 0, "unexpected": 0})
    except Exception as e:  # a fault process that failed: say so
        f = {"done": f"failed ({e})", "unexpected": "—"}
    print(f"| {kind} ({n}) | {f['done']} | {f['unexpected']} |")
s = faults["server"]
print(f"\nServer RSS: {rss_alone} MB at the end of the run without faults; in the run with them, {rss_start} MB "
      f"after 10 s of good clients alone, before the faults, peak {s['memory']['peak_rss_bytes'] / 1e6:.0f} MB, "
      f"{rss_after} MB five seconds after they ended ({100 * (rss_after - rss_start) / rss_start:+.0f} %); renders "
      f"cancelled: {s['renders'].get('cancelled', 0)}; sessions evicted before Hello: "
      f"{s['sessions'].get('evicted', 0)}.")
PY
cat "$out/hostile.md"
