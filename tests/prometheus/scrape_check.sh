#!/usr/bin/env bash
# A real Prometheus (Debian's package) scrapes a real `voxbrick serve --http` that has an access token, every second,
# with the token in its scrape configuration (`authorization`, sent as Authorization: Bearer): the target is up, the
# frames `voxbrick request` renders are stored (voxbrick_frames_total above 0, then rising with more frames), a
# latency quantile reads from the histogram, and a job with a wrong token is down. Fails (never skips) without
# prometheus. Every process it starts is stopped on every path; it gives up after 50 s.
# Usage: scrape_check.sh VOXBRICK WORK
# shellcheck disable=SC2317  # the functions below run from traps and waitFor
set -uo pipefail
exe=$(realpath "$1") work=$2
prometheus=${VOXBRICK_PROMETHEUS:-prometheus}
token="scrape-Token_1"
deadline=$((SECONDS + 50))
failed=0
check() {  # check WHAT STATUS
  if [ "$2" -eq 0 ]; then echo "ok: $1"; else echo "FAIL: $1"; failed=1; fi
}
command -v "$prometheus" > /dev/null || { echo "FAIL: no '$prometheus' (scripts/setup.sh installs Debian's)"; exit 1; }
rm -rf "$work" && mkdir -p "$work/datasets"

pids=()
stop() {  # SIGTERM to what was started, SIGKILL to what is left after 5 s
  for p in "${pids[@]}"; do kill -TERM "$p" 2> /dev/null; done
  for _ in $(seq 1 50); do
    alive=0
    for p in "${pids[@]}"; do kill -0 "$p" 2> /dev/null && alive=1; done
    [ "$alive" -eq 0 ] && break
    sleep 0.1
  done
  for p in "${pids[@]}"; do kill -KILL "$p" 2> /dev/null; done
  wait 2> /dev/null
}
trap stop EXIT
trap 'exit 1' INT TERM
logs() {
  echo "--- serve.log"; tail -n 30 "$work/serve.log" 2> /dev/null
  echo "--- prometheus.log"; tail -n 30 "$work/prometheus.log" 2> /dev/null
}
waitFor() {  # waitFor WHAT COMMAND...: runs COMMAND every 0.25 s until it succeeds or the deadline passes
  local what=$1
  shift
  until "$@"; do
    if [ $SECONDS -ge $deadline ]; then echo "FAIL: $what within the deadline"; logs; exit 1; fi
    sleep 0.25
  done
}

"$exe" prep synthetic:sparse,n=32 --brick 16 --no-vdb -q -o "$work/datasets/sparse" > /dev/null || exit 1
"$exe" serve --no-config --datasets "$work/datasets" --render-threads 1 --port 0 --port-file "$work/port" \
  --http 0 --http-port-file "$work/http-port" --http-token "$token" > "$work/serve.log" 2>&1 &
pids+=($!)
waitFor "the server listens" test -s "$work/http-port" -a -s "$work/port"
port=$(cat "$work/port") httpPort=$(cat "$work/http-port")

# A port of Prometheus' own: the kernel's pick, closed again.
promPort=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
cat > "$work/prometheus.yml" << EOF
global:
  scrape_interval: 1s
  scrape_timeout: 1s
scrape_configs:
  - job_name: voxbrick
    authorization:
      credentials: $token
    static_configs:
      - targets: ["127.0.0.1:$httpPort"]
  - job_name: wrong-token
    authorization:
      credentials: not-$token
    static_configs:
      - targets: ["127.0.0.1:$httpPort"]
EOF
"$prometheus" --config.file="$work/prometheus.yml" --storage.tsdb.path="$work/tsdb" \
  --web.listen-address="127.0.0.1:$promPort" --log.level=warn > "$work/prometheus.log" 2>&1 &
pids+=($!)

# One instant query through Prometheus' HTTP API: prints the value of its one result ("none" if it has none).
query() {
  python3 - "http://127.0.0.1:$promPort/api/v1/query" "$1" << 'PY'
import json, sys, urllib.parse, urllib.request
url = sys.argv[1] + "?" + urllib.parse.urlencode({"query": sys.argv[2]})
try:
    with urllib.request.urlopen(url, timeout=5) as r:
        body = json.load(r)
except Exception as e:
    print("none"); sys.exit(0)
result = body.get("data", {}).get("result", [])
print(result[0]["value"][1] if body.get("status") == "success" and len(result) == 1 else "none")
PY
}
ready() {
  python3 -c "import urllib.request as u; u.urlopen('http://127.0.0.1:$promPort/-/ready', timeout=2)" 2> /dev/null
}
above() {  # above QUERY NUMBER: the query's value is a number above NUMBER
  local v
  v=$(query "$1")
  [ "$v" != "none" ] && awk -v v="$v" -v n="$2" 'BEGIN { exit !(v + 0 > n + 0) }'
}
equals() { [ "$(query "$1")" = "$2" ]; }
render() {  # render N: N frames through `voxbrick request`
  for i in $(seq 1 "$1"); do
    "$exe" request "127.0.0.1:$port" --dataset sparse -o "$work/frame-$i.png" --size 64x48 --tf grayscale \
      --orbit "$((i * 30)),20" --timeout 20 > /dev/null 2>&1 || { echo "FAIL: voxbrick request"; logs; exit 1; }
  done
}

waitFor "Prometheus is ready" ready
render 2
frames='sum(voxbrick_frames_total{job="voxbrick"})'
waitFor "Prometheus stores the first frames" above "$frames" 0
first=$(query "$frames")
check "voxbrick_frames_total stored: $first" 0
equals 'up{job="voxbrick"}' 1; check "the target with the token is up" $?
render 3
atLeast=$(awk -v f="$first" 'BEGIN { print f + 2 }')
waitFor "voxbrick_frames_total rises from $first by 3" above "$frames" "$atLeast"
check "voxbrick_frames_total rose to $(query "$frames")" 0
buckets='voxbrick_frame_latency_seconds_bucket{job="voxbrick",class="still"}'
p50=$(query "histogram_quantile(0.5, sum by (le) ($buckets))")
awk -v v="$p50" 'BEGIN { exit !(v + 0 > 0 && v + 0 <= 10) }'
check "the median frame latency from the histogram: $p50 s" $?
equals 'up{job="voxbrick"}' 1; check "still up" $?
waitFor "the job with a wrong token scraped" equals 'count(up{job="wrong-token"})' 1
equals 'up{job="wrong-token"}' 0; check "the job with a wrong token is down" $?
[ $failed -eq 0 ] || logs
exit $failed
