#!/usr/bin/env bash
# PNG frames encoded Small (libpng's adaptive filters, zlib's default level) against Fast (the Up filter, zlib level
# 1; image::PngSpeed), and Fast against lossless WebP (image::encodeWebp, libwebp's presets 0 to 2): renders views of the MRI at 512², 1024² and 1920x1080 with `voxbrick render`, adds two flatter
# pictures already in the repository (the demo's ball, the GPU kit's frame of a synthetic field), and bench_png
# measures bytes and encode and decode ms of each. Writes bench/results/image/png-speed.{csv,md}, with the time each
# frame takes to reach a client (encoded, then sent) on links of 10, 100 and 1000 Mbit/s, the link rate below which
# WebP reaches Chromium's canvas first (server::kWebpBelowKbps), and, where Chromium and
# the browser tests' packages are installed, Chromium's decode of each (bench/browser_decode.mjs: createImageBitmap as
# the viewer calls it, medians of 20).
#
#   bash bench/run_png_speed.sh [--repeats 5]
set -euo pipefail
cd "$(dirname "$0")/.."
repeats=5
while [ $# -gt 0 ]; do
  case "$1" in
    --repeats) repeats=$2; shift 2 ;;
    *) echo "run_png_speed.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin=build/voxbrick
tool=build/bench/bench_png
[ -x "$bin" ] && [ -x "$tool" ] || { echo "run_png_speed.sh: build voxbrick and bench_png first" >&2; exit 2; }
nifti=/usr/share/mricron/templates/ch2better.nii.gz
work=bench/work/png
store=$work/mri.vbs
mkdir -p "$work" bench/results/image
[ -f "$store/store.json" ] || "$bin" prep "$nifti" -o "$store" -q
frames=()
for spec in "mri-shaded-512:--tf mri --shading --orbit 30,20 --size 512x512" \
            "mri-shaded-1024:--tf mri --shading --orbit 30,20 --size 1024x1024" \
            "grayscale-left-1024:--tf grayscale --view left --size 1024x1024" \
            "mri-superior-1920x1080:--tf mri --view superior --size 1920x1080"; do
  name=${spec%%:*}
  # shellcheck disable=SC2086
  "$bin" render "$store" ${spec#*:} -o "$work/$name.png" > /dev/null
  frames+=("$work/$name.png")
done
frames+=(demo/ball.png bench/results/gpu/device/frame-512.png)
csv=bench/results/image/png-speed.csv
rm -rf "$work/encoded" "$work/chromium.jsonl"
mkdir -p "$work/encoded"
"$tool" --csv "$csv" --repeats "$repeats" --out "$work/encoded" -- "${frames[@]}" > /dev/null
if [ -x "${VOXBRICK_CHROMIUM:-/usr/bin/chromium}" ] && [ -d tests/browser/node_modules/puppeteer-core ]; then
  node bench/browser_decode.mjs "$work/encoded"/*.png "$work/encoded"/*.webp > "$work/chromium.jsonl"
else
  echo "run_png_speed.sh: no Chromium or no tests/browser packages: the table has no Chromium column" >&2
fi
python3 - "$csv" bench/results/image/png-speed.md "$repeats" "$work/chromium.jsonl" <<'PY'
import csv, json, os, sys, datetime
rows = list(csv.DictReader(open(sys.argv[1])))
chromium = {}
if os.path.exists(sys.argv[4]):
    for line in open(sys.argv[4]):
        r = json.loads(line)
        chromium[os.path.splitext(r['image'])[0]] = r['bitmap_default']['decode_ms']
cpu = next((l.split(':', 1)[1].strip() for l in open('/proc/cpuinfo') if l.startswith('model name')), '?')
out = ['# Lossless frames: PNG encoded Small against Fast, and lossless WebP', '',
       f'- Command: `bash bench/run_png_speed.sh --repeats {sys.argv[3]}` (views of the MRI rendered by `voxbrick render`; `demo/ball.png`, the demo\'s',
       '  synthetic ball; `frame-512` is the GPU kit\'s frame of a synthetic field, `bench/results/gpu/device/frame-512.png`).',
       f'- Date: {datetime.date.today()}; machine: {cpu}, one core, shared: ms are medians of {sys.argv[3]}, indicative.',
       '- Small: libpng\'s adaptive filter for each row, zlib\'s default level (encodePng\'s default, the files `voxbrick',
       '  render` writes). Fast: the Up filter on every row, zlib level 1 (the server\'s png frames unless the session\'s',
       '  link was measured below 10 Mbit/s). Both lossless, 8-bit RGBA.',
       '- To the client: encode ms plus the bytes\' time on the link (no round trip, no decode), Small / Fast.',
       '- Decode ms: libpng\'s (image::decodePng, the C++ client\'s); Chromium\'s: `createImageBitmap` with default options,',
       '  as the viewer decodes a png frame (headless Debian Chromium, software; medians of 20).', '',
       '| frame | size | Small bytes | Fast bytes (ratio) | Small encode ms | Fast encode ms | Small decode ms | Fast decode ms | Chromium decode ms, Small / Fast | to the client at 10 Mbit/s ms | at 100 Mbit/s | at 1 Gbit/s |',
       '| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |']
for small in [r for r in rows if r['speed'] == 'small']:
    fast = next(r for r in rows if r['frame'] == small['frame'] and r['speed'] == 'fast')
    sb, fb = int(small['bytes']), int(fast['bytes'])
    se, fe = float(small['encode_ms']), float(fast['encode_ms'])
    def to(mbps):
        return f'{se + sb * 8 / (mbps * 1000):.0f} / {fe + fb * 8 / (mbps * 1000):.0f}'
    name = small['frame']
    browser = (f"{chromium[name + '-small']:.1f} / {chromium[name + '-fast']:.1f}"
               if name + '-small' in chromium and name + '-fast' in chromium else '')
    out.append(f"| {name} | {small['size']} | {sb} | {fb} ({fb / sb:.2f}) | {se:.1f} | {fe:.1f} | "
               f"{float(small['decode_ms']):.1f} | {float(fast['decode_ms']):.1f} | {browser} | {to(10)} | {to(100)} | "
               f"{to(1000)} |")
out += ['', '## Fast PNG against lossless WebP', '',
        '- WebP: image::encodeWebp (libwebp 1.2.4\'s lossless presets 0, 1 and 2; `exact`, so every byte comes back), the',
        '  server\'s webp frames at preset 1 (a scene with `accepts_webp` on a link measured slow). Decode: libwebp\'s, and',
        '  Chromium\'s `createImageBitmap` as for png.',
        '- To the canvas: encode ms plus the bytes\' time on the link plus Chromium\'s decode ms, Fast / WebP 1.',
        '- Even at: the link rate at which Fast and WebP 1 reach the canvas together (slower links: WebP first).', '',
        '| frame | Fast bytes | WebP 0 / 1 / 2 bytes (ratio of Fast\'s, preset 1) | Fast encode ms | WebP 0 / 1 / 2 encode ms | Fast / WebP 1 decode ms | Chromium decode ms, Fast / WebP 1 | to the canvas at 10 Mbit/s ms | at 20 Mbit/s | at 50 Mbit/s | even at Mbit/s |',
        '| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |']
for fast in [r for r in rows if r['speed'] == 'fast']:
    name = fast['frame']
    webp = {r['speed']: r for r in rows if r['frame'] == name and r['speed'].startswith('webp')}
    if 'webp1' not in webp:
        continue
    w1 = webp['webp1']
    fb, wb = int(fast['bytes']), int(w1['bytes'])
    fe, we = float(fast['encode_ms']), float(w1['encode_ms'])
    fd = chromium.get(name + '-fast', float(fast['decode_ms']))
    wd = chromium.get(name + '-webp1', float(w1['decode_ms']))
    def canvas(mbps):
        return f'{fe + fb * 8 / (mbps * 1000) + fd:.0f} / {we + wb * 8 / (mbps * 1000) + wd:.0f}'
    extra_ms = (we + wd) - (fe + fd)
    even = f'{(fb - wb) * 8 / (extra_ms * 1000):.0f}' if extra_ms > 0 and fb > wb else ('always' if fb > wb else 'never')
    browser = (f"{chromium[name + '-fast']:.1f} / {chromium[name + '-webp1']:.1f}"
               if name + '-fast' in chromium and name + '-webp1' in chromium else '')
    levels = [webp.get(f'webp{i}') for i in range(3)]
    level_bytes = ' / '.join(r['bytes'] if r else '' for r in levels)
    level_ms = ' / '.join(f"{float(r['encode_ms']):.1f}" if r else '' for r in levels)
    out.append(f"| {name} | {fb} | {level_bytes} ({wb / fb:.2f}) | {fe:.1f} | {level_ms} | "
               f"{float(fast['decode_ms']):.1f} / {float(w1['decode_ms']):.1f} | {browser} | {canvas(10)} | "
               f"{canvas(20)} | {canvas(50)} | {even} |")
open(sys.argv[2], 'w').write('\n'.join(out) + '\n')
PY
echo "run_png_speed.sh: wrote bench/results/image/png-speed.{csv,md}"
