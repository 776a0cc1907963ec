#!/usr/bin/env python3
"""What the exact frame at rest costs on a slow link: the bytes of a lossless frame in every form a browser decodes
(PNG, lossless WebP at each effort), and of a lossless refinement sent as a lossy frame plus its exact residual
(JPEG at 85-95, the residual as lossless WebP), against the time a link of KBPS takes to carry each. The exact frame
must equal `voxbrick render` byte for byte, so no lossy form is an answer on its own.

    python3 bench/exact_frame_bytes.py [--kbps 10000] [--rtt-ms 40] FRAME.png ... > bench/results/video/exact-frame-bytes.md

Needs Pillow (with libwebp, Debian's python3-pil) and NumPy.
"""
import argparse
import datetime
import io
import statistics
import sys
import time

import numpy as np
from PIL import Image


def size_and_ms(image, **save):
    start = time.perf_counter()
    out = io.BytesIO()
    image.save(out, **save)
    return len(out.getvalue()), (time.perf_counter() - start) * 1000, out.getvalue()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--kbps', type=float, default=10000, help='the link, kbit/s')
    ap.add_argument('--rtt-ms', type=float, default=40, help="the link's round trip, ms")
    ap.add_argument('frames', nargs='+', help='exact frames (PNG)')
    a = ap.parse_args()
    rows = {}

    def add(name, nbytes, ms):
        rows.setdefault(name, []).append((nbytes, ms))

    for path in a.frames:
        rgb = Image.open(path).convert('RGB')
        pixels = np.asarray(rgb).astype(np.int16)
        n, ms, _ = size_and_ms(rgb, format='PNG', compress_level=1)
        add('png, zlib level 1', n, ms)
        n, ms, _ = size_and_ms(rgb, format='PNG', optimize=True)
        add('png, optimised (smallest zlib)', n, ms)
        for method, quality in ((0, 0), (1, 50), (4, 100), (6, 100)):
            n, ms, _ = size_and_ms(rgb, format='WEBP', lossless=True, method=method, quality=quality, exact=True)
            add(f'lossless webp, method {method} quality {quality}', n, ms)
        for q in (85, 95):
            jn, jms, jpeg = size_and_ms(rgb, format='JPEG', quality=q)
            shown = np.asarray(Image.open(io.BytesIO(jpeg)).convert('RGB')).astype(np.int16)
            residual = Image.fromarray(((pixels - shown) % 256).astype(np.uint8))
            rn, rms, _ = size_and_ms(residual, format='WEBP', lossless=True, method=4, quality=100, exact=True)
            add(f'jpeg q{q} + its residual as lossless webp (method 4)', jn + rn, jms + rms)

    w, h = Image.open(a.frames[0]).size
    print('# The exact frame at rest: its bytes in each lossless form, and its time on a slow link')
    print()
    print(f'- Command: `python3 bench/exact_frame_bytes.py --kbps {a.kbps:g} --rtt-ms {a.rtt_ms:g} {" ".join(a.frames)}`')
    print(f'- Date: {datetime.date.today()}; Pillow {Image.__version__} (Debian\'s libwebp, libpng, libjpeg-turbo); '
          'encode ms on this machine, indicative only.')
    print(f'- {len(a.frames)} exact frames of {w}x{h}; medians. Link time: the bytes at {a.kbps:g} kbit/s plus half '
          f'the round trip ({a.rtt_ms / 2:g} ms), before any drawing, encoding or decoding.')
    print()
    print('| form | bytes | link ms | encode ms |')
    print('| --- | ---: | ---: | ---: |')
    for name, values in rows.items():
        nbytes = statistics.median(v[0] for v in values)
        ms = statistics.median(v[1] for v in values)
        link = nbytes * 8 / a.kbps + a.rtt_ms / 2
        print(f'| {name} | {nbytes:.0f} | {link:.0f} | {ms:.0f} |')
    print()


if __name__ == '__main__':
    sys.exit(main())
