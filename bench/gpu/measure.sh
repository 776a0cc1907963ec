#!/usr/bin/env bash
# The GPU figures in one go, on a machine lent for a few minutes: unpacks the kit (bench/gpu/pack.sh), then runs
# the steps below in order of value, each under a hard time limit and all within MEASURE_BUDGET seconds, so that a
# step cut short leaves every earlier step's files. Run from the repository root, after the GL loaders are
# installed (bench/gpu/README.md has the exact call):
#
#   bash bench/gpu/measure.sh
#
# Results go to bench/results/gpu/ (one folder per step, summary.md, measure.log); with $OUT set (the device
# machine), to $OUT as three files: summary.md, measure.log and gpu-results.tar.gz (everything, refreshed after each
# step). Every step's markdown names the device, the date and the commands.
#
# Steps (seconds at most; each also stops at the overall budget):
#   device          40  the GL renderer string (must be NVIDIA unless MEASURE_ALLOW_SOFTWARE=1), nvidia-smi, the MRI
#                       store, one 512^2 frame
#   test_render    150  the GL test program (19 s on the H200); pass/fail counts, the failed tests, and the tests that
#                       skipped (the OSMesa cases: the kit's libOSMesa is a stand-in, so that backend does not exist)
#   mri-sweep-512   90  voxbrick bench on the MRI at 512^2, 8 views, steps 0.5/0.75/1: ray caster, slabs of 32,
#                       slicing; frame times and PSNR against the CPU reference
#   roofline        90  bench_render on the MRI at 512^2, 1024^2 (8 views), 2048^2 (2): the default settings beside the
#                       sampling roofline (one trilinear fetch per sample); the ray caster's fragment and compute kernels
#   mri-sweep-1024  60  as mri-sweep-512 at 1024^2, 2 views, steps 0.75/1
#   mri-sweep-2048 110  as mri-sweep-512 at 2048^2, 1 view, step 0.75, the reference at step 0.25
#                       (the sweep's references, two transfer functions a view at step 0.125, are CPU renders:
#                       about 1.6 s a view at 512^2 and 23 s at 2048^2 on the H200 machine's 16 cores)
#   load-drag       30  voxbrick serve + voxbrick load on the MRI at 512^2: one client, then 4 dragging at 10 Hz
#   encode-aside    40  two servers, one render thread each, still frames encoded aside against on the render thread:
#                       2 clients asking 1024^2 frames one at a time, png then jpeg, each server in turn
#   load-video      45  as load-drag at 1024^2: 4 clients dragging at 15 Hz with a 50 ms interactive budget, their
#                       provisional frames as JPEG, then as a vp8 and a vp9 video stream (encoded on the server's CPU)
#   video-link      80  one client dragging the MRI at 1024² at 30 Hz (interactive 50 ms) through bench_link_relay (10
#                       Mbit/s, 40 ms round trip, a 200 ms queue) and on loopback: JPEG, vp8, vp9 moving frames
#   crowd-load      60  the MRI served at 512²: 48 clients asking still frames as a batch script (--batch) beside 4
#                       clients dragging at 10 Hz (interactive 50 ms): the draggers' frames/s and latency; then 80
#                       clients dragging at 30 Hz: frames/s, latency, Jain's index, sessions told Busy, the render
#                       threads' share drawing and waiting for a job; the 80 again on a server with 4 render threads
#   tets-1m         60  synthetic-mesh:ball,n=70 (1 025 244 tets, made by prep: no Python needed), 512^2 and 1024^2,
#                       each visibility; PSNR against the exact reference at 512^2 when time is left
#   orbit           30  voxbrick orbit on the MRI at 1024^2, 36 frames, PNG and JPEG: the next frame planned while the
#                       GPU draws, files encoded beside the drawing
#   field-1024     150  prep synthetic:blobs,n=1024 (4.3 GB f32), frames at 1024^2 at lod 1 and 0 (and warm at 2048^2,
#                       lod 1; and with the fragment kernel); if the prep does
#                       not finish in time, n=512 instead (said in the step's file)
#
# Only when MEASURE_STEPS names them, with the browser kit (bench/gpu/pack_browser.sh; README.md has the calls):
#   crowd-browser  200  bench/crowd.mjs: 16 headless Chromium tabs dragging beside 64 TCP draggers, beside 64 clients
#                       asking 1024^2 still frames, and with --batch; every target of the crowd judged; 320 s when the
#                       kit carries a baseline (pack.sh --baseline), whose server runs each scenario after this build's
#   browser-link   240  bench/browser_link.mjs: a drag in Chromium at 1024^2 (then 512^2, 1920x1080 while time is
#                       left), JPEG, vp8 and vp9 (4:4:4; at 1024^2 also 4:2:0), through a 10 Mbit/s, 40 ms relay and
#                       on loopback
#
# Environment: MEASURE_QUICK=1 (tiny sizes, a 240 s budget: proves every step on any machine), MEASURE_BUDGET
# (seconds; default 500, quick 240), MEASURE_STEPS (names to run, default all), MEASURE_WORK (scratch, default
# /tmp/voxbrick-gpu), MEASURE_KIT (default bench/gpu/kit), MEASURE_BROWSERKIT (default
# bench/gpu/browserkit), MEASURE_LINK_SIZES (browser-link's sizes), MEASURE_ALLOW_SOFTWARE=1 (go on without an NVIDIA renderer).
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
cd "$repo"
self=$repo/bench/gpu/measure.sh
export PATH=$PATH:/usr/sbin:/sbin  # ldconfig

die() { echo "measure.sh: $*" >&2; exit 1; }
now() { date +%s; }

