#!/usr/bin/env bash
# `mpirun -n 3 voxbrick serve --mpi` with `voxbrick request` as the client, each rank with a datasets directory of its
# own (as on separate machines): a served frame equals the one-process frame within 1/255, a grid's and a tetrahedral
# mesh's (drawn in parts, each clipped to its box); a dataset missing on one
# rank is refused naming the rank and the server keeps serving; a rank stopped (SIGSTOP) or killed (SIGKILL) makes
# the next Render an error naming it within the deadline (5 s here), and the server then serves on with the other
# ranks (frames equal to the one-process frame, the stats naming the lost rank); a stopped rank that goes on again
# (SIGCONT) is taken back; SIGTERM to rank 0 ends every rank with status 0, and SIGTERM to mpirun ends every rank.
# Usage: serve_check.sh VOXBRICK MPIRUN WORK
set -uo pipefail
exe=$(realpath "$1") mpirun=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
"$exe" prep synthetic:blobs,n=64 --brick 16 --no-vdb -q -o "$work/blobs" > /dev/null || exit 1
"$exe" prep synthetic-mesh:ball,n=12 --tets-per-chunk 512 -q -o "$work/ball" > /dev/null || exit 1
for r in 0 1 2; do mkdir -p "$work/r$r/ds" && cp -r "$work/blobs" "$work/r$r/ds/blobs" && cp -r "$work/ball" "$work/r$r/ds/ball"; done
cp -r "$work/blobs" "$work/r0/ds/gone" && cp -r "$work/blobs" "$work/r1/ds/gone"  # not on rank 2
cat > "$work/rank.sh" << 'WRAP'
#!/bin/sh
# Each rank in its own directory (its own datasets), its process id beside them.
cd "$(dirname "$0")/r$OMPI_COMM_WORLD_RANK" && echo $$ > pid && exec "$@"
WRAP
chmod +x "$work/rank.sh"
scene="--tf mri --orbit 35,25,2.2 --size 72x64 --step 0.5"
failed=0
check() {  # check WHAT CONDITION-STATUS
  if [ "$2" -eq 0 ]; then echo "ok: $1"; else echo "FAIL: $1"; failed=1; fi
}
start() {  # start [SERVE-OPTION ...]
  rm -f "$work/port" "$work"/r*/pid
  "$mpirun" --oversubscribe --allow-run-as-root --enable-recovery -n 3 "$work/rank.sh" "$exe" serve --mpi --no-config \
    --datasets ds --port 0 --port-file "$work/port" --mpi-timeout 5 "$@" > "$work/serve.log" 2>&1 &
  mpirunPid=$!
  for _ in $(seq 1 100); do [ -f "$work/port" ] && [ -f "$work/r2/pid" ] && break; sleep 0.2; done
  port=$(cat "$work/port" 2> /dev/null) || { echo "FAIL: the server did not start; its log:"; cat "$work/serve.log"; exit 1; }
}
request() {  # request DATASET OUTPUT: prints the client's output, returns its status; the stats in OUTPUT.json
  # shellcheck disable=SC2086
  "$exe" request "127.0.0.1:$port" --dataset "$1" -o "$2" --stats "$2.json" --timeout 30 $scene 2>&1
}
timedRequest() {  # timedRequest DATASET OUT: request, setting out, status and took (seconds)
  local begin
  begin=$(date +%s.%N)
  out=$(request "$1" "$2"); status=$?
  took=$(awk -v a="$begin" -v b="$(date +%s.%N)" 'BEGIN { print b - a }')
}
same() {  # same IMAGE: whether IMAGE equals the one-process frame within 1/255 (prints the comparison)
  local line maxAbs
  line=$("$exe" compare "$work/single.png" "$1")
  echo "$line"
  maxAbs=$(sed -n 's/.*max_abs \([0-9.e+-]*\).*/\1/p' <<< "$line")
  [ -n "$maxAbs" ] && awk -v m="$maxAbs" 'BEGIN { exit !(m <= 1.0 / 255 + 1e-6) }'
}
members() {  # members STATS: the ranks that drew the frame, and those lost ("0,1 lost 2")
  /usr/bin/python3 -c 'import json, sys
d = json.load(open(sys.argv[1]))["distributed"]
print(",".join(map(str, d["members"])), "lost", ",".join(str(l["rank"]) for l in d["lost_ranks"]))' "$1"
}
finish() {  # finish SECONDS: waits for mpirun; returns its status, or 124 if it had to be killed
  for _ in $(seq 1 $(($1 * 10))); do kill -0 "$mpirunPid" 2> /dev/null || { wait "$mpirunPid"; return $?; }; sleep 0.1; done
  echo "mpirun did not end in $1 s: killing it; its log:"; cat "$work/serve.log"
  kill -KILL "$mpirunPid"; wait "$mpirunPid" 2> /dev/null; return 124
}

