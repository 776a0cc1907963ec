#!/usr/bin/env bash
# `mpirun -n N voxbrick render --mpi` against the one-process `voxbrick render`, within 1/255 per channel, for the
# cases of the sort-last comparison: the MRI (ch2better), a smooth field with the MRI preset, a sparse field, the camera inside the
# volume, an orthographic view, a coarse level of detail, a mirrored acquisition (its image flipped, and each part's
# footprint with it) and an interactive frame (composited at its reduced size), each rank of a grid walking only its
# part (bricks_outside_part in its stats) and reading only its footprint; and tetrahedral meshes: the staircase
# ball ray cast (perspective and orthographic), the camera inside a box mesh (drawn projected), and a ball paged within
# a small host budget, whose rank 0 leaves out the chunks outside its part. Usage: frames_check.sh VOXBRICK MPIRUN WORK N
# (WORK holds the datasets and the one-process frames, made once: `frames_check.sh VOXBRICK MPIRUN WORK setup`).
# `frames_check.sh VOXBRICK MPIRUN WORK N CASES` runs only the cases named in CASES (comma-separated).
# `frames_check.sh VOXBRICK MPIRUN WORK refusals`: on 2 ranks, `render --mpi` refuses what the one-process render
# refuses (--channel on a store that is no OME-Zarr, a transparent frame to JPEG, --analytic without the reference).
set -euo pipefail
exe=$1 mpirun=$2 work=$3 ranks=$4 only=${5:-}
cases=(
  "brain|brain|--tf mri --orbit 35,25,2.2"
  "mri|blobs|--tf mri --orbit 35,25,2.2"
  "sparse|sparse|--tf sparse --orbit 35,25,2.2"
  "inside|blobs|--tf mri --orbit 35,25,0.25 --fov 75"
  "ortho|blobs|--tf mri --orbit 200,-40,2.2 --ortho"
  "lod|blobs|--tf mri --orbit 35,25,2.2 --lod 4"
  "mirrored|mirrored|--tf mri --orbit 35,25,2.2"
  "interactive|blobs|--tf mri --orbit 35,25,2.2 --scene $work/interactive.json"
  "mesh|ball.vms|--tf hot --orbit 35,25"
  "meshortho|ball.vms|--tf hot --orbit 200,-40 --ortho"
  "meshinside|box.vms|--tf hot --orbit 35,25,0.3 --fov 75"
  "meshpaged|paged.vms|--tf ct-bone --window 0.5,0.95 --orbit 35,25 --host-cache 2"
)
# How each mesh case's parts are clipped to their boxes (FrameStats::tetPart): the ray caster's walk, or projected
# tets where the whole frame is projected (the camera within the mesh's box).
declare -A clip=([mesh]=raycast [meshortho]=raycast [meshinside]=projected [meshpaged]=raycast)
common="--size 72x64 --step 0.5 -q"
# An interactive frame is drawn smaller only where its shorter side is above the ladder's 64-pixel floor.
interactiveCommon="--size 144x128 --step 0.5 -q"
meshCommon="--size 72x64 -q"
# The options every case of dataset $1 (case $2) takes.
commonFor() {
  if [[ $1 == *.vms ]]; then echo "$meshCommon"; elif [ "${2:-}" = interactive ]; then echo "$interactiveCommon"; else echo "$common"; fi
}
# The value of the first "KEY": N in JSON file $2.
jsonNumber() { sed -n 's/.*"'"$1"'": \([0-9]*\).*/\1/p' "$2" | head -n 1; }
if [ "$ranks" = setup ]; then
  rm -rf "$work" && mkdir -p "$work"
  # The first interactive frame of a process (no rate measured yet) is the cheapest setting, on one rank or many.
  echo '{"interactive": true, "time_budget_ms": 10}' > "$work/interactive.json"
  "$exe" prep synthetic:blobs,n=64 --brick 16 --no-vdb -q -o "$work/blobs" > /dev/null
  "$exe" prep synthetic:sparse,n=64 --brick 16 --no-vdb -q -o "$work/sparse" > /dev/null
  # Two blobs in a mirrored (LAS) grid: its image is drawn in the store's own frame and flipped left to right.
  /usr/bin/python3 - "$work/mirrored.nrrd" << 'NRRD'