# ---------------------------------------------------------------------------------------------------------------------
# One step, run as `measure.sh --step NAME` under `timeout` by the driver below (its environment is set there).
if [ "${1:-}" = "--step" ]; then
  name=$2
  dir=$RES/$name
  mkdir -p "$dir"
  q() { [ "$QUICK" = 1 ]; }
  vb() { "$KIT/bin/voxbrick" "$@"; }
  # The step's markdown: device, date, then each command as it is run.
  md=$dir/$name.md
  header() {
    { echo "# $name"; echo; echo "- device: $(cat "$RES/device.txt" 2> /dev/null || echo unknown)";
      echo "- date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"; echo "- kit: $(sed -n 's/^commit: //p' "$KIT/MANIFEST.txt")";
      [ "$QUICK" = 1 ] && echo "- MEASURE_QUICK=1: tiny sizes, not figures"; echo; } > "$md"
  }
  # Runs a command, logging it in the markdown (paths shortened).
  cmd() {
    local shown=() a
    for a in "$@"; do
      a=${a//$KIT\/bin\//}; a=${a//$KIT/\$KIT}; a=${a//$RES/\$RES}; a=${a//$WORK/\$WORK}; [ "$a" = vb ] && a=voxbrick
      [[ "$a" =~ [\ \|] ]] && a="'$a'"
      shown+=("$a")
    done
    echo "    ${shown[*]}" >> "$md"
    "$@"
  }
  # Starts `voxbrick serve` on the MRI store ($render_threads render threads, default 2, and the arguments given) in
  # the background, logging to the step's server.log; sets `server` (its pid, killed when the step ends) and `port`.
  serve_mri() {
    mkdir -p "$WORK/served"
    [ -e "$WORK/served/mri" ] || cp -r "$WORK/mri.vbs" "$WORK/served/mri"
    rm -f "$WORK/port"
    cmd "$KIT/bin/voxbrick" serve --datasets "$WORK/served" --port 0 --port-file "$WORK/port" \
      --render-threads "${render_threads:-2}" "$@" \
      > "$dir/server.log" 2>&1 &
    server=$!
    trap 'kill "$server" 2> /dev/null || true' EXIT
    for _ in $(seq 300); do [ -s "$WORK/port" ] && break; sleep 0.1; done
    [ -s "$WORK/port" ] || die "$name: the server wrote no port (server.log: $(tail -3 "$dir/server.log"))"
    port=$(cat "$WORK/port")
  }
  # The steps in Chromium: the browser kit's node and Chromium (BKIT, unpacked by the driver), tests/browser's
  # packages where the harness imports them from, the GPU kit's voxbrick, and the MRI where their servers serve it;
  # the step's markdown names the browser kit.
  browser_env() {
    [ -n "${BKIT:-}" ] && [ -x "$BKIT/bin/node" ] || die "$name: no browser kit unpacked (bench/gpu/README.md)"
    [ -e tests/browser/node_modules ] || ln -s "$BKIT/node_modules" tests/browser/node_modules
    mkdir -p "$WORK/served"
    [ -e "$WORK/served/mri" ] || cp -r "$WORK/mri.vbs" "$WORK/served/mri"
    export VOXBRICK_EXE=$KIT/bin/voxbrick VOXBRICK_CHROMIUM=$BKIT/bin/chromium
    export VOXBRICK_BENCH_COMMAND="MEASURE_STEPS=$name bash bench/gpu/measure.sh"
    export VOXBRICK_BENCH_BUILD
    VOXBRICK_BENCH_BUILD="the GPU kit's, $(sed -n 's/^commit: //p' "$KIT/MANIFEST.txt" | cut -c1-12)"
    echo "The browser kit: $(sed -n 's/^chromium: //p' "$BKIT/MANIFEST.txt"), node $("$BKIT/bin/node" --version)." >> "$md"
    echo >> "$md"
  }
  # PSNR (dB) of two PNGs by voxbrick compare; inf when identical.
  psnr() {
    vb compare "$1" "$2" --json | sed -n 's/.*"psnr": *\([-0-9][-0-9.e+]*\).*/\1/p; s/.*"identical": *true.*/inf/p' | head -1
  }
  # The time left to this step, less a margin for what follows the long command.
  left() {  # at least 1: `timeout 0` would mean no limit
    local l=$(($(cat "$WORK/step-deadline") - $(now) - ${1:-5}))
    echo $((l < 1 ? 1 : l))
  }
  header
  case "$name" in
    device)
      {
        echo "commands:"; echo
        renderer=$(cmd vb render "$WORK/mri.vbs" --size 512x512 --tf mri --warm-up 2 --stats "$dir/frame-512.json" \
          -o "$dir/frame-512.png" 2>&1 | tee "$dir/render.log" | sed -n 's/^render: \(.*\)$/\1/p' | grep -v '^wrote' |
          head -1) || true
        echo; echo "- GL renderer: ${renderer:-none (see render.log)}"
        echo "- frame: $(grep '^render: wrote' "$dir/render.log" || echo none)"
        echo "- nvidia-smi: $(nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2> /dev/null ||
          echo 'not available')"
        echo "- CPU: $(nproc) cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2 / 1048576}' /proc/meminfo)," \
          "$(sed -n 's/^model name\s*: //p' /proc/cpuinfo | head -1)"
        echo "- system: $(uname -srm), $(ldd --version | head -1)"
        echo "- libstdc++: $LIBSTDCXX"
        echo; echo '```'; cat "$KIT/MANIFEST.txt"; echo '```'
      } >> "$md"
      renderer=$(sed -n 's/^- GL renderer: //p' "$md")
      echo "$renderer" > "$RES/device.txt"
      [ -s "$dir/frame-512.png" ] || die "device: no frame rendered (render.log: $(tail -3 "$dir/render.log"))"
      if ! grep -qi nvidia <<< "$renderer"; then
        [ "${MEASURE_ALLOW_SOFTWARE:-0}" = 1 ] || [ "$QUICK" = 1 ] ||
          die "device: the GL renderer is '$renderer', not NVIDIA (set MEASURE_ALLOW_SOFTWARE=1 to measure anyway)"
        echo "- NOTE: not an NVIDIA renderer" >> "$md"
      fi
      ;;
    mri-sweep-*)
      size=${name#mri-sweep-}
      refstep=0.125
      case "$size" in
        512) views=8 steps=0.5,0.75,1 ;;
        1024) views=2 steps=0.75,1 ;;
        # The CPU reference at 2048^2 and step 0.125 took 23 s a transfer function on 16 cores: at step 0.25 (still
        # three times finer than the GPU's 0.75) half that, so both references and the points fit the step's limit.
        *) views=1 steps=0.75 refstep=0.25 ;;
      esac
      if q; then views=1 steps=1; case "$size" in 512) size=64 views=2 ;; 1024) size=96 ;; *) size=128 ;; esac; fi
      echo "voxbrick bench on the MRI at ${size}x${size}, $views views, steps $steps (the sweep's files:" \
        "sweep.{csv,md,svg}); frames timed as a server sends them (\`--frames8\`: finished on the GPU as 8 bits)," \
        "PSNR of the same views' float frames against the CPU reference (step $refstep)." >> "$md"; echo >> "$md"
      cmd timeout "$(left 3)" "$KIT/bin/voxbrick" bench --datasets mri --mri "$KIT/data/ch2better.nii.gz" \
        --work "$WORK/bench" --out "$dir" --size "$size" --views "$views" --steps "$steps" --reference-step "$refstep" --alternatives none \
        --no-shading --slabs 32 --ert-slab 32 --erts 0.999 --slab-sub-blocks 8 --no-best-slab --no-pre-integration \
        --no-opaque --frames8 2>&1 | tee "$dir/bench.log"
      echo >> "$md"; [ -f "$dir/sweep.md" ] && cat "$dir/sweep.md" >> "$md"
      ;;
    roofline)
      # size:views; 2048^2 with 2 views: with 8 it did not finish in the step's time on the H200.
      sizes="512:8 1024:8 2048:2"
      if q; then sizes="64:2 96:2"; fi
      # bench_render preps its MRI stores from Debian's path unless they are in --work: made here from the kit's.
      mkdir -p "$WORK/bench_render"
      for brick in 16 32 64; do
        [ -f "$WORK/bench_render/mri-ch2better-b$brick.vbs/store.json" ] ||
          vb prep "$KIT/data/ch2better.nii.gz" --brick "$brick" --no-vdb -q -o "$WORK/bench_render/mri-ch2better-b$brick.vbs"
      done
      # The ray caster with each kernel ("raycast": fragment, "raycast compute": compute), each beside its roofline.
      configs='vertex slicer, skip|vertex slicer, no skip|vertex slicer, skip, sub-block 8|roofline, no skip|slab 32, ert 0.999, skip, sub-block 8|slab 32, skip, sub-block 8|slab 32, skip, sub-block 8, roofline|raycast, ert 0.999, skip, sub-block 8|raycast, skip, sub-block 8|raycast, skip, sub-block 8, roofline|raycast compute, ert 0.999, skip, sub-block 8|raycast compute, skip, sub-block 8|raycast compute, skip, sub-block 8, roofline'
      echo "bench_render on the MRI ($sizes: size:views), step 0.5: each setting beside its roofline (one trilinear fetch" \
        "per sample, no classification, no blending); the ray caster's fragment kernel (raycast) and compute kernel" \
        "(raycast compute). One CSV and markdown per size." >> "$md"; echo >> "$md"
      for sv in $sizes; do
        size=${sv%:*} views=${sv#*:}
        cmd timeout "$(left 3)" "$KIT/bin/bench_render" --out "$dir" --work "$WORK/bench_render" --size "$size" \
          --views "$views" --step 0.5 --datasets mri-ch2better --name "roofline-$size" --configs "$configs" 2>&1 |
          tee -a "$dir/bench_render.log"
        echo >> "$md"; cat "$dir/roofline-$size.md" >> "$md"; echo >> "$md"
      done
      ;;
    test_render)
      filter='*'
      q && filter='Context.*:RendererCli.*:TetCommands.*:FilterProbe.*'
      echo "The GL test program (its expectations were set on llvmpipe). Log: test_render.log." >> "$md"; echo >> "$md"
      # The OME-Zarr frame tests write their fixtures with Debian's python3-zarr, which a machine that reaches no
      # package registry may lack: then they are left out, and the report says so.
      if ! /usr/bin/python3 -c 'import zarr, numcodecs' > /dev/null 2>&1; then
        filter="$filter-ZarrFrames.*"
        echo "- not run: ZarrFrames.* (this machine lacks Debian's python3-zarr, which writes their fixtures)" >> "$md"
      fi
      set +e
      cmd timeout "$(left 8)" "$KIT/bin/test_render" --gtest_filter="$filter" > "$dir/test_render.log" 2>&1
      rc=$?
      set -e
      # Each test's result. The OSMesa cases skip, naming the kit's stand-in (render::osMesaStandIn): a failure is a
      # failure, whatever its log mentions.
      awk '/^\[       OK \]/ && /\([0-9]+ ms\)$/ {print $4 ",ok"}
           /^\[  SKIPPED \]/ && /\([0-9]+ ms\)$/ {print $4 ",skipped"}
           /^\[  FAILED  \]/ && /\([0-9]+ ms\)$/ {sub(/,$/, "", $4); print $4 ",failed"}' \
        "$dir/test_render.log" > "$dir/results.tmp"
      { echo "test,result"; cat "$dir/results.tmp"; } > "$dir/test_render.csv"
      rm -f "$dir/results.tmp"
      total=$(sed -n 's/^\[==========\] Running \([0-9]*\) tests.*/\1/p' "$dir/test_render.log")
      count() { grep -c ",$1\$" "$dir/test_render.csv" || true; }
      {
        echo; echo "- exit status: $rc$([ "$rc" = 124 ] && echo ' (stopped at its time limit)')"
        echo "- tests: ${total:-?} to run, $(count ok) passed, $(count failed) failed, $(count skipped) skipped"
        if grep -q ',failed$' "$dir/test_render.csv"; then
          echo "- failed:"; sed -n 's/^\(.*\),failed$/  - \1/p' "$dir/test_render.csv"
        fi
        if grep -q ',skipped$' "$dir/test_render.csv"; then
          echo "- skipped: $(sed -n 's/^\(.*\),skipped$/\1/p' "$dir/test_render.csv" | paste -sd ' ')"
          echo "- why: $(grep -m1 'did not run' "$dir/test_render.log" || echo '(see the log)')"
        fi
        echo "- filter precision: $(grep -m1 'linear filter weight step' "$dir/test_render.log" | sed 's/^\[ info \] //' || true)"
        echo "- last test started: $(grep '^\[ RUN      \]' "$dir/test_render.log" | tail -1 | sed 's/^\[ RUN      \] //')"
      } >> "$md"
      ;;
    orbit)
      size=1024 frames=36
      q && size=64 frames=6
      echo "voxbrick orbit on the MRI store, tf mri, ${size}x${size}, $frames frames: each next frame planned while the" \
        "GPU draws the last, files encoded beside the drawing; as PNG and as JPEG. The summary line gives the mean" \
        "frame (its planning and drawing to its readback) and the wall time a frame after the first." >> "$md"; echo >> "$md"
      for ext in png jpg; do
        rm -rf "$WORK/orbit-$ext"
        cmd timeout "$(left 3)" "$KIT/bin/voxbrick" orbit "$WORK/mri.vbs" --tf mri --size "${size}x${size}" \
          --frames "$frames" -q -o "$WORK/orbit-$ext/f%03d.$ext" 2>&1 | tee "$dir/orbit-$ext.log"
        echo "- $ext: $(grep 'orbit: wrote' "$dir/orbit-$ext.log" | tail -1)" >> "$md"
      done
      ;;
    load-drag)
      size=512x512 duration=10
      q && size=64x64 duration=2
      echo "voxbrick serve (2 render threads) on the MRI store, driven by voxbrick load over loopback; tf mri," \
        "$size." >> "$md"; echo >> "$md"
      serve_mri
      cmd "$KIT/bin/voxbrick" load "127.0.0.1:$port" --dataset mri --tf mri --step 0.75 --clients 1 \
        --duration "$duration" --size "$size" --json "$dir/load-one.json" 2>&1 | tee "$dir/load.log"
      cmd "$KIT/bin/voxbrick" load "127.0.0.1:$port" --dataset mri --tf mri --step 0.75 --clients 4 \
        --duration "$duration" --size "$size" --drag 10 --json "$dir/load-drag.json" 2>&1 | tee -a "$dir/load.log"
      kill -TERM "$server"; wait "$server" || true
      echo >> "$md"
      if command -v python3 > /dev/null; then
        python3 - "$dir" >> "$md" <<'PY'
