# Sourced by the run scripts of the benchmarks in Chromium (run_browser_drag.sh, run_crowd.sh, run_tls_drag.sh,
# run_browser_ab.sh) and of the link's (run_link_ab.sh), from the repository's root. `mri_datasets WORK EXE`: the MRI
# template prepped once by EXE into WORK/mri.vbs and linked as WORK/datasets/mri, the configuration directory
# exported. `browser_bench_setup WORK SCRIPT ARGS...` exports the configuration directory and the built
# voxbrick, preps the MRI template into WORK/datasets/mri once, installs tests/browser's packages if they are missing,
# and records the command line the results name (bash bench/SCRIPT ARGS...). Also sourced by run_video_memory.sh and
# run_encoder_ladder.sh, run_stream_drawing.sh, run_drawing_psnr.sh and run_ladder_bottom.sh, for mri_datasets,
# video_replay, serve_in_background, stop_server and crowd_drag (below); by run_mpi_interactive.sh and
# run_jpeg_as_drawn.sh too.
mri_datasets() {
  local work=$1 exe=$2
  mkdir -p "$work/datasets"
  [ -f "$work/mri.vbs/store.json" ] || "$exe" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$work/mri.vbs" -q
  [ -e "$work/datasets/mri" ] || ln -s ../mri.vbs "$work/datasets/mri"
  export VOXBRICK_CONFIG_DIR=$PWD/config
}

# `video_replay SCRIPT EXE SIZE`: the MRI prepped by EXE (mri_datasets) in bench/work/video, whose replay/ must hold
# the frames drawn beforehand for --replay-frames at SIZE² (`bash bench/run_browser_link.sh --replay-draw-ms 10` draws
# them); sets `work`, `datasets` and `replay`, or names SCRIPT and exits.
video_replay() {
  local script=$1 exe=$2 size=$3
  work=bench/work/video
  datasets=$work/datasets
  replay=$work/replay
  mri_datasets "$work" "$exe"
  [ -f "$replay/replay.json" ] && [ -d "$replay/${size}x${size}" ] || {
    echo "$script: no ${size}x${size} frames in $replay (bash bench/run_browser_link.sh --replay-draw-ms 10 makes them)" >&2
    exit 2
  }
}

# `crowd_drag LOAD_EXE JSON CLIENTS SIZE CODEC DURATION`: against the server serve_in_background started (`port`),
# CLIENTS `voxbrick load` clients of LOAD_EXE dragging the MRI at SIZE² (30 cameras a second, a 50 ms budget, their
# moving frames in CODEC) for DURATION seconds, the report in JSON; then that server is stopped and `pid` cleared.
# The round of the video crowd benchmarks (run_encoder_ladder.sh, run_stream_drawing.sh).
crowd_drag() {
  local exe=$1 json=$2 clients=$3 size=$4 codec=$5 duration=$6
  "$exe" load "127.0.0.1:$port" --dataset mri --tf mri --clients "$clients" --size "${size}x${size}" --drag 30 \
    --interactive 50 --provisional-encoding "$codec" --duration "$duration" --json "$json" > /dev/null
  stop_server
}

# `stop_server_on_exit`: clears `pid` and has the script stop the server it names when it exits, however it exits.
# `stop_server`: stops that server now and waits for it.
stop_server_on_exit() {
  pid=
  trap '[ -n "$pid" ] && kill "$pid" 2> /dev/null || true' EXIT
}
stop_server() {
  kill "$pid"
  wait "$pid" 2> /dev/null || true
  pid=
}

# `serve_in_background SCRIPT LOG EXE ARGS...`: EXE serve --port 0 ARGS in the background, its output in LOG; sets
# `pid` and `port` once it listens, or names SCRIPT and the log and exits.
serve_in_background() {
  local script=$1 log=$2 exe=$3
  shift 3
  "$exe" serve --port 0 "$@" > "$log" 2>&1 &
  pid=$!
  listening_port "$script" "$log" 10
}

# `listening_port SCRIPT LOG SECONDS`: sets `port` once the server whose output goes to LOG says it listens, within
# SECONDS, or names SCRIPT and the log and exits.
listening_port() {
  local script=$1 log=$2 seconds=$3
  port=
  for _ in $(seq $((seconds * 10))); do
    port=$(grep -ao "listening on [0-9.:]*[0-9]" "$log" | head -1 | sed 's/.*://') || true
    [ -n "$port" ] && return 0
    sleep 0.1
  done
  echo "$script: the server did not start: $(cat "$log")" >&2
  exit 1
}

browser_bench_setup() {
  local work=$1 script=$2
  shift 2
  export VOXBRICK_CONFIG_DIR=$PWD/config
  mkdir -p "$work/datasets"
  local mri=/usr/share/mricron/templates/ch2better.nii.gz
  [ -f "$work/datasets/mri/store.json" ] || ./build/voxbrick prep "$mri" -q -o "$work/datasets/mri"
  [ -d tests/browser/node_modules/puppeteer-core ] || (cd tests/browser && npm ci --no-audit --no-fund)
  export VOXBRICK_EXE=$PWD/build/voxbrick
  export VOXBRICK_BENCH_COMMAND="bash bench/$script${*:+ $*}"
}
