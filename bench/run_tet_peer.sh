#!/usr/bin/env bash
# Peer benchmark for tetrahedral meshes: a gmsh-meshed ball of about N tets with an analytic vertex field, rendered by
# VTK's vtkProjectedTetrahedraMapper and vtkUnstructuredGridVolumeRayCastMapper (Mesa llvmpipe under Xvfb here) and
# by voxbrick, every frame judged against voxbrick's CPU reference renderer.
#
#   bash bench/run_tet_peer.sh [--tets 50000|1000000|50000,1000000] [--shape ball|box] [--work DIR] [--out DIR]
#                              [--views N] [--size WxH] [--tf hot|FILE] [--repeats N] [--name NAME]
#                              [--voxbrick 'k=v,...']... [--mappers pt,rc] [--integrators pre,partial,linear]
#                              [--elevation DEG] [--distance R] [--fov DEG] [--window LO,HI] [--reference-step S]
#                              [--heatmaps N] [--voxbrick-bin PATH] [--vtk-only]
#   e.g. bash bench/run_tet_peer.sh --tets 1000000 --views 4 --repeats 3 --size 512x512
#
# For each tet count (default 50000,1000000): makes the mesh with bench/make_tet_meshes.py (cached in
# bench/work/tets/SHAPE-N.{vtk,json}), preps it (`voxbrick prep MESH.vtk -o STORE --field NAME`, cached in
# WORK/stores), then runs bench/vtk_tet_peer.py under xvfb-run. Writes OUT/NAME.{csv,md} (NAME default
# peer-tets-SHAPE-N; with several counts a given --name gets -N appended); frames, heat maps and cached reference
# frames go to WORK (default bench/work/peer-tets). --vtk-only renders the VTK side alone (no build needed). Each
# --voxbrick value is one voxbrick setting merged into the scene JSON (default visibility=raycast), as in
# run_vtk_peer.sh. Installs its own dependencies (python3-vtk9, python3-numpy, xvfb, xauth, gmsh) with apt-get when
# they are missing; run as root on Debian 12.
set -euo pipefail
cd "$(dirname "$0")/.."
command_line="bash bench/run_tet_peer.sh$(printf ' %q' "$@")"

work=bench/work/peer-tets
meshes=bench/work/tets
out=bench/results/peers
bin=build/voxbrick
tets=50000,1000000
shape=ball
name=
vtk_only=0
pass=()
while [ $# -gt 0 ]; do
  case "$1" in
    --work) work=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --voxbrick-bin) bin=$2; shift 2 ;;
    --tets) tets=$2; shift 2 ;;
    --shape) shape=$2; shift 2 ;;
    --name) name=$2; shift 2 ;;
    --vtk-only) vtk_only=1; pass+=("$1"); shift ;;
    --views|--tf|--voxbrick|--mappers|--integrators|--repeats|--size|--elevation|--distance|--fov|--window|\
    --reference-step|--heatmaps)
      [ $# -ge 2 ] || { echo "run_tet_peer.sh: $1 needs a value" >&2; exit 2; }
      pass+=("$1" "$2"); shift 2 ;;
    -h|--help) sed -n 2,21p "$0"; exit 0 ;;
    *) echo "run_tet_peer.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
IFS=, read -r -a counts <<< "$tets"
for n in "${counts[@]}"; do
  [[ "$n" =~ ^[1-9][0-9]*$ ]] || { echo "run_tet_peer.sh: --tets wants counts like 50000,1000000, not '$n'" >&2; exit 2; }
done

# Dependencies (not part of scripts/setup.sh: only this benchmark needs VTK and gmsh).
need=(python3-vtk9 python3-numpy xvfb xauth gmsh)
missing=()
for p in "${need[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "run_tet_peer.sh: installing ${missing[*]}"
  SUDO=; [ "$(id -u)" -eq 0 ] || SUDO=sudo
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

mkdir -p "$work" "$meshes" "$out"
vb=
if [ "$vtk_only" = 0 ]; then
  # One copy of the binary for the whole run, so that a rebuild of build/ meanwhile cannot mix two builds in a table.
  mkdir -p "$work/bin"
  for i in $(seq 60); do [ -x "$bin" ] && break; echo "run_tet_peer.sh: waiting for $bin"; sleep 10; done
  [ -x "$bin" ] || { echo "run_tet_peer.sh: no $bin (build first: bash scripts/build.sh)" >&2; exit 1; }
  cp -p "$bin" "$work/bin/voxbrick.tmp" && mv "$work/bin/voxbrick.tmp" "$work/bin/voxbrick"
  vb=$work/bin/voxbrick
  export VOXBRICK_CONFIG_DIR=$PWD/config
fi

start=$(date +%s)
for n in "${counts[@]}"; do
  base=$meshes/$shape-$n
  nice -n 10 /usr/bin/python3 bench/make_tet_meshes.py --tets "$n" --shape "$shape" --out "$meshes" > "$base.make.log"
  grep '^\[make_tet_meshes' "$base.make.log" || true
  field=$(/usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["field"])' "$base.json")
  run_name=${name:-peer-tets-$shape-$n}
  if [ -n "$name" ] && [ ${#counts[@]} -gt 1 ]; then run_name=$name-$n; fi
  store_args=()
  if [ "$vtk_only" = 0 ]; then
    store=$work/stores/$shape-$n.mesh
    mkdir -p "$work/stores"
    # Re-prep when the mesh file is newer than the store (make_tet_meshes.py --force, another gmsh).
    if [ ! -f "$store/mesh.json" ] || [ "$base.vtk" -nt "$store/mesh.json" ]; then
      echo "run_tet_peer.sh: $vb prep $base.vtk -o $store --field $field"
      rm -rf "$store"
      nice "$vb" prep "$base.vtk" -o "$store" --field "$field"
    fi
    store_args=(--voxbrick-bin "$vb" --store "$store" --voxbrick-source "$bin")
  fi
  nice -n 10 xvfb-run -a -s "-screen 0 1280x1024x24 -nolisten tcp" /usr/bin/python3 bench/vtk_tet_peer.py \
    --mesh "$base.vtk" --field "$field" --work "$work" --out "$out" --name "$run_name" --config-dir config \
    --command "$command_line" "${store_args[@]}" "${pass[@]}"
done
echo "run_tet_peer.sh: $(( $(date +%s) - start )) s"
