#!/usr/bin/env bash
# `mpirun -n N voxbrick render --mpi` against the one-process `voxbrick render`, within 1/255 per channel, for the
# cases of the sort-last comparison: the MRI (ch2better), a smooth field with the MRI preset, a sparse field, the camera inside the
# volume, an orthographic view, a coarse level of detail and an interactive frame (composited at its reduced size).
# With 2 ranks or more, each rank walks only its part (bricks_outside_part in its stats). Usage: frames_check.sh VOXBRICK MPIRUN WORK N
# (WORK holds the datasets and the one-process frames, made once: `frames_check.sh VOXBRICK MPIRUN WORK setup`).
# `frames_check.sh VOXBRICK MPIRUN WORK refusals`: on 2 ranks, `render --mpi` refuses what the one-process render
# refuses (--channel on a store that is no OME-Zarr, a transparent frame to JPEG, --analytic without the reference).
set -euo pipefail
exe=$1 mpirun=$2 work=$3 ranks=$4
cases=(
  "brain|brain|--tf mri --orbit 35,25,2.2"
  "mri|blobs|--tf mri --orbit 35,25,2.2"
  "sparse|sparse|--tf sparse --orbit 35,25,2.2"
  "inside|blobs|--tf mri --orbit 35,25,0.25 --fov 75"
  "ortho|blobs|--tf mri --orbit 200,-40,2.2 --ortho"
  "lod|blobs|--tf mri --orbit 35,25,2.2 --lod 4"
  "interactive|blobs|--tf mri --orbit 35,25,2.2 --scene $work/interactive.json"
)
common="--size 72x64 --step 0.5 -q"
if [ "$ranks" = setup ]; then
  rm -rf "$work" && mkdir -p "$work"
  # The first interactive frame of a process (no rate measured yet) is the cheapest setting, on one rank or many.
  echo '{"interactive": true, "time_budget_ms": 10}' > "$work/interactive.json"
  "$exe" prep synthetic:blobs,n=64 --brick 16 --no-vdb -q -o "$work/blobs" > /dev/null
  "$exe" prep synthetic:sparse,n=64 --brick 16 --no-vdb -q -o "$work/sparse" > /dev/null
  # The MRI itself (Debian's mricron-data, installed by scripts/setup.sh).
  "$exe" prep /usr/share/mricron/templates/ch2better.nii.gz --brick 32 --no-vdb -q -o "$work/brain" > /dev/null
  for c in "${cases[@]}"; do
    IFS='|' read -r name data options <<< "$c"
    # shellcheck disable=SC2086
    "$exe" render "$work/$data" -o "$work/$name.single.png" $common $options
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
for c in "${cases[@]}"; do
  IFS='|' read -r name data options <<< "$c"
  out="$work/$name.$ranks.png"
  # shellcheck disable=SC2086
  "$mpirun" --oversubscribe --allow-run-as-root -n "$ranks" "$exe" render "$work/$data" --mpi -o "$out" \
    --stats "$work/$name.$ranks.json" $common $options > /dev/null
  line=$("$exe" compare "$work/$name.single.png" "$out")
  maxAbs=$(sed -n 's/.*max_abs \([0-9.e+-]*\).*/\1/p' <<< "$line")
  if [ -n "$maxAbs" ] && awk -v m="$maxAbs" 'BEGIN { exit !(m <= 1.0 / 255 + 1e-6) }'; then
    echo "$name, $ranks ranks: $line"
  else
    echo "FAIL $name, $ranks ranks: $line (more than 1/255)"
    failed=1
  fi
  grep -q '"ranks": '"$ranks" "$work/$name.$ranks.json" || { echo "FAIL $name: stats without the ranks"; failed=1; }
  # Each rank walked only its part; an interactive frame was composited at the size it was drawn.
  if ! /usr/bin/python3 - "$work/$name.$ranks.json" "$name" "$ranks" << 'CHECK'; then
import json, sys
stats, name, ranks = json.load(open(sys.argv[1])), sys.argv[2], int(sys.argv[3])
d = stats["distributed"]
outside = [r["bricks_outside_part"] for r in d["per_rank"]]
if ranks > 1 and not all(n > 0 for n in outside):
    sys.exit(f"a rank walked into other parts: bricks_outside_part {outside}")
if name == "interactive":
    drawn = (stats["interactive"]["width"], stats["interactive"]["height"])
    if (d["composited_width"], d["composited_height"]) != drawn or drawn[0] >= 72:
        sys.exit(f"composited at {d['composited_width']}x{d['composited_height']}, drawn at {drawn[0]}x{drawn[1]}")
CHECK
    echo "FAIL $name, $ranks ranks: the stats above"
    failed=1
  fi
done
exit $failed