# shellcheck disable=SC2086
"$exe" render "$work/blobs" -o "$work/single.png" --stats "$work/single.json" -q $scene || exit 1
# Video encoders held to 1.5 MB each (a quarter of 6): a VP8 stream of 512x512 frames goes at 128x128 (1.2 MiB; at
# 192x192, 2.1 MiB).
start --video-memory 6
out=$(request blobs "$work/served.png"); check "a frame served through rank 0 ($out)" $?
line=$(same "$work/served.png"); check "served frame equals one process's: $line" $?
[ "$(members "$work/served.png.json")" = "0,1,2 lost " ]; check "drawn by ranks 0, 1 and 2: $(members "$work/served.png.json")" $?
# The frame's cost is the whole frame's (every rank's samples), as one process's: the rate the server measures
# from it, and chooses interactive drawings by, is the group's.
line=$(/usr/bin/python3 -c 'import json, sys
one, served = (json.load(open(f))["samples_estimated"] for f in sys.argv[1:])
print(f"{served:.0f} samples estimated, one process {one:.0f}")
sys.exit(0 if abs(served - one) <= 0.1 * one else 1)' "$work/single.json" "$work/served.png.json" 2>&1)
check "the served frame's estimated samples are the whole frame's: $line" $?
# A mesh: drawn in parts across the ranks (rank 0's part clipped by the ray caster), the one-process frame.
meshScene="--tf hot --orbit 35,25 --size 72x64"
# shellcheck disable=SC2086
"$exe" render "$work/ball" -o "$work/mesh-single.png" -q $meshScene || exit 1
# shellcheck disable=SC2086
out=$("$exe" request "127.0.0.1:$port" --dataset ball -o "$work/mesh-served.png" --stats "$work/mesh-served.json" \
  --timeout 30 $meshScene 2>&1); check "a mesh frame served through rank 0 ($out)" $?
line=$("$exe" compare "$work/mesh-single.png" "$work/mesh-served.png")
maxAbs=$(sed -n 's/.*max_abs \([0-9.e+-]*\).*/\1/p' <<< "$line")
[ -n "$maxAbs" ] && awk -v m="$maxAbs" 'BEGIN { exit !(m <= 1.0 / 255 + 1e-6) }'; check "served mesh frame equals one process's: $line" $?
grep -q '"tet_part": "raycast"' "$work/mesh-served.json"; check "the mesh frame was drawn in parts" $?
out=$(request gone "$work/gone.png"); status=$?
[ $status -ne 0 ] && grep -q "rank 2" <<< "$out"; check "a dataset missing on rank 2 is refused naming it: $out" $?
out=$(request blobs "$work/again.png"); check "still serving after the refusal" $?
# An interactive request: every rank draws the rung rank 0 chose (the provisional frame), then the exact frame.
echo '{"interactive": true, "time_budget_ms": 30}' > "$work/interactive.json"
# shellcheck disable=SC2086
out=$("$exe" request "127.0.0.1:$port" --dataset blobs -o "$work/interactive.png" --scene "$work/interactive.json" \
  --timeout 30 $scene 2>&1); status=$?
[ $status -eq 0 ] && grep -q "provisional frame" <<< "$out"; check "an interactive frame, then the exact one: $out" $?
# A drag as a VP8 stream sent smaller than its scene (for the encoders' memory): every rank draws its part at the
# stream's size, not at the scene's to be shrunk on rank 0 (the frames' drawn scale no larger than the sent one; a
# step of 2 voxels makes the drawing without the cap larger than the stream).
out=$("$exe" load "127.0.0.1:$port" --dataset blobs --tf mri --step 2 --clients 1 --size 512x512 --drag 10 \
  --interactive 2000 --encoding png --provisional-encoding vp8 --duration 3 --json "$work/video.json" \
  --require-clean 2>&1); status=$?
line=$(/usr/bin/python3 -c 'import json, sys
r = json.load(open(sys.argv[1]))
drawn, sent, frames = r["drawn_scale"] or {}, r["sent_scale"] or {}, (r["video"] or {}).get("frames", 0)
print("video frames", frames, "drawn p10-p90", drawn.get("p10"), drawn.get("p90"), "sent", sent.get("p10"), sent.get("p90"))
sys.exit(0 if frames >= 2 and sent["p90"] <= 0.25 and drawn["p90"] <= sent["p10"] + 1e-9 else 1)' "$work/video.json" 2>&1)
[ $? -eq 0 ] && [ $status -eq 0 ]
check "a VP8 stream at a quarter of the scene's sides, drawn at that size across the ranks ($line; $out)" $?
kill -STOP "$(cat "$work/r2/pid")"
timedRequest blobs "$work/stopped.png"
[ $status -ne 0 ] && grep -q "rank 2" <<< "$out" && awk -v t="$took" 'BEGIN { exit !(t < 15) }'
check "a stopped rank 2 is named within ${took} s: $out" $?
timedRequest blobs "$work/later.png"
check "the next Render is served by the other ranks: $out" $status
# The regroup waits for the ranks that answer, not for the stopped one: less than the deadline.
awk -v t="$took" 'BEGIN { exit !(t < 5) }'; check "... in ${took} s, less than the 5 s deadline" $?
line=$(same "$work/later.png"); check "... equal to one process's frame: $line" $?
[ "$(members "$work/later.png.json")" = "0,1 lost 2" ]; check "... its stats name rank 2 lost: $(members "$work/later.png.json")" $?
grep -q '"reason": *"[^"]*rank 2 did not answer' "$work/later.png.json"; check "... and why" $?
out=$(request blobs "$work/later2.png"); status=$?
[ $status -eq 0 ] && same "$work/later2.png" > /dev/null; check "and the one after: $out" $?
# Going on again, rank 2 answers the regroup it missed and is taken back.
kill -CONT "$(cat "$work/r2/pid")"
for _ in $(seq 1 40); do  # it first takes the frame command it missed, whose exchanges pass their deadline
  request blobs "$work/back.png" > /dev/null && [ "$(members "$work/back.png.json")" = "0,1,2 lost " ] && break
  sleep 0.5
done
[ "$(members "$work/back.png.json")" = "0,1,2 lost " ]; check "rank 2 going on again is taken back: $(members "$work/back.png.json")" $?
line=$(same "$work/back.png"); check "... and the frame equals one process's: $line" $?
kill -KILL "$(cat "$work/r2/pid")"
kill -TERM "$(cat "$work/r0/pid")"
finish 20; status=$?
[ $status -ne 124 ]; check "SIGTERM to rank 0 ends the job after a fault (mpirun status $status)" $?

start
out=$(request blobs "$work/before.png"); check "a frame before rank 1 is killed" $?
kill -KILL "$(cat "$work/r1/pid")"
out=$(request blobs "$work/killed.png"); status=$?
[ $status -ne 0 ] && grep -q "rank 1" <<< "$out"; check "a killed rank 1 is named: $out" $?
timedRequest blobs "$work/survived.png"
check "the next Render is served by ranks 0 and 2: $out" $status
awk -v t="$took" 'BEGIN { exit !(t < 5) }'; check "... in ${took} s, less than the 5 s deadline" $?
line=$(same "$work/survived.png"); check "... equal to one process's frame: $line" $?
[ "$(members "$work/survived.png.json")" = "0,2 lost 1" ]; check "... its stats name rank 1 lost: $(members "$work/survived.png.json")" $?
kill -TERM "$(cat "$work/r0/pid")"
finish 20; status=$?
[ $status -ne 124 ]; check "SIGTERM to rank 0 ends the job after a rank was killed (mpirun status $status)" $?

start
out=$(request blobs "$work/clean.png"); check "frame before a clean stop" $?
kill -TERM "$(cat "$work/r0/pid")"
finish 20; status=$?
[ $status -eq 0 ]; check "SIGTERM to rank 0: every rank leaves, mpirun status $status" $?

start
kill -TERM "$mpirunPid"
finish 20; status=$?
[ $status -ne 124 ]; check "SIGTERM to mpirun: the job ends (mpirun status $status)" $?
exit $failed
