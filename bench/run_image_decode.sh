#!/usr/bin/env bash
# A still frame's decode and draw in Chromium, each way a page can decode it: the MRI drawn by `voxbrick render` at
# 512² and 1024² as PNG (the exact frame) and JPEG (q85, the moving frames' default), decoded by createImageBitmap
# with its default options (the viewer's), with premultiplyAlpha and colorSpaceConversion "none" (the viewer's
# before), with each of those two alone, and by WebCodecs'
# ImageDecoder; each drawn to a canvas (bench/browser_decode.mjs, 20 times each, medians). The figures behind the
# viewer's createImageBitmap call (web/js/frames.js). Writes bench/results/browser/image-decode.{csv,md}.
#
#   bash bench/run_image_decode.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/voxbrick
[ -x "$bin" ] || { echo "run_image_decode.sh: build voxbrick first" >&2; exit 2; }
[ -d tests/browser/node_modules/puppeteer-core ] || (cd tests/browser && npm ci --no-audit --no-fund > /dev/null)
export VOXBRICK_CONFIG_DIR=$PWD/config
work=bench/work/video
store=$work/mri.vbs
stills=$work/stills
mkdir -p "$stills" bench/results/browser
[ -f "$store/store.json" ] || "$bin" prep /usr/share/mricron/templates/ch2better.nii.gz -o "$store" -q
for size in 512 1024; do
  for ext in png jpg; do
    "$bin" render "$store" --tf mri --shading --orbit 35,25 --size "${size}x${size}" --jpeg-quality 85 \
      -o "$stills/mri-$size.$ext" -q
  done
done
load=$(cut -d' ' -f1-3 /proc/loadavg)
node bench/browser_decode.mjs "$stills"/mri-* > "$work/image-decode.jsonl"
python3 - "$work/image-decode.jsonl" bench/results/browser/image-decode "$load" << 'EOF'
import json, os, subprocess, sys
from datetime import date
rows = [json.loads(l) for l in open(sys.argv[1])]
out, load = sys.argv[2], sys.argv[3]
ways = [("bitmap_no_premultiply_no_conversion", "createImageBitmap, premultiplyAlpha and colorSpaceConversion \"none\" (the viewer's before)"),
        ("bitmap_default", "createImageBitmap, default options (the viewer's now)"),
        ("bitmap_no_premultiply", "createImageBitmap, premultiplyAlpha \"none\" only"),
        ("bitmap_no_conversion", "createImageBitmap, colorSpaceConversion \"none\" only"),
        ("image_decoder", "WebCodecs ImageDecoder")]
with open(out + ".csv", "w") as f:
    f.write("image,bytes,way,decode_ms,draw_ms\n")
    for r in rows:
        for way, _ in ways:
            if way in r:
                f.write(f"{r['image']},{r['bytes']},{way},{r[way]['decode_ms']},{r[way]['draw_ms']}\n")
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
version = subprocess.run(["/usr/bin/chromium", "--version"], capture_output=True, text=True).stdout.strip()
md = ["# A still frame decoded and drawn in Chromium", "",
      "- Command: `bash bench/run_image_decode.sh` (the MRI, `voxbrick render --tf mri --shading --orbit 35,25`, "
      "as PNG and as JPEG q85; bench/browser_decode.mjs).",
      f"- Date: {date.today()}; machine: {cpu}, {os.cpu_count()} cores, load average at the start {load}; "
      f"{version}, headless, launched as the viewer's tests launch it (tests/browser/harness.mjs: --disable-gpu, "
      "--force-color-profile=srgb).",
      "- Each cell: decode ms + draw ms (to a canvas of the frame's size, the draw forced by reading a pixel back), "
      "medians of 20.", "",
      "| way | " + " | ".join(f"{r['image']} ({r['bytes'] // 1024} KB)" for r in rows) + " |",
      "| --- |" + " ---: |" * len(rows)]
for way, label in ways:
    md.append(f"| {label} | " + " | ".join(
        f"{r[way]['decode_ms']} + {r[way]['draw_ms']}" if way in r else "" for r in rows) + " |")
open(out + ".md", "w").write("\n".join(md) + "\n")
print("\n".join(md))
EOF
