# Shared by the crowd benchmarks that put two builds side by side (run_cold_crowd.sh, run_crowd_admission.sh): their
# options, the MRI store, a fresh `voxbrick serve` of either build and `voxbrick load`'s dragging clients (this tree's
# load for both builds). Sourced, from the repository's root; set `rounds`, `clients`, `duration` and `size` to the
# script's defaults first.

# Reads OLD NEW and the options (--rounds, --clients, --duration, --size) into old, new, rounds, clients, duration,
# size, and the script's own options named in `crowd_ab_own` (e.g. crowd_ab_own=(cycle): --cycle into `cycle`);
# `script` names the caller in errors.
crowd_ab_args() {
  local script=$1
  shift
  [ $# -ge 2 ] || { echo "usage: bash bench/$script OLD_VOXBRICK NEW_VOXBRICK [options]" >&2; exit 2; }
  old=$1 new=$2
  shift 2
  while [ $# -gt 0 ]; do
    case "$1" in
      --rounds) rounds=$2; shift 2 ;;
      --clients) clients=$2; shift 2 ;;
      --duration) duration=$2; shift 2 ;;
      --size) size=$2; shift 2 ;;
      --*)
        if [[ " ${crowd_ab_own[*]-} " == *" ${1#--} "* ]]; then
          printf -v "${1#--}" '%s' "$2"
          shift 2
        else
          echo "$script: unknown option $1" >&2
          exit 2
        fi
        ;;
      *) echo "$script: unknown option $1" >&2; exit 2 ;;
    esac
  done
}

# The work folder WORK with the MRI store in WORK/data (prepped once, by the new build); a server left running is
# stopped on exit.
crowd_ab_setup() {
  work=$1
  mkdir -p "$work/data"
  export VOXBRICK_CONFIG_DIR=$PWD/config
  [ -f "$work/data/mri/store.json" ] || "$new" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$work/data/mri" -q
  server=""
  trap '[ -n "$server" ] && kill "$server" 2> /dev/null || true' EXIT
}

# Begins the results of benchmark NAME: the work folder bench/work/NAME (crowd_ab_setup) and the CSV
# bench/results/server/NAME.csv (in `csv`; its folder in `out`) with its head: the run (date, machine, source tree,
# builds), the command (bash bench/SCRIPT OLD NEW OPTIONS) and the COLUMNS.
crowd_ab_begin() {
  local name=$1 script=$2 options=$3 columns=$4
  out=bench/results/server
  mkdir -p "$out"
  crowd_ab_setup "bench/work/$name"
  csv=$out/$name.csv
  {
    echo "# $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p' | head -1); source tree $(crowd_ab_tree); old $old, new $new"
    echo "# bash bench/$script OLD NEW $options"
    echo "$columns"
  } > "$csv"
}

# The source tree as the results' head names it: its commit, and whether it had changes outside bench/results.
crowd_ab_tree() {
  echo "$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- . ':!bench/results' || echo ' with uncommitted changes')"
}

# A fresh server of build BUILD (old or new) on the MRI, 2 render threads: its pid in `server`, its port in `port`.
crowd_ab_serve() {
  local exe=$old
  [ "$1" = new ] && exe=$new
  rm -f "$work/port"
  "$exe" serve --no-config --datasets "$work/data" --port 0 --port-file "$work/port" --render-threads 2 \
    --max-sessions 256 > "$work/$1.log" 2>&1 &
  server=$!
  for _ in $(seq 600); do [ -s "$work/port" ] && break; sleep 0.1; done
  port=$(cat "$work/port")
}

crowd_ab_stop() {
  kill "$server"
  wait "$server" 2> /dev/null || true  # its status is that of the signal
  server=""
}

# CLIENTS clients dragging the MRI at 30 Hz (interactive 50 ms, provisional JPEG) for SECONDS, at size x size, against
# the server on `port`; the report in JSON.
crowd_ab_load() {
  "$new" load "127.0.0.1:$port" --dataset mri --tf mri --step 0.75 --clients "$1" --drag 30 --interactive 50 \
    --provisional-encoding jpeg --duration "$2" --size "${size}x${size}" --json "$3" > /dev/null
}