import json, os, sys
d = sys.argv[1]
rows = [("1 client, one frame at a time", "load-one.json"), ("4 clients dragging at 10 Hz, latest wins", "load-drag.json")]
print("| run | frames | frames/s | p50 ms | p95 ms | p99 ms | max ms | errors | renderer p50 ms |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
with open(os.path.join(d, "load-drag.csv"), "w") as csv:
    csv.write("run,frames,frames_per_s,p50_ms,p95_ms,p99_ms,max_ms,errors,render_ms_p50\n")
    for label, f in rows:
        j = json.load(open(os.path.join(d, f)))
        lat = j["latency_ms"]
        r = j.get("render_ms_p50", float("nan"))
        print(f"| {label} | {j['frames']} | {j['frames_per_s']:.2f} | {lat['p50']:.1f} | {lat['p95']:.1f} | "
              f"{lat['p99']:.1f} | {lat['max']:.1f} | {j['errors']} | {r:.1f} |")
        csv.write(f"{label},{j['frames']},{j['frames_per_s']:.3f},{lat['p50']:.2f},{lat['p95']:.2f},{lat['p99']:.2f},"
                  f"{lat['max']:.2f},{j['errors']},{r:.2f}\n")
PY
      else
        echo "(no python3: the reports are load-one.json and load-drag.json)" >> "$md"
      fi
      ;;
    encode-aside)
      size=1024x1024 duration=4
      q && size=64x64 duration=1
      echo "Still frames encoded aside (\`[server] encode_aside\`, the default) against on the render thread: two" \
        "servers on the MRI, one render thread each, 2 clients asking $size frames one at a time (tf mri, step" \
        "0.75), each server in turn, png then jpeg." >> "$md"; echo >> "$md"
      mkdir -p "$WORK/served"
      [ -e "$WORK/served/mri" ] || cp -r "$WORK/mri.vbs" "$WORK/served/mri"
      declare -A aport apid
      for mode in aside inline; do
        printf '[server]\nencode_aside = %s\n' "$([ $mode = aside ] && echo true || echo false)" > "$WORK/$mode.toml"
        rm -f "$WORK/$mode.port"
        cmd "$KIT/bin/voxbrick" serve --config "$WORK/$mode.toml" --datasets "$WORK/served" --port 0 \
          --port-file "$WORK/$mode.port" --render-threads 1 > "$dir/server-$mode.log" 2>&1 &
        apid[$mode]=$!
      done
      trap 'kill "${apid[aside]}" "${apid[inline]}" 2> /dev/null || true' EXIT
      for mode in aside inline; do
        for _ in $(seq 300); do [ -s "$WORK/$mode.port" ] && break; sleep 0.1; done
        [ -s "$WORK/$mode.port" ] || die "$name: the $mode server wrote no port"
        aport[$mode]=$(cat "$WORK/$mode.port")
      done
      echo "encoding,mode,frames_per_s,p50_ms,p99_ms,render_ms_p50" > "$dir/encode-aside.csv"
      for enc in png jpeg; do
        for mode in aside inline; do
          cmd "$KIT/bin/voxbrick" load "127.0.0.1:${aport[$mode]}" --dataset mri --tf mri --step 0.75 --clients 2 \
            --duration "$duration" --size "$size" --encoding "$enc" --json "$dir/load-$enc-$mode.json" 2>&1 |
            tee -a "$dir/load.log"
          if command -v python3 > /dev/null; then
            python3 -c "import json; j = json.load(open('$dir/load-$enc-$mode.json')); l = j['latency_ms']; print('$enc,$mode,%.2f,%.1f,%.1f,%.2f' % (j['frames_per_s'], l['p50'], l['p99'], j.get('render_ms_p50') or 0))" >> "$dir/encode-aside.csv"
          fi
        done
      done
      kill -TERM "${apid[aside]}" "${apid[inline]}"; wait "${apid[aside]}" "${apid[inline]}" || true
      { echo '```'; cat "$dir/encode-aside.csv"; echo '```'; } >> "$md"
      ;;
    load-video)
      size=1024x1024 duration=8
      q && size=128x128 duration=2
      echo "voxbrick serve (2 render threads, 2 encode threads) on the MRI store; voxbrick load over loopback: 4" \
        "clients dragging at 15 Hz, interactive 50 ms, tf mri, $size; provisional frames as JPEG, vp8, vp9." >> "$md"
      echo >> "$md"
      serve_mri
      for enc in jpeg vp8 vp9; do
        cmd "$KIT/bin/voxbrick" load "127.0.0.1:$port" --dataset mri --tf mri --step 0.75 --clients 4 \
          --duration "$duration" --size "$size" --drag 15 --interactive 50 --provisional-encoding "$enc" \
          --json "$dir/load-$enc.json" 2>&1 | tee -a "$dir/load.log"
      done
      kill -TERM "$server"; wait "$server" || true
      echo >> "$md"
      if command -v python3 > /dev/null; then
        python3 - "$dir" >> "$md" <<'PY'