import sys
import numpy as np
z, y, x = np.mgrid[0:32, 0:36, 0:40]
v = np.exp(-(((x - 12) / 6.0) ** 2 + ((y - 20) / 7.0) ** 2 + ((z - 10) / 5.0) ** 2)) \
    + 0.7 * np.exp(-(((x - 30) / 5.0) ** 2 + ((y - 10) / 5.0) ** 2 + ((z - 22) / 6.0) ** 2))
header = ("NRRD0004\ntype: float\ndimension: 3\nspace: right-anterior-superior\nsizes: 40 36 32\n"
          "space directions: (-1.5,0,0) (0,1.5,0) (0,0,1.5)\nkinds: domain domain domain\nendian: little\n"
          "encoding: raw\nspace origin: (0,0,0)\n\n")
open(sys.argv[1], "wb").write(header.encode() + v.astype("<f4").tobytes())
NRRD
  "$exe" prep "$work/mirrored.nrrd" --brick 16 --no-vdb -q -o "$work/mirrored" > /dev/null
  # The MRI itself (Debian's mricron-data, installed by scripts/setup.sh).
  "$exe" prep /usr/share/mricron/templates/ch2better.nii.gz --brick 32 --no-vdb -q -o "$work/brain" > /dev/null
  # Meshes in small chunks, so that parts and paging have chunks to tell apart; the paged one too large for 2 MB
  # whole, its view within it once the transfer function's transparent chunks are left out.
  "$exe" prep synthetic-mesh:ball,n=16 --tets-per-chunk 512 -q -o "$work/ball.vms" > /dev/null
  "$exe" prep synthetic-mesh:box,n=10 --tets-per-chunk 512 -q -o "$work/box.vms" > /dev/null
  "$exe" prep synthetic-mesh:ball,n=28 --tets-per-chunk 256 -q -o "$work/paged.vms" > /dev/null
  for c in "${cases[@]}"; do
    IFS='|' read -r name data options <<< "$c"
    # shellcheck disable=SC2086,SC2046
    "$exe" render "$work/$data" -o "$work/$name.single.png" --stats "$work/$name.single.json" $(commonFor "$data" "$name") \
      $options
  done
  exit 0
fi
failed=0
if [ "$ranks" = refusals ]; then
  refusals=(
    "--channel 1 -o $work/refused.png|--time and --channel apply to an OME-Zarr only"
    "--background none -o $work/refused.jpg|--background none needs a .png output"
    "--analytic blobs -o $work/refused.png|--analytic needs --backend reference, which does not run with --mpi"
  )
  for r in "${refusals[@]}"; do
    IFS='|' read -r options expected <<< "$r"
    # shellcheck disable=SC2086
    if out=$("$mpirun" --oversubscribe --allow-run-as-root -n 2 "$exe" render "$work/blobs" --mpi $common \
      $options 2>&1); then
      echo "FAIL render --mpi $options: accepted"
      failed=1
    elif ! grep -qF -- "$expected" <<< "$out"; then
      echo "FAIL render --mpi $options: no '$expected' in: $out"
      failed=1
    else
      echo "render --mpi $options: refused ($expected)"
    fi
  done
  exit $failed
