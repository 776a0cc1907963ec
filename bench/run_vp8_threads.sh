#!/usr/bin/env bash
# VP8 and VP9 encoded in 1, 2 and 4 libvpx threads (VP8: as many token partitions, VP9: tile columns), on an idle
# machine and on one whose every core is kept busy (as a rendering server's are, or a viewer's laptop running more
# than the tab): the encoder's ms a frame (bench_video, fixed speed, so that VP8 does not trade quality for time) and
# Chromium's WebCodecs decoder's ms from a chunk put in to its frame out, a chunk every 33 ms
# (bench/browser_decode.mjs), over a 1024x1024 drag of the MRI. Rounds alternate idle and busy. The figures behind
# image::videoThreadsFor. Writes bench/results/video/video-vp8-threads.{csv,md}.
#
#   bash bench/run_vp8_threads.sh [--rounds 3] [--frames 60]
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=3 frames=60
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    *) echo "run_vp8_threads.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
tool=build/bench/bench_video
[ -x "$bin" ] && [ -x "$tool" ] || { echo "run_vp8_threads.sh: build voxbrick and bench_video first" >&2; exit 2; }
[ -d tests/browser/node_modules/puppeteer-core ] || (cd tests/browser && npm ci --no-audit --no-fund > /dev/null)
export VOXBRICK_CONFIG_DIR=$PWD/config
work=bench/work/video
store=$work/mri.vbs
drag=$work/drag-1024
mkdir -p "$work" bench/results/video
[ -f "$store/store.json" ] || "$bin" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$store" -q
# The drag of bench/run_video.sh (2° a frame), reused where it was rendered already.
if [ "$(ls "$drag"/f*.png 2> /dev/null | wc -l)" -lt "$frames" ]; then
  rm -rf "$drag" && mkdir -p "$drag"
  "$bin" orbit "$store" --tf mri --shading --frames 180 --size 1024x1024 -o "$drag/f%03d.png" -q
fi
mapfile -t pngs < <(ls "$drag"/f*.png | sort | head -n "$frames")
streams=$work/vp8-threads
busy=()
stopBusy() { for p in "${busy[@]}"; do kill "$p" 2> /dev/null || true; done; busy=(); }
trap stopBusy EXIT
raw=$work/vp8-threads.jsonl
: > "$raw"
for r in $(seq 1 "$rounds"); do
  order="idle busy"; [ $((r % 2)) -eq 0 ] && order="busy idle"
  for load in $order; do
    if [ "$load" = busy ]; then
      for _ in $(seq "$(nproc)"); do
        (while :; do :; done) &
        busy+=($!)
      done
    fi
    rm -rf "$streams" && mkdir -p "$streams"
    "$tool" --csv "$streams/encode.csv" --fps 30 --qualities 85 --kbps 4000 --threads 1,2,4 --fixed-speed \
      --streams "$streams" "${pngs[@]}" > /dev/null
    python3 - "$streams/encode.csv" "$r" "$load" >> "$raw" << 'EOF'
import csv, json, re, sys
for row in csv.DictReader(open(sys.argv[1])):
    if row["encoding"] == "jpeg":
        continue
    m = re.search(r"(\d+) threads", row["setting"])
    print(json.dumps({"round": int(sys.argv[2]), "load": sys.argv[3], "what": "encode", "codec": row["encoding"],
                      "threads": int(m.group(1)) if m else 1, "ms": float(row["encode_ms"]),
                      "bytes": float(row["bytes_per_frame"]), "psnr": float(row["psnr_mean_db"])}))
EOF
    node bench/browser_decode.mjs --intervals 33 "$streams"/*.chunks |
      python3 -c '
import json, re, sys
for line in sys.stdin:
    d = json.loads(line)
    codec, threads = re.match(r"(vp8|vp9)-.*-(\d+)t\.chunks", d["stream"]).groups()
    print(json.dumps({"round": int(sys.argv[1]), "load": sys.argv[2], "what": "decode", "codec": codec,
                      "threads": int(threads), "p50": d["p50"], "p99": d["p99"], "max": d["max"], "held": d["held"],
                      "frames": d["frames"], "decoded": d["decoded"], "errors": d["errors"]}))
' "$r" "$load" >> "$raw"
    stopBusy
  done
done
python3 - "$raw" bench/results/video/video-vp8-threads "$frames" "$rounds" << 'EOF'
import json, os, statistics, subprocess, sys
from datetime import date
rows = [json.loads(l) for l in open(sys.argv[1])]
out, frames, rounds = sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
with open(out + ".csv", "w") as f:
    f.write("round,load,what,codec,threads,encode_ms,bytes,psnr_db,decode_p50_ms,decode_p99_ms,decode_max_ms,held\n")
    for r in rows:
        if r["what"] == "encode":
            f.write(f'{r["round"]},{r["load"]},encode,{r["codec"]},{r["threads"]},{r["ms"]:.2f},{r["bytes"]:.0f},'
                    f'{r["psnr"]:.2f},,,,\n')
        else:
            f.write(f'{r["round"]},{r["load"]},decode,{r["codec"]},{r["threads"]},,,,{r["p50"]},{r["p99"]},'
                    f'{r["max"]},{r["held"]}\n')
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
version = subprocess.run(["/usr/bin/chromium", "--version"], capture_output=True, text=True).stdout.strip()
md = [f"# VP8 and VP9 in several threads, on an idle machine and a busy one", "",
      f"- Command: `bash bench/run_vp8_threads.sh --rounds {rounds} --frames {frames}` (the first {frames} frames of "
      "`bench/run_video.sh`'s 1024x1024 drag of the MRI, 4000 kbit/s).",
      f"- Date: {date.today()}; machine: {cpu}, {os.cpu_count()} cores; {version}, headless. Busy: one shell loop a "
      "core beside the run.",
      "- Encode: bench_video's ms a frame, VP8 at a fixed speed (the server's is adaptive). Decode: Chromium's "
      "WebCodecs VideoDecoder as the viewer configures it, ms from a chunk put in to its frame out, a chunk every "
      "33 ms; held: chunks put in while an earlier one's frame was still out. Each row: the median over the rounds, "
      "and the worst round's figure.", "",
      "| codec | threads | load | encode ms (worst round) | decode p50 ms (worst round) | decode p99 ms (worst round) | held (worst) |",
      "| --- | ---: | --- | ---: | ---: | ---: | ---: |"]
for codec in ("vp8", "vp9"):
    for threads in (1, 2, 4):
        for load in ("idle", "busy"):
            enc = [r["ms"] for r in rows if r["what"] == "encode" and (r["codec"], r["threads"], r["load"]) == (codec, threads, load)]
            dec = [r for r in rows if r["what"] == "decode" and (r["codec"], r["threads"], r["load"]) == (codec, threads, load)]
            if not enc or not dec:
                continue
            p50 = [d["p50"] for d in dec]
            p99 = [d["p99"] for d in dec]
            held = [d["held"] for d in dec]
            md.append(f"| {codec} | {threads} | {load} | {statistics.median(enc):.1f} ({max(enc):.1f}) | "
                      f"{statistics.median(p50):.1f} ({max(p50):.1f}) | {statistics.median(p99):.1f} ({max(p99):.1f}) | "
                      f"{statistics.median(held):.0f} ({max(held)}) |")
open(out + ".md", "w").write("\n".join(md) + "\n")
print("\n".join(md))
EOF