import json, os, sys
d = sys.argv[1]
print("| provisional | frames | frames/s | p50 ms | p95 ms | p99 ms | KB a frame | encode p50 ms | decode p50 ms | key frames | errors |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
with open(os.path.join(d, "load-video.csv"), "w") as csv:
    csv.write("provisional,frames,frames_per_s,p50_ms,p95_ms,p99_ms,kb_per_frame,encode_ms_p50,decode_ms_p50,key_frames,errors\n")
    for enc in ("jpeg", "vp8", "vp9"):
        f = os.path.join(d, f"load-{enc}.json")
        if not os.path.exists(f):
            continue
        j = json.load(open(f))
        lat = j["latency_ms"]
        num = lambda x: float("nan") if x is None else float(x)
        kb = num(j.get("payload_bytes_per_frame")) / 1024
        v = j.get("video") or {}
        dec = num((v.get("decode_ms") or {}).get("p50"))
        row = (enc, j["frames"], j["frames_per_s"], lat["p50"], lat["p95"], lat["p99"], kb,
               num(j.get("encode_ms_p50")), dec, v.get("key_frames", 0), j["errors"])
        print("| %s | %d | %.2f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %s | %d |" % row)
        csv.write("%s,%d,%.3f,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,%s,%d\n" % row)
PY
      else
        echo "(no python3: the reports are load-jpeg.json, load-vp8.json, load-vp9.json)" >> "$md"
      fi
      ;;
    video-link)
      size=1024x1024 duration=10
      q && size=128x128 duration=2
      [ -x "$KIT/bin/bench_link_relay" ] || die "video-link: the kit has no bench_link_relay (build it before pack.sh)"
      rm -f "$WORK/relay-port"
      echo "voxbrick serve (2 render threads) on the MRI store; one client (voxbrick load --drag 30, interactive 50 ms," \
        "tf mri, $size, ${duration} s, each Frame reported as the viewer does) on loopback and through" \
        "bench_link_relay: 10 Mbit/s each way, 20 ms each way (40 ms round trip), a 200 ms queue." >> "$md"
      echo >> "$md"
      serve_mri
      cmd "$KIT/bin/bench_link_relay" --target "$port" --port-file "$WORK/relay-port" --mbit 10 --delay-ms 20 \
        --queue-ms 200 > "$dir/relay.log" 2>&1 &
      relay=$!
      trap 'kill "$server" "$relay" 2> /dev/null || true' EXIT
      for _ in $(seq 100); do [ -s "$WORK/relay-port" ] && break; sleep 0.1; done
      relayPort=$(cat "$WORK/relay-port")
      for link in relay loopback; do
        p=$port; [ "$link" = relay ] && p=$relayPort
        for enc in jpeg vp8 vp9; do
          [ "$link" = loopback ] && [ "$enc" = vp9 ] && continue
          cmd "$KIT/bin/voxbrick" load "127.0.0.1:$p" --dataset mri --tf mri --step 0.75 --clients 1 --drag 30 \
            --interactive 50 --provisional-encoding "$enc" --duration "$duration" --size "$size" \
            --json "$dir/$link-$enc.json" 2>&1 | tee -a "$dir/load.log"
        done
      done
      kill -TERM "$server" "$relay"; wait "$server" || true
      echo >> "$md"
      if command -v python3 > /dev/null; then
        python3 - "$dir" >> "$md" <<'PY'
