# Sourced by the run scripts of the benchmarks in Chromium (run_browser_drag.sh, run_crowd.sh, run_tls_drag.sh,
# run_browser_ab.sh) and of the link's (run_link_ab.sh), from the repository's root. `mri_datasets WORK EXE`: the MRI
# template prepped once by EXE into WORK/mri.vbs and linked as WORK/datasets/mri, the configuration directory
# exported. `browser_bench_setup WORK SCRIPT ARGS...` exports the configuration directory and the built
# voxbrick, preps the MRI template into WORK/datasets/mri once, installs tests/browser's packages if they are missing,
# and records the command line the results name (bash bench/SCRIPT ARGS...).
mri_datasets() {
  local work=$1 exe=$2
  mkdir -p "$work/datasets"
  [ -f "$work/mri.vbs/store.json" ] || "$exe" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$work/mri.vbs" -q
  [ -e "$work/datasets/mri" ] || ln -s ../mri.vbs "$work/datasets/mri"
  export VOXBRICK_CONFIG_DIR=$PWD/config
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
