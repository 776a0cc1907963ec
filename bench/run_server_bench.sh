#!/usr/bin/env bash
# Render service benchmarks, all against the real server on loopback:
#   1. overhead: one client asking for frames one at a time; the client's latency against the renderer's own frame
#      time (from the frame statistics) of the same frames;
#   2. a long load run: 64 clients for 60 s, with faulty and idle clients mixed in;
#   3. a camera drag: clients sending 10 cameras a second without waiting, with latest-wins coalescing and without.
# Results: bench/results/server/server-*.json and bench/results/server/server.md.
set -euo pipefail
cd "$(dirname "$0")/.."
out=bench/results/server
work=bench/work/served
mkdir -p "$out" "$work"
export VOXBRICK_CONFIG_DIR=$PWD/config
[ -f "$work/sparse/store.json" ] || ./build/voxbrick prep synthetic:sparse,n=256 --no-vdb -q -o "$work/sparse"

server=
start() {
  rm -f "$work/port"
  ./build/voxbrick serve --datasets "$work" --port 0 --port-file "$work/port" --render-threads 2 --max-sessions 256 "$@" \
    > "$work/server.log" 2>&1 &
  server=$!
  for _ in $(seq 600); do [ -s "$work/port" ] && break; sleep 0.1; done
  port=$(cat "$work/port")
}
stop() { kill -TERM "$server"; wait "$server"; }
trap '[ -n "$server" ] && kill "$server" 2>/dev/null || true' EXIT
load() { ./build/voxbrick load "127.0.0.1:$port" --dataset sparse --tf sparse "$@"; }

start
load --clients 1 --duration 30 --size 512x512 --json "$out/server-overhead.json"
load --clients 64 --duration 60 --size 128x128 --fault-clients 8 --idle-sessions 32 --json "$out/server-load.json"
load --clients 4 --duration 6 --size 256x256 --drag 10 --json "$out/server-drag-coalesced.json"
stop
start --no-coalesce
load --clients 4 --duration 6 --size 256x256 --drag 10 --json "$out/server-drag-queued.json"
stop

python3 - "$out" <<'PY'
import json, sys, os
out = sys.argv[1]
r = {k: json.load(open(os.path.join(out, f"server-{k}.json"))) for k in ["overhead", "load", "drag-coalesced", "drag-queued"]}
o, l, c, q = r["overhead"], r["load"], r["drag-coalesced"], r["drag-queued"]
lines = ["Render service on loopback (`bash bench/run_server_bench.sh`), two render threads, the sparse field (256^3),",
         "transfer function `sparse`. Latencies are measured by the clients, from sending a request to its frame.", "",
         "| run | frames | frames/s | p50 ms | p95 ms | p99 ms | max ms | errors | server peak RSS MB |",
         "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
def row(name, j):
    lat = j["latency_ms"]
    lines.append(f"| {name} | {j['frames']} | {j['frames_per_s']:.2f} | {lat['p50']:.0f} | {lat['p95']:.0f} | {lat['p99']:.0f} | "
                 f"{lat['max']:.0f} | {j['errors']} | {j['server']['memory']['peak_rss_bytes'] / 1e6:.0f} |")
row("1 client, 512x512, one at a time", o)
row("64 clients, 128x128, 60 s (+8 faulty, 32 idle)", l)
row("4 clients dragging at 10 Hz, latest wins", c)
row("4 clients dragging at 10 Hz, every request rendered", q)
overhead = o["latency_ms"]["p50"] / o["render_ms_p50"] - 1 if o["render_ms_p50"] else float("nan")
lines += ["", f"- Service overhead: median client latency {o['latency_ms']['p50']:.1f} ms against the renderer's median frame "
          f"time {o['render_ms_p50']:.1f} ms for the same frames: **{100 * overhead:.1f} %** (goal <= 10 %).",
          f"- Faults during the long run: " + ", ".join(f"{k} {v['done']} ({v['unexpected']} unexpected)" for k, v in l["faults"].items()) + ".",
          f"- Camera drag: latest wins answered {c['superseded']} requests `Superseded` and showed cameras "
          f"{c['latency_ms']['p50']:.0f} ms old (median); rendering every request showed them "
          f"{q['latency_ms']['p50']:.0f} ms old, {q['latency_ms']['p50'] / max(c['latency_ms']['p50'], 1e-9):.0f}x older"
          f" ({q['errors']} requests refused beyond 64 queued per session)."]
open(os.path.join(out, "server.md"), "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
PY