import json, os, sys
d = sys.argv[1]
num = lambda x: float("nan") if x is None else float(x)
print("| link | moving frames | frames/s | p50 ms | p95 ms | p99 ms | KB a frame | encode p50 ms | decode p50 ms | key frames | errors |")
print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
with open(os.path.join(d, "video-link.csv"), "w") as csv:
    csv.write("link,provisional,frames_per_s,p50_ms,p95_ms,p99_ms,kb_per_frame,encode_ms_p50,decode_ms_p50,key_frames,errors\n")
    for link in ("relay", "loopback"):
        for enc in ("jpeg", "vp8", "vp9"):
            f = os.path.join(d, f"{link}-{enc}.json")
            if not os.path.exists(f):
                continue
            j = json.load(open(f))
            lat = j["latency_ms"]
            v = j.get("video") or {}
            row = (link, enc, j["frames_per_s"], lat["p50"], lat["p95"], lat["p99"],
                   num(j.get("payload_bytes_per_frame")) / 1024, num(j.get("encode_ms_p50")),
                   num((v.get("decode_ms") or {}).get("p50")), v.get("key_frames", 0), j["errors"])
            print("| %s | %s | %.2f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %s | %d |" % row)
            csv.write("%s,%s,%.3f,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,%s,%d\n" % row)
PY
      fi
      ;;
    crowd-load)
      size=512x512 duration=12
      q && size=64x64 duration=3
      echo "voxbrick serve (2 render threads) on the MRI store; at once: 48 clients of a batch script (--batch, still" \
        "frames one after another) and 4 clients dragging at 10 Hz (interactive 50 ms, provisional jpeg), $size." >> "$md"
      echo >> "$md"
      serve_mri --max-sessions 256
      cmd "$KIT/bin/voxbrick" load "127.0.0.1:$port" --dataset mri --tf mri --step 0.75 --clients 48 --batch \
        --duration "$duration" --size "$size" --json "$dir/load-batch.json" > "$dir/load-batch.log" 2>&1 &
      batch=$!
      sleep 1
      cmd "$KIT/bin/voxbrick" load "127.0.0.1:$port" --dataset mri --tf mri --step 0.75 --clients 4 --drag 10 \
        --interactive 50 --provisional-encoding jpeg --duration $((duration - 2)) --size "$size" \
        --json "$dir/load-drag.json" 2>&1 | tee "$dir/load-drag.log"
      wait "$batch" || true
      cat "$dir/load-batch.log"
      # Then a crowd of one class: 80 clients dragging at 30 Hz (as 16 viewers beside 64 scripted draggers).
      cmd "$KIT/bin/voxbrick" load "127.0.0.1:$port" --dataset mri --tf mri --step 0.75 --clients 80 --drag 30 \
        --interactive 50 --provisional-encoding jpeg --duration $((duration - 2)) --size "$size" \
        --json "$dir/load-crowd80.json" 2>&1 | tee "$dir/load-crowd80.log"
      kill -TERM "$server"; wait "$server" || true
      # The same crowd on a fresh server with 4 render threads: whether more of the machine's
      # cores draw more frames of one GPU (the figures say how busy each server's render threads were).
      mv "$dir/server.log" "$dir/server-2-threads.log"
      render_threads=4 serve_mri --max-sessions 256
      cmd "$KIT/bin/voxbrick" load "127.0.0.1:$port" --dataset mri --tf mri --step 0.75 --clients 80 --drag 30 \
        --interactive 50 --provisional-encoding jpeg --duration $((duration - 2)) --size "$size" \
        --json "$dir/load-crowd80-4.json" 2>&1 | tee "$dir/load-crowd80-4.log"
      kill -TERM "$server"; wait "$server" || true
      echo >> "$md"
      if command -v python3 > /dev/null; then
        python3 - "$dir" >> "$md" <<'PY'
import json, os, sys
d = sys.argv[1]
def load(f):
    p = os.path.join(d, f)
    return json.load(open(p)) if os.path.exists(p) else None
def share(j, key):
    """The render threads' share of the run in `key` (render_busy_s: drawing and encoding; render_wait_s: asking the
    scheduler for a job): their seconds over the run (the server's at its end less those as it began, `voxbrick
    load`'s server and server_before) over threads x the server's seconds between the two."""
    if not j or key not in (j.get("server") or {}) or key not in (j.get("server_before") or {}):
        return float("nan")
    now, was = j["server"][key], j["server_before"][key]
    return (sum(now) - sum(was)) / (len(now) * (j["server"]["uptime_s"] - j["server_before"]["uptime_s"]))