fi
ran=0
for c in "${cases[@]}"; do
  IFS='|' read -r name data options <<< "$c"
  [ -z "$only" ] || [[ ",$only," == *",$name,"* ]] || continue
  ran=$((ran + 1))
  out="$work/$name.$ranks.png"
  # shellcheck disable=SC2086,SC2046
  "$mpirun" --oversubscribe --allow-run-as-root -n "$ranks" "$exe" render "$work/$data" --mpi -o "$out" \
    --stats "$work/$name.$ranks.json" $(commonFor "$data" "$name") $options > /dev/null
  line=$("$exe" compare "$work/$name.single.png" "$out")
  maxAbs=$(sed -n 's/.*max_abs \([0-9.e+-]*\).*/\1/p' <<< "$line")
  if [ -n "$maxAbs" ] && awk -v m="$maxAbs" 'BEGIN { exit !(m <= 1.0 / 255 + 1e-6) }'; then
    echo "$name, $ranks ranks: $line"
  else
    echo "FAIL $name, $ranks ranks: $line (more than 1/255)"
    failed=1
  fi
  grep -q '"ranks": '"$ranks" "$work/$name.$ranks.json" || { echo "FAIL $name: stats without the ranks"; failed=1; }
  # Each rank of a grid walked only its part; an interactive frame was composited at the size it was drawn.
  if ! /usr/bin/python3 - "$work/$name.$ranks.json" "$name" "$ranks" << 'CHECK'; then
import json, sys
stats, name, ranks = json.load(open(sys.argv[1])), sys.argv[2], int(sys.argv[3])
d = stats["distributed"]
outside = [r["bricks_outside_part"] for r in d["per_rank"]]
if ranks > 1 and not name.startswith("mesh") and not all(n > 0 for n in outside):
    sys.exit(f"a rank walked into other parts: bricks_outside_part {outside}")
# A projected mesh's ranks each drew cells of their own part, and none drew them all (the one process's cells).
if name == "meshinside":
    tets = [r["tets_drawn"] for r in d["per_rank"]]
    whole = json.load(open(sys.argv[1].replace(f".{ranks}.json", ".single.json"))).get("tets_drawn", 0)
    if not all(t > 0 for t in tets) or (ranks > 1 and max(tets) >= whole):
        sys.exit(f"tets drawn per rank {tets}, the one process {whole}")
# Each rank's footprint lies within the composited frame, and (away from the camera inside the data) is smaller than
# it on some rank from 3 parts on.
frame = d["composited_width"] * d["composited_height"]
footprints = [r["footprint_pixels"] for r in d["per_rank"]]
if any(not 0 <= f <= frame for f in footprints) or (ranks > 2 and "inside" not in name and min(footprints) >= frame):
    sys.exit(f"footprints {footprints} of a {frame}-pixel frame")
if name == "interactive":
    drawn = (stats["interactive"]["width"], stats["interactive"]["height"])
    if (d["composited_width"], d["composited_height"]) != drawn or drawn[0] >= 144:
        sys.exit(f"composited at {d['composited_width']}x{d['composited_height']}, drawn at {drawn[0]}x{drawn[1]}")
CHECK
    echo "FAIL $name, $ranks ranks: the stats above"
    failed=1
  fi
  if [ -n "${clip[$name]:-}" ] && ! grep -q '"tet_part": "'"${clip[$name]}"'"' "$work/$name.$ranks.json"; then
    echo "FAIL $name: rank 0's part was not clipped as ${clip[$name]}"
    failed=1
  fi
  if [ "$name" = meshpaged ]; then
    # A paged mesh: rank 0 leaves out (culls) the chunks whose box misses its part's, besides those outside the view:
    # more than the one process does, on 2 ranks or more.
    single=$(jsonNumber tet_chunks_culled "$work/$name.single.json")
    own=$(jsonNumber tet_chunks_culled "$work/$name.$ranks.json")
    read=$(jsonNumber tet_chunks_read "$work/$name.$ranks.json")
    if [ -z "$single" ] || [ -z "$own" ] || [ "$own" -lt "$single" ] || { [ "$ranks" -gt 1 ] && [ "$own" -le "$single" ]; }; then
      echo "FAIL $name: rank 0 left out ${own:-?} chunks, the one process ${single:-?}"
      failed=1
    else
      echo "$name, $ranks ranks: rank 0 left out $own chunks (the one process $single) and read $read"
    fi
  fi
done
if [ -n "$only" ] && [ "$ran" -ne "$(tr ',' '\n' <<< "$only" | grep -c .)" ]; then
  echo "FAIL $ran of the cases $only exist"
  failed=1
fi
exit $failed
