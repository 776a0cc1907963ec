#!/usr/bin/env bash
# Two builds of the server side by side in real Chromium: bench/browser_link.mjs's drag (its options pass through,
# e.g. --sizes 1024x1024 --encodings vp8,vp9 --links loopback,relay), each round once with the old build's
# `voxbrick serve` and once with the new one's, the order alternating between rounds. Writes OUT.{csv,md}: every
# run's rows with the build and round, then each build's medians.
#
#   bash bench/run_browser_ab.sh OLD_VOXBRICK NEW_VOXBRICK OUT [--rounds 2] [browser_link options]
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 3 ] || { echo "usage: bash bench/run_browser_ab.sh OLD_VOXBRICK NEW_VOXBRICK OUT [--rounds 2] [...]" >&2; exit 2; }
old=$(realpath "$1") new=$(realpath "$2") out=$3
shift 3
rounds=2
if [ "${1:-}" = --rounds ]; then rounds=$2; shift 2; fi
[ -d tests/browser/node_modules/puppeteer-core ] || (cd tests/browser && npm ci --no-audit --no-fund > /dev/null)
source bench/browser_bench.sh
work=bench/work/video
datasets=$work/datasets
mkdir -p "$(dirname "$out")"
mri_datasets "$work" "$new"
export VOXBRICK_BENCH_COMMAND="bash bench/run_browser_ab.sh OLD NEW $out --rounds $rounds${*:+ $*}"
runs=()
for r in $(seq 1 "$rounds"); do
  order="old new"; [ $((r % 2)) -eq 0 ] && order="new old"
  for build in $order; do
    exe=$old; [ "$build" = new ] && exe=$new
    VOXBRICK_EXE=$exe node bench/browser_link.mjs --datasets "$datasets" --out "$work/ab-$build-$r" "$@" > /dev/null
    runs+=("$build,$r,$work/ab-$build-$r")
  done
done
python3 - "$out" "$old" "$new" "$rounds" "$*" "${runs[@]}" << 'EOF'
import csv, os, statistics, subprocess, sys
from datetime import date
out, old, new, rounds, options, runs = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5], sys.argv[6:]
rows = []
for run in runs:
    build, r, prefix = run.split(",", 2)
    for row in csv.DictReader(open(prefix + ".csv")):
        rows.append({"build": build, "round": int(r), **row})
    machine = next((l[len("- Machine: "):].strip() for l in open(prefix + ".md") if l.startswith("- Machine: ")), "?")
fields = ["build", "round", "link", "size", "encoding", "fps", "latency_p50_ms", "latency_p99_ms", "bytes_per_frame",
          "encode_ms_p50", "decode_ms_p50", "psnr_db_mean", "rung_p50", "bitrate_kbps_p50", "exact_after_release_ms",
          "exact_encoding", "exact_bytes", "errors"]
with open(out + ".csv", "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(fields)
    for row in rows:
        w.writerow([row.get(k, "") for k in fields])
tree = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
md = ["# Two builds side by side in Chromium", "",
      f"- Command: `bash bench/run_browser_ab.sh OLD NEW {out} --rounds {rounds}{' ' + options if options else ''}`;"
      f" old `{old}`, new `{new}` (source tree {tree}).",
      f"- Date: {date.today()}; the last run's machine line: {machine}",
      "- Each run: bench/browser_link.mjs's drag (10 s at 30 Hz, 2° a move, the MRI; relay: 10 Mbit/s, 40 ms round "
      "trip), a fresh server of that build; rounds alternate the order. Latency: camera change to frame drawn.", "",
      "| build | round | link | size | encoding | frames/s | latency p50 ms | p99 ms | bytes/frame | encode ms | "
      "decode ms | PSNR dB | rung | kbit/s | exact after release ms | exact frame | errors |",
      "|---|---:|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|"]
num = lambda x: f"{float(x):.1f}" if x not in ("", None) else ""
for row in rows:
    md.append(f"| {row['build']} | {row['round']} | {row['link']} | {row['size']} | {row['encoding']} | {num(row['fps'])} | "
              f"{num(row['latency_p50_ms'])} | {num(row['latency_p99_ms'])} | {float(row['bytes_per_frame']):.0f} | "
              f"{num(row['encode_ms_p50'])} | {num(row['decode_ms_p50'])} | {num(row['psnr_db_mean'])} | "
              f"{row['rung_p50']} | {num(row.get('bitrate_kbps_p50'))} | {num(row['exact_after_release_ms'])} | "
              f"{row.get('exact_encoding') or ''}{', ' + row['exact_bytes'] + ' B' if row.get('exact_bytes') else ''} | "
              f"{row['errors']} |")
md += ["", "Medians over the rounds:", "",
       "| link | size | encoding | build | frames/s | latency p50 ms | p99 ms | bytes/frame | PSNR dB | encode ms | decode ms | "
       "exact after release ms |",
       "|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
keys = sorted({(r["link"], r["size"], r["encoding"]) for r in rows})
for link, size, encoding in keys:
    for build in ("old", "new"):
        sel = [r for r in rows if (r["link"], r["size"], r["encoding"], r["build"]) == (link, size, encoding, build)]
        med = lambda k: statistics.median([float(r[k]) for r in sel if r[k] != ""] or [float("nan")])
        md.append(f"| {link} | {size} | {encoding} | {build} | {med('fps'):.1f} | {med('latency_p50_ms'):.0f} | "
                  f"{med('latency_p99_ms'):.0f} | {med('bytes_per_frame'):.0f} | {med('psnr_db_mean'):.1f} | "
                  f"{med('encode_ms_p50'):.1f} | {med('decode_ms_p50'):.1f} | "
                  f"{med('exact_after_release_ms'):.0f} |")
open(out + ".md", "w").write("\n".join(md) + "\n")
print("\n".join(md))
EOF