print("| clients | render threads | frames | frames/s a client | p50 ms | p95 ms | p99 ms | Jain's index | Busy replies | "
      "admitted (got a frame) | frames/s each admitted | the slowest admitted, from its first frame | capacity | "
      "render threads busy | waiting for a job | errors |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
with open(os.path.join(d, "crowd-load.csv"), "w") as csv:
    csv.write("clients,render_threads,frames,frames_per_s_per_client,p50_ms,p95_ms,p99_ms,jain_index,busy,admitted,"
              "frames_per_s_admitted,slowest_since_first,capacity,render_busy_share,render_wait_share,errors\n")
    for label, f, n in (("4 dragging beside the batch", "load-drag.json", 4), ("48 batch", "load-batch.json", 48),
                        ("80 dragging at 30 Hz, alone", "load-crowd80.json", 80),
                        ("80 dragging at 30 Hz, alone", "load-crowd80-4.json", 80)):
        j = load(f)
        if not j:
            continue
        lat = j["latency_ms"]
        jain = j.get("jain_index")
        per = j.get("per_client", [])
        took = [c for c in per if c["frames"] > 0]
        # Beside the batch the two runs overlap: their threads' shares are the crowd's alone.
        crowd = "crowd80" in f
        busy = share(j, "render_busy_s") if crowd else float("nan")
        wait = share(j, "render_wait_s") if crowd else float("nan")
        # A client let in late (told Busy first) is judged from its first frame (voxbrick load's since-first rate).
        since = [c["frames_per_s_since_first"] for c in took if c.get("frames_per_s_since_first") is not None]
        capacity = ((j.get("server") or {}).get("sessions") or {}).get("interactive_capacity", -1)
        row = (label, (j.get("server") or {}).get("render_threads", 0), j["frames"], j["frames_per_s"] / n, lat["p50"], lat["p95"],
               lat["p99"], float("nan") if jain is None else jain, j.get("busy", 0), len(took),
               sum(c["frames_per_s"] for c in took) / len(took) if took else float("nan"),
               min(since) if since else float("nan"), capacity, busy, wait, j["errors"])
        print("| %s | %d | %d | %.2f | %.1f | %.1f | %.1f | %.3f | %d | %d | %.2f | %.2f | %d | %.2f | %.2f | %d |" % row)
        csv.write("%s,%d,%d,%.3f,%.2f,%.2f,%.2f,%.3f,%d,%d,%.3f,%.3f,%d,%.3f,%.3f,%d\n" % row)
PY
      fi
      ;;
    crowd-browser)
      # bench/crowd.mjs as on the development machine: 16 headless Chromium tabs dragging the MRI at 512² beside 64
      # TCP draggers (A), beside 64 clients asking 1024² still frames (B), and with --batch (B'); the browser kit's
      # Chromium and node, the GPU kit's voxbrick (each scenario on a fresh server); then, when the kit carries one
      # (pack.sh --baseline), every scenario again on the baseline's server, for the same table.
      browser_env
      args=(--datasets "$WORK/served" --dataset mri --tf mri --out "$dir/crowd")
      q && args+=(--tabs 2 --drag-clients 4 --batch-clients 4 --duration 3 --size 128 --batch-size 256)
      if [ -x "$KIT/baseline/voxbrick" ]; then args+=(--baseline-exe "$KIT/baseline/voxbrick"); fi
      cmd "$BKIT/bin/node" bench/crowd.mjs "${args[@]}" 2>&1 | tee "$dir/crowd.log"
      [ -s "$dir/crowd.md" ] || die "crowd-browser: bench/crowd.mjs wrote no results (crowd.log)"
      { echo; sed -n '/^| scenario/,$p' "$dir/crowd.md"; } >> "$md"
      ;;
    browser-link)
      # bench/browser_link.mjs: a 10 s drag of the MRI in headless Chromium, JPEG against vp8 and vp9 (in 4:4:4, the
      # page's way where Chromium decodes it; at 1024² 4:2:0 too, vp9-420), through bench/link_relay.mjs (10 Mbit/s,
      # 40 ms round trip) and on loopback; 1024² first (the size the targets name), then 512² and 1920x1080 while time
      # is left. Rows are written as they finish: a step cut short keeps the relay's first.
      browser_env
      sizes=${MEASURE_LINK_SIZES:-1024x1024 512x512 1920x1080}
      q && sizes=128x128
      for size in $sizes; do
        [ "$(left 10)" -gt 60 ] || { echo "- $size: skipped, too little time left" >> "$md"; continue; }
        encodings=jpeg,vp8,vp9
        # At 1024² also JPEG at two lower qualities, for the video rows' bytes at equal PSNR (browser_link.mjs's table),
        # before vp9 in 4:2:0.
        [ "$size" = 1024x1024 ] && encodings+=,jpeg-q50,jpeg-q20,vp9-420
        args=(--datasets "$WORK/served" --out "$dir/link-$size" --sizes "$size" --encodings "$encodings"
          --links relay,loopback)
        q && args+=(--duration 2 --samples 1)
        cmd timeout "$(left 5)" "$BKIT/bin/node" bench/browser_link.mjs "${args[@]}" 2>&1 | tee "$dir/link-$size.log" || true
        [ -s "$dir/link-$size.md" ] && { echo; sed -n '/^| link/,$p' "$dir/link-$size.md"; echo; } >> "$md"
      done
      ls "$dir"/link-*.md > /dev/null 2>&1 || die "browser-link: bench/browser_link.mjs wrote no results"
      ;;
    tets-1m)
      n=70 sizes="512 1024"
      q && n=12 sizes="64"
      echo "synthetic-mesh:ball,n=$n (the Kuhn-subdivided cube cut to the unit ball; made by voxbrick prep, so the" \
        "machine needs neither gmsh nor numpy), tf hot, warm frames (--warm-up 2)." >> "$md"; echo >> "$md"
      [ -f "$WORK/ball-$n/mesh.json" ] || [ -d "$WORK/ball-$n" ] ||
        cmd vb prep "synthetic-mesh:ball,n=$n" -q -o "$WORK/ball-$n" | tee "$dir/prep.log"
      vb info "$WORK/ball-$n" > "$dir/info.txt"
      tets=$(awk '$1 == "tets" {print $2}' "$dir/info.txt")
      echo "visibility,size,tets,ms_total,ms_drawing,ms_sorting,tets_drawn,tet_ray_passes,psnr_vs_reference_db,kernel" \
        > "$dir/tets-1m.csv"
      # raycast: the ray caster's default kernel (fragment); raycast-compute: its compute kernel.
      for size in $sizes; do
        for vis in raycast raycast-compute mpvo centroid; do
          args=(--visibility "$vis")
          [ "$vis" = raycast-compute ] && args=(--visibility raycast --raycaster compute)
          cmd vb render "$WORK/ball-$n" --tf hot "${args[@]}" --size "${size}x${size}" --warm-up 2 -q \
            --stats "$dir/$vis-$size.json" -o "$WORK/tets-$vis-$size.png"
        done
      done
      # The exact reference at the first size, if it fits in what is left (a CPU renderer: minutes on few cores).
      first=${sizes%% *}
      if [ "$(left 10)" -gt 20 ]; then
        cmd timeout "$(left 10)" "$KIT/bin/voxbrick" render "$WORK/ball-$n" --tf hot --size "${first}x${first}" \
          --backend reference -q -o "$WORK/tets-reference-$first.png" || echo "(the reference did not finish)" >> "$md"
      fi
      for size in $sizes; do
        for vis in raycast raycast-compute mpvo centroid; do
          psnr=
          if [ "$size" = "$first" ] && [ -s "$WORK/tets-reference-$first.png" ]; then
            psnr=$(psnr "$WORK/tets-$vis-$size.png" "$WORK/tets-reference-$first.png")
          fi
          s=$dir/$vis-$size.json
          get() { sed -n "s/.*\"$1\": *\([-0-9.e]*\).*/\1/p" "$s" | head -1; }
          kernel=$(sed -n 's/.*"raycaster": *"\([a-z]*\)".*/\1/p' "$s" | head -1)
          echo "$vis,$size,$tets,$(get total),$(get drawing),$(get sorting),$(get tets_drawn),$(get tet_ray_passes),$psnr,$kernel" \
            >> "$dir/tets-1m.csv"
        done
      done
      { echo; echo '```'; cat "$dir/tets-1m.csv"; echo '```'; } >> "$md"
      ;;
    field-1024)
      n=1024 size=1024 fallback=512 budget=110
      q && n=64 size=64 fallback=32 budget=60
      echo "A synthetic field (blobs, f32) prepped here, frames at ${size}x${size}, tf hot, lod 1 (default) and 0," \
        "GPU budget 16 GB, host budget 16 GB; the first frame (paging) and a warm one." >> "$md"; echo >> "$md"
      prep_budget=$(($(left 60) < budget ? $(left 60) : budget))
      set +e
      start=$(now)
      cmd timeout "$prep_budget" "$KIT/bin/voxbrick" prep "synthetic:blobs,n=$n" --no-vdb -q --force \
        -o "$WORK/blobs-$n" 2>&1 | tee "$dir/prep.log"
      rc=${PIPESTATUS[0]}
      set -e
      if [ "$rc" != 0 ]; then
        echo "- prep of n=$n stopped after $(($(now) - start)) s (exit $rc, limit $prep_budget s): **scaled down to" \
          "n=$fallback**" >> "$md"
        n=$fallback
        cmd vb prep "synthetic:blobs,n=$n" --no-vdb -q --force -o "$WORK/blobs-$n" 2>&1 | tee -a "$dir/prep.log"
      fi
      echo "- prep: $(grep -h 'MB/s' "$dir/prep.log" | tail -1)" >> "$md"
      echo "n,size,lod,frame,ms_total,ms_paging,ms_traversal,ms_planning,ms_setup,ms_drawing,ms_readback,ms_ending,bricks_drawn,bricks_paged_in,psnr_vs_lod0_db,raycaster,cells_sent" \
        > "$dir/field-1024.csv"
      for lod in 1 0; do
        cmd timeout "$(left 5)" "$KIT/bin/voxbrick" render "$WORK/blobs-$n" --tf hot --size "${size}x${size}" \
          --lod "$lod" --gpu-budget 16384 --host-cache 16384 -q --stats "$dir/first-lod$lod.json" \
          -o "$WORK/field-first-lod$lod.png"
        cmd timeout "$(left 5)" "$KIT/bin/voxbrick" render "$WORK/blobs-$n" --tf hot --size "${size}x${size}" \
          --lod "$lod" --gpu-budget 16384 --host-cache 16384 --warm-up 1 -q --stats "$dir/warm-lod$lod.json" \
          -o "$WORK/field-lod$lod.png"
      done
      # The warm frame again with the fragment kernel (auto takes the compute kernel on NVIDIA): side by side.
      cmd timeout "$(left 5)" "$KIT/bin/voxbrick" render "$WORK/blobs-$n" --tf hot --size "${size}x${size}" \
        --lod 1 --gpu-budget 16384 --host-cache 16384 --warm-up 1 --raycaster fragment -q \
        --stats "$dir/warm-fragment-lod1.json" -o "$WORK/field-fragment-lod1.png" || true
      # The warm lod-1 frame after five frames of the same view (steady state: nothing lazily made any more).
      cmd timeout "$(left 5)" "$KIT/bin/voxbrick" render "$WORK/blobs-$n" --tf hot --size "${size}x${size}" \
        --lod 1 --gpu-budget 16384 --host-cache 16384 --warm-up 5 -q \
        --stats "$dir/warm-steady-lod1.json" -o "$WORK/field-steady-lod1.png" || true
      # And at twice the size (four times the pixels).
      cmd timeout "$(left 5)" "$KIT/bin/voxbrick" render "$WORK/blobs-$n" --tf hot --size "$((2 * size))x$((2 * size))" \
        --lod 1 --gpu-budget 16384 --host-cache 16384 --warm-up 1 -q \
        --stats "$dir/warm-double-lod1.json" -o "$WORK/field-double-lod1.png" || true
      for lod in 1 0; do
        frames="first warm"
        [ "$lod" = 1 ] && frames="first warm warm-steady warm-fragment warm-double"
        for frame in $frames; do
          s=$dir/$frame-lod$lod.json
          [ -f "$s" ] || continue
          get() { sed -n "s/.*\"$1\": *\([-0-9.e]*\).*/\1/p" "$s" | head -1; }
          psnr=
          if [ "$lod" = 1 ] && [ "$frame" = warm ]; then psnr=$(psnr "$WORK/field-lod1.png" "$WORK/field-lod0.png"); fi
          kernel=$(sed -n 's/.*"raycaster": *"\([a-z]*\)".*/\1/p' "$s" | head -1)
          side=$size; [ "$frame" = warm-double ] && side=$((2 * size))
          echo "$n,$side,$lod,$frame,$(get total),$(get paging),$(get traversal),$(get planning),$(get setup),$(get drawing),$(get readback),$(get ending),$(get bricks_drawn),$(get bricks_paged_in),$psnr,$kernel,$(get cells_sent)" \
            >> "$dir/field-1024.csv"
        done
      done
      { echo; echo '```'; cat "$dir/field-1024.csv"; echo '```'; } >> "$md"
      ;;
    *) die "unknown step '$name'" ;;
  esac
  exit 0
