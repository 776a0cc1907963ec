#!/usr/bin/env bash
# Peer benchmark against VTK: the same scene rendered by vtkFixedPointVolumeRayCastMapper, vtkGPUVolumeRayCastMapper
# (Mesa llvmpipe under Xvfb here) and voxbrick, every frame judged against voxbrick's CPU reference renderer.
#
#   bash bench/run_vtk_peer.sh [--work DIR] [--out DIR] [--views N] [--tf mri|ct-bone|FILE]
#                              [--voxbrick 'k=v,...']... [--vtk-steps 1,0.5] [--mappers fixed,gpu] [--repeats N]
#                              [--size WxH] [--elevation DEG] [--distance R] [--fov DEG] [--window LO,HI]
#                              [--volume FILE.nii.gz] [--voxbrick-bin PATH] [--name NAME] [--reference-step S]
#                              [--heatmaps N] [--no-pad]
#   e.g. bash bench/run_vtk_peer.sh --views 8 --vtk-steps 1,0.5 --voxbrick 'step=0.75' --voxbrick 'step=0.5'
#
# Each --voxbrick value is one voxbrick setting: a comma list of key=value merged into the scene JSON (values are
# JSON when they parse as JSON, else strings; 1 and 0 are true and false for the scene's boolean keys, so
# 'step=0.5,raycast=1' is the frame ray caster; 'a.b=v' nests), or a JSON object. Scene keys of render/core/Scene.h that
# change the picture (camera, size, transfer_function, background, window, shading) are refused there. --vtk-steps
# defaults to the steps of the voxbrick settings. Writes OUT/NAME.{csv,md} (NAME default peer-vtk); frames, heat
# maps and the cached reference frames go to WORK (default bench/work/peer-vtk). Installs its own dependencies
# (python3-vtk9, xvfb, xauth, python3-numpy) with apt-get when they are missing; run as root on Debian 12.
set -euo pipefail
cd "$(dirname "$0")/.."
command_line="bash bench/run_vtk_peer.sh$(printf ' %q' "$@")"

work=bench/work/peer-vtk
out=bench/results/peers
volume=/usr/share/mricron/templates/ch2better.nii.gz
bin=build/voxbrick
pass=()
while [ $# -gt 0 ]; do
  case "$1" in
    --work) work=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --volume) volume=$2; shift 2 ;;
    --voxbrick-bin) bin=$2; shift 2 ;;
    --no-pad) pass+=("$1"); shift ;;
    --views|--tf|--voxbrick|--vtk-steps|--mappers|--repeats|--size|--elevation|--distance|--fov|--window|--name|\
    --reference-step|--heatmaps)
      [ $# -ge 2 ] || { echo "run_vtk_peer.sh: $1 needs a value" >&2; exit 2; }
      pass+=("$1" "$2"); shift 2 ;;
    -h|--help) sed -n 2,18p "$0"; exit 0 ;;
    *) echo "run_vtk_peer.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done

# Dependencies (not part of scripts/setup.sh: only this benchmark needs VTK).
need=(python3-vtk9 xvfb xauth python3-numpy)
[ "$volume" = /usr/share/mricron/templates/ch2better.nii.gz ] && need+=(mricron-data)
missing=()
for p in "${need[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "run_vtk_peer.sh: installing ${missing[*]}"
  SUDO=; [ "$(id -u)" -eq 0 ] || SUDO=sudo
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# One copy of the binary for the whole run, so that a rebuild of build/ meanwhile cannot mix two builds in a table.
mkdir -p "$work/bin" "$out"
for i in $(seq 60); do [ -x "$bin" ] && break; echo "run_vtk_peer.sh: waiting for $bin"; sleep 10; done
[ -x "$bin" ] || { echo "run_vtk_peer.sh: no $bin (build first: bash scripts/build.sh)" >&2; exit 1; }
cp -p "$bin" "$work/bin/voxbrick.tmp" && mv "$work/bin/voxbrick.tmp" "$work/bin/voxbrick"
vb=$work/bin/voxbrick
export VOXBRICK_CONFIG_DIR=$PWD/config

store=$work/$(basename "$volume" | sed 's/\.gz$//; s/\.[^.]*$//').vbs
[ -d "$store" ] || nice "$vb" prep "$volume" -o "$store" --no-vdb -q

start=$(date +%s)
nice -n 10 xvfb-run -a -s "-screen 0 1280x1024x24 -nolisten tcp" /usr/bin/python3 bench/vtk_peer.py \
  --voxbrick-bin "$vb" --store "$store" --volume "$volume" --work "$work" --out "$out" --config-dir config \
  --voxbrick-source "$bin" --command "$command_line" "${pass[@]}"
echo "run_vtk_peer.sh: $(( $(date +%s) - start )) s"
