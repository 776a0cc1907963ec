"""What a crowd of `voxbrick load --provisional-encoding ...` clients saw, from its --json file: the figures the video
benchmarks (run_encoder_ladder.sh, run_stream_drawing.sh) tabulate side by side, their medians, and the CSV they keep
(run_encode_cost.sh too)."""
import csv
import json
import statistics


def crowd_row(path):
    """The slowest and fastest client's frames a second, Jain's index, latency p50/p99, the video frames encoded and
    their mean encode ms, bytes a frame, key frames for a new size, frames sent smaller by reason, the drawings' and
    the streams' median scale (where the load client reports them), and errors."""
    j = json.load(open(path))
    v = j['server']['video']
    fps = [c['frames_per_s'] for c in j['per_client']]
    frames = sum(v['encoded'][c]['frames'] for c in ('vp8', 'vp9'))
    enc = sum(v['encoded'][c]['encode_ms_mean'] * v['encoded'][c]['frames'] for c in ('vp8', 'vp9')) / max(1, frames)
    return {'fps_min': round(min(fps), 2), 'fps_max': round(max(fps), 2), 'jain': round(j['jain_index'], 3),
            'latency_p50_ms': round(j['latency_ms']['p50']), 'latency_p99_ms': round(j['latency_ms']['p99']),
            'render_ms_p50': round(j['render_ms_p50'], 1), 'encode_ms_mean': round(enc, 1),
            'bytes_per_frame': round(j['payload_bytes_per_frame']), 'video_frames': frames,
            'scaled_frames': v['scaled_frames'], 'size_key_frames': v['key_frames']['size'],
            'drawn_scale_p50': (j.get('drawn_scale') or {}).get('p50', ''),
            'sent_scale_p50': (j.get('sent_scale') or {}).get('p50', ''), 'errors': j['errors']}


def median_of(rows, column, value, key):
    """The median of `key` over the rows whose `column` is `value`."""
    return statistics.median(r[key] for r in rows if r[column] == value)


def range_of(rows, column, value, key):
    """`key`'s range over those rows, 'lo–hi' (one value where they agree)."""
    vals = [r[key] for r in rows if r[column] == value]
    return f'{min(vals)}–{max(vals)}' if min(vals) != max(vals) else f'{vals[0]}'


def write_rows(path, rows):
    """`rows` (dicts with the same keys) as a CSV file with a header line."""
    with open(path, 'w', newline='') as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