fi

# ---------------------------------------------------------------------------------------------------------------------
# The driver.
export QUICK=${MEASURE_QUICK:-0}
budget=${MEASURE_BUDGET:-$([ "$QUICK" = 1 ] && echo 240 || echo 500)}
all="device test_render mri-sweep-512 roofline mri-sweep-1024 mri-sweep-2048 load-drag encode-aside load-video video-link crowd-load tets-1m field-1024 orbit"
# The steps in Chromium need the browser kit (bench/gpu/pack_browser.sh), which travels in parts over several calls:
# they run only when MEASURE_STEPS names them.
browser_steps="crowd-browser browser-link"
steps=${MEASURE_STEPS:-$all}
for s in $steps; do
  grep -qw -- "$s" <<< "$all $browser_steps" || die "MEASURE_STEPS: unknown step '$s' (known: $all $browser_steps)"
done
declare -A cap=([crowd-browser]=200 [browser-link]=240 [device]=40 [test_render]=150 [mri-sweep-512]=90 [roofline]=90 [mri-sweep-1024]=60
  [mri-sweep-2048]=110 [load-drag]=30 [encode-aside]=40 [load-video]=45 [video-link]=80 [crowd-load]=60 [tets-1m]=60 [field-1024]=150 [orbit]=30)
start=$(now)
deadline=$((start + budget))
export WORK=${MEASURE_WORK:-/tmp/voxbrick-gpu}
kitdir=${MEASURE_KIT:-bench/gpu/kit}
if [ -n "${OUT:-}" ]; then export RES=$WORK/results; else export RES=$repo/bench/results/gpu; fi
mkdir -p "$WORK" "$RES"
if grep -qw device <<< "$steps"; then rm -f "$RES/device.txt"; fi
log=$RES/measure.log
exec > >(tee -a "$log") 2>&1

# Copies what exists so far to $OUT (when set): summary.md, measure.log, gpu-results.tar.gz.
publish() {
  [ -n "${OUT:-}" ] || return 0
  mkdir -p "$OUT"
  cp "$RES/summary.md" "$OUT/summary.md" 2> /dev/null || true
  tar -C "$RES" -czf "$OUT/gpu-results.tar.gz.part" . 2> /dev/null &&
    mv "$OUT/gpu-results.tar.gz.part" "$OUT/gpu-results.tar.gz"
  cp "$log" "$OUT/measure.log" 2> /dev/null || true
}

echo "measure.sh: $(date -u +%Y-%m-%dT%H:%M:%SZ), budget ${budget} s, steps: $steps$([ "$QUICK" = 1 ] && echo ' (quick)')"

# The kit, unpacked fresh, with the machine's zstd or the kit's own.
[ -f "$kitdir/voxbrick-gpukit.tar.zst" ] ||
  die "no kit at $kitdir/voxbrick-gpukit.tar.zst: run bench/gpu/pack.sh here, and name $kitdir in the call's carry"
rm -rf "$WORK/voxbrick-gpukit"
if command -v zstd > /dev/null; then
  zstd -dcq "$kitdir/voxbrick-gpukit.tar.zst" | tar -C "$WORK" -xf -
else
  LD_LIBRARY_PATH="$kitdir/unzstd" "$kitdir/unzstd/zstd" -dcq "$kitdir/voxbrick-gpukit.tar.zst" | tar -C "$WORK" -xf -
fi
export KIT=$WORK/voxbrick-gpukit
export VOXBRICK_CONFIG_DIR=$KIT/config
if [ -x "$KIT/baseline/voxbrick" ]; then
  cap[crowd-browser]=320
  echo "measure.sh: the kit carries a baseline ($(cut -c1-7 "$KIT/baseline/COMMIT")): crowd-browser runs its scenarios on it too"
fi

