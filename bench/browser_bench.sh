# Sourced by the run scripts of the benchmarks in Chromium (run_browser_drag.sh, run_crowd.sh, run_tls_drag.sh), from
# the repository's root: `browser_bench_setup WORK SCRIPT ARGS...` exports the configuration directory and the built
# voxbrick, preps the MRI template into WORK/datasets/mri once, installs tests/browser's packages if they are missing,
# and records the command line the results name (bash bench/SCRIPT ARGS...).
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
