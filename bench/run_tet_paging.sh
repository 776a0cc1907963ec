#!/usr/bin/env bash
# A mesh paged by view (a host budget below its size) against the same mesh held whole, side by side in one run:
# the first frame of a process (chunks read from the store) and a warm one (the working set kept), the chunks read,
# culled and left out, the ray caster's passes, and each paged frame's PSNR against the whole mesh's frame.
#
#   bash bench/run_tet_paging.sh [--mesh FILE] [--repeats N] [--size WxH] [--chunks "4096 16384"]
#
# Writes bench/results/tets/tet-paging.csv (one row a run) and prints the medians. Needs build/voxbrick and the mesh
# (bench/make_tet_meshes.py makes the gmsh balls).
set -euo pipefail
cd "$(dirname "$0")/.."
mesh=bench/work/tets/ball-1000000.vtk
repeats=3
size=512x512
chunks="4096"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --mesh) mesh="$2"; shift 2 ;;
    --repeats) repeats="$2"; shift 2 ;;
    --size) size="$2"; shift 2 ;;
    --chunks) chunks="$2"; shift 2 ;;
    *) echo "run_tet_paging.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
voxbrick=build/voxbrick
work=bench/work/tets/paging
out=bench/results/tets/tet-paging.csv
mkdir -p "$work" "$(dirname "$out")"
for chunk in $chunks; do
  "$voxbrick" prep "$mesh" --tets-per-chunk "$chunk" --force -q -o "$work/mesh-$chunk" > /dev/null
done

echo "tets_per_chunk,tf,view,host_budget_mb,repeat,first_ms,warm_ms,warm_paging_ms,chunks_read,chunks_culled,chunks_skipped_empty,ray_passes,psnr_vs_whole_db" > "$out"
# fit: the whole mesh in frame; detail: an 8-degree view from 1.5 radii, which sees the middle of the mesh.
declare -A views=([fit]="--orbit 30,20" [detail]="--orbit 30,20,1.5 --fov 8")
for repeat in $(seq 1 "$repeats"); do
  for chunk in $chunks; do
    for tf in hot ct-bone; do
      for view in fit detail; do
        for budget in 1024 24 16; do
          store="$work/mesh-$chunk"
          name="$work/frame-$chunk-$tf-$view-$budget"
          args=(--size "$size" --tf "$tf" ${views[$view]} --host-cache "$budget" -q)
          # The first frame of a process, then a warm one (after a frame of the same view).
          if ! "$voxbrick" render "$store" "${args[@]}" --stats "$name-first.json" -o "$name.png" > "$name.log" 2>&1; then
            echo "$chunk,$tf,$view,$budget,$repeat,refused,,,,,,," >> "$out"
            continue
          fi
          "$voxbrick" render "$store" "${args[@]}" --warm-up 1 --stats "$name-warm.json" -o "$name.png" >> "$name.log" 2>&1
          whole="$work/frame-$chunk-$tf-$view-1024.png"
          psnr=$("$voxbrick" compare "$name.png" "$whole" | sed -n 's/.*psnr \([^ ]*\) dB.*/\1/p')
          /usr/bin/python3 - "$name-first.json" "$name-warm.json" "$chunk,$tf,$view,$budget,$repeat" "$psnr" >> "$out" <<'EOF'
import json, sys
first, warm = (json.load(open(p)) for p in sys.argv[1:3])
print(",".join([sys.argv[3], f"{first['ms']['total']:.1f}", f"{warm['ms']['total']:.1f}",
                f"{warm['ms']['paging']:.2f}", str(first['tet_chunks_read']), str(first['tet_chunks_culled']),
                str(first['tet_chunks_skipped_empty']), str(warm['tet_ray_passes']), sys.argv[4]]))
EOF
        done
      done
    done
  done
done

/usr/bin/python3 - "$out" <<'EOF'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
groups = {}
for r in rows:
    groups.setdefault((r["tets_per_chunk"], r["tf"], r["view"], r["host_budget_mb"]), []).append(r)
print("| chunk | tf | view | budget MiB | first ms | warm ms | chunks read | culled | left out | passes | PSNR vs whole |")
print("|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
for key, rs in groups.items():
    if rs[0]["first_ms"] == "refused":
        print("| " + " | ".join(key) + " | refused | | | | | | |")
        continue
    med = lambda k: statistics.median(float(r[k]) for r in rs)
    print(f"| {' | '.join(key)} | {med('first_ms'):.0f} | {med('warm_ms'):.0f} | {rs[0]['chunks_read']} | "
          f"{rs[0]['chunks_culled']} | {rs[0]['chunks_skipped_empty']} | {rs[0]['ray_passes']} | {rs[0]['psnr_vs_whole_db']} |")
EOF
