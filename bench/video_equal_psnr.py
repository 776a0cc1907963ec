#!/usr/bin/env python3
"""Bytes a frame each video setting of a bench_video CSV takes for each JPEG quality's mean PSNR, and the ratio to
JPEG's bytes: a Markdown table.

Each setting (a row's encoding and setting less its bitrate, e.g. "vp9, 2 threads; 4:4:4") is measured at several
bitrates; its bytes at a PSNR are interpolated between the two bitrates around it, log-linear (the logarithm of the
bytes linear in the PSNR). Outside the measured bitrates nothing is guessed: "below B" where even the lowest bitrate
exceeded the PSNR, "above B" where even the highest fell short.

    python3 bench/video_equal_psnr.py bench/results/video/video-444.csv
"""
import csv
import math
import re
import sys
from collections import defaultdict


def setting_of(row):
    """The row's setting less its bitrate, and the bitrate (kbit/s)."""
    match = re.match(r'(\d+) kbit/s(.*)', row['setting'])
    rest = match.group(2).lstrip('; ')
    return (row['encoding'] + (', ' + rest if rest else ''), int(match.group(1)))


def bytes_at(points, psnr):
    """points: [(psnr, bytes)] by bitrate. The bytes for `psnr`, as text, and the number (None outside)."""
    points = sorted(points)
    if psnr < points[0][0]:
        return f'below {points[0][1]:,.0f}'.replace(',', ' '), None
    if psnr > points[-1][0]:
        return f'above {points[-1][1]:,.0f}'.replace(',', ' '), None
    for (p0, b0), (p1, b1) in zip(points, points[1:]):
        if p0 <= psnr <= p1:
            t = 0 if p1 == p0 else (psnr - p0) / (p1 - p0)
            value = math.exp(math.log(b0) + t * (math.log(b1) - math.log(b0)))
            return f'{value:,.0f}'.replace(',', ' '), value
    raise AssertionError('unreachable')


def main(path):
    rows = list(csv.DictReader(open(path)))
    jpegs = [(r['setting'], float(r['psnr_mean_db']), float(r['bytes_per_frame'])) for r in rows
             if r['encoding'] == 'jpeg']
    videos = defaultdict(list)
    for r in rows:
        if r['encoding'] == 'jpeg':
            continue
        name, _ = setting_of(r)
        videos[name].append((float(r['psnr_mean_db']), float(r['bytes_per_frame'])))
    head = ['encoding'] + [f"at {q}'s {p:.2f} dB (JPEG {b:,.0f} B)".replace(',', ' ') for q, p, b in jpegs]
    print('| ' + ' | '.join(head) + ' |')
    print('| --- |' + ' ---: |' * len(jpegs))
    for name, points in videos.items():
        cells = [name]
        for _, psnr, jpeg_bytes in jpegs:
            text, value = bytes_at(points, psnr)
            cells.append(f'{text} ({value / jpeg_bytes:.2f})' if value else text)
        print('| ' + ' | '.join(cells) + ' |')


if __name__ == '__main__':
    if len(sys.argv) != 2:
        sys.exit('usage: video_equal_psnr.py BENCH_VIDEO.csv')
    main(sys.argv[1])