# The browser kit, for the steps in Chromium: its parts from this call's carry (MEASURE_BROWSERKIT, default
# bench/gpu/browserkit) or stashed in /tmp by earlier calls (bench/gpu/stash_browserkit.sh), checked against SHA256SUMS.
if grep -qwE 'crowd-browser|browser-link' <<< "$steps"; then
  bkdir=${MEASURE_BROWSERKIT:-bench/gpu/browserkit}
  stash=/tmp/voxbrick-browserkit-parts
  sums=$bkdir/SHA256SUMS
  [ -f "$sums" ] || sums=$stash/SHA256SUMS
  [ -f "$sums" ] || die "no browser kit: neither $bkdir/SHA256SUMS nor $stash/SHA256SUMS (bench/gpu/pack_browser.sh)"
  files=()
  for p in $(awk '$2 ~ /^part-/ {print $2}' "$sums"); do
    if [ -f "$bkdir/$p" ]; then files+=("$bkdir/$p")
    elif [ -f "$stash/$p" ]; then files+=("$stash/$p")
    else die "browser kit: $p is neither in $bkdir nor in $stash (carry it in an earlier call: bench/gpu/README.md)"; fi
  done
  [ "$(cat "${files[@]}" | sha256sum | cut -d' ' -f1)" = "$(awk '$2 == "archive" {print $1}' "$sums")" ] ||
    die "browser kit: its parts do not make the archive $sums names (parts of two packs?)"
  rm -rf "$WORK/voxbrick-browserkit"
  if command -v zstd > /dev/null; then
    cat "${files[@]}" | zstd -dcq --long=27 | tar -C "$WORK" -xf -
  else
    cat "${files[@]}" | LD_LIBRARY_PATH="$kitdir/unzstd" "$kitdir/unzstd/zstd" -dcq --long=27 | tar -C "$WORK" -xf -
  fi
  export BKIT=$WORK/voxbrick-browserkit
  echo "measure.sh: browser kit: $(sed -n 's/^chromium: //p' "$BKIT/MANIFEST.txt"), ${#files[@]} parts"
  # Chromium once before the steps (browserkit_smoke.mjs, a few seconds): should it not start on this machine as it
  # does here, the switches that run it in some containers are tried, and the first that works is kept for the steps.
  for flags in "${VOXBRICK_CHROMIUM_FLAGS:-}" "--no-zygote" "--no-zygote --single-process"; do
    if (cd "$BKIT" && VOXBRICK_CHROMIUM_FLAGS=$flags CHROME=$BKIT/bin/chromium timeout 60 "$BKIT/bin/node" \
      "$repo/bench/gpu/browserkit_smoke.mjs" > "$WORK/browser-smoke.json" 2> "$WORK/browser-smoke.log"); then
      export VOXBRICK_CHROMIUM_FLAGS=$flags
      echo "measure.sh: Chromium starts${flags:+ with $flags}: $(sed 's/,"libraries".*/}/' "$WORK/browser-smoke.json")"
      break
    fi
    echo "measure.sh: Chromium did not start${flags:+ with $flags}: $(tail -3 "$WORK/browser-smoke.log")"
  done
fi

# libstdc++: the machine's where it is at least as new as the kit's (GCC 12: GLIBCXX_3.4.30), else the kit's.
# (awk reads all of ldconfig's list: leaving early would end ldconfig by SIGPIPE, a failure under pipefail)
sys_cxx=$(ldconfig -p 2> /dev/null | awk '/libstdc\+\+\.so\.6 .*x86-64/ && !found {print $NF; found = 1}')
if [ -n "$sys_cxx" ] && grep -qa 'GLIBCXX_3\.4\.30' "$sys_cxx"; then
  export LIBSTDCXX="the machine's ($sys_cxx)"
  export LD_LIBRARY_PATH=$KIT/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
else
  export LIBSTDCXX="the kit's (the machine's ${sys_cxx:-none} is older)"
  export LD_LIBRARY_PATH=$KIT/lib:$KIT/lib/cxx${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
fi
# The GL loaders (the .gl debs) and NVIDIA's EGL vendor library.
ldconfig -p 2> /dev/null | awk '/libEGL\.so\.1 / {found = 1} END {exit !found}' || [ -n "$(find /usr/lib /lib -name 'libEGL.so.1' 2> /dev/null | head -1)" ] ||
  die "no libEGL.so.1: unpack the GL loader debs first (for f in .gl/*.deb; do dpkg -x \$f /; done; ldconfig)"
nvidia_json=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
if [ -z "${__EGL_VENDOR_LIBRARY_FILENAMES:-}" ] && [ -f "$nvidia_json" ]; then
  export __EGL_VENDOR_LIBRARY_FILENAMES=$nvidia_json
fi
"$KIT/bin/voxbrick" --version > /dev/null || die "the kit's voxbrick does not start (libraries? see above)"

# test_render calls voxbrick by the absolute path it was built with: the kit's voxbrick goes there if nothing is.
test_exe=$(cat "$KIT/TEST_VOXBRICK_PATH")
if [ ! -e "$test_exe" ]; then
  if mkdir -p "$(dirname "$test_exe")" 2> /dev/null; then
    printf '#!/bin/sh\nexec "%s" "$@"\n' "$KIT/bin/voxbrick" > "$test_exe" && chmod +x "$test_exe"
  else
    echo "measure.sh: cannot create $test_exe: test_render's command-line tests will fail"
  fi
fi

# The MRI store every step shares.
[ -f "$WORK/mri.vbs/store.json" ] ||
  "$KIT/bin/voxbrick" prep "$KIT/data/ch2better.nii.gz" --no-vdb -q --force -o "$WORK/mri.vbs"

summary=$RES/summary.md
{
  echo "# voxbrick on a GPU: summary"; echo
  echo "measure.sh, $(date -u +%Y-%m-%dT%H:%M:%SZ), budget $budget s$([ "$QUICK" = 1 ] && echo ', MEASURE_QUICK=1 (tiny sizes: not figures)')."
  echo; echo "| step | status | seconds | limit |"; echo "|---|---|---:|---:|"
} > "$summary"
publish

failed=0
for s in $steps; do
  left=$((deadline - $(now) - 5))
  limit=$((cap[$s] < left ? cap[$s] : left))
  if [ "$limit" -lt 10 ]; then
    echo "| $s | skipped: ${left} s left of the budget | 0 | ${cap[$s]} |" >> "$summary"
    echo "measure.sh: $s skipped (${left} s left)"
    continue
  fi
  echo "measure.sh: --- $s (at most $limit s) ---"
  echo $(($(now) + limit)) > "$WORK/step-deadline"
  t0=$(now)
  set +e
  timeout -k 5 "$limit" bash "$self" --step "$s"
  rc=$?
  set -e
  took=$(($(now) - t0))
  case "$rc" in
    0) status=ok ;;
    124 | 137) status="stopped at its limit"; failed=1 ;;
    *) status="failed (exit $rc)"; failed=1 ;;
  esac
  echo "| $s | $status | $took | $limit |" >> "$summary"
  echo "measure.sh: $s: $status in $took s"
  publish
  if [ "$s" = device ] && [ "$rc" != 0 ]; then
    echo "measure.sh: no usable device: the other steps are not run" | tee -a "$summary"
    break
  fi
done
{ echo; echo "Device: $(cat "$RES/device.txt" 2> /dev/null || echo unknown)"; echo "Total: $(($(now) - start)) s."; } >> "$summary"
publish
cat "$summary"
exit "$failed"
