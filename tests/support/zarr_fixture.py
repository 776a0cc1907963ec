#!/usr/bin/python3
"""Writes an OME-Zarr (OME-NGFF 0.4 multiscales over Zarr v2) with Debian's python3-zarr, for the Zarr tests and
bench/run_zarr.sh. One argument: a JSON object (see `spec` below). Level m is level 0 taken every 2^m voxels (not
averaged, so a reader that uses the file's own levels can be told from one that averages); chunks that hold only the
fill value are not written (write_empty_chunks=False), so the volume has missing chunks. With "dump": PATH, also writes
level 0's voxels at time 0 and channel 0, as written, to PATH: little-endian float64 (exact for every dtype here),
x fastest, then y, then z, so that a test can compare what a reader decodes with the array itself."""
import json
import sys

import numcodecs
import numpy as np
import zarr


def volume(shape, dtype, t, c, pattern, zs, step):
    """Level-0 voxels at z indices `zs` and every `step` voxel along y and x."""
    lin = [np.linspace(-1, 1, n) for n in shape]
    z, y, x = np.meshgrid(lin[0][zs], lin[1][::step], lin[2][::step], indexing="ij")
    if pattern == "noise":
        rng = np.random.default_rng([1 + t * 7 + c, int(zs[0]), step])
        v = rng.random(z.shape) * 200
    else:  # a ball off centre, with ripples, zero outside: the corners' chunks are empty
        r2 = (x - 0.2) ** 2 + (y + 0.1) ** 2 + (z - 0.15) ** 2
        v = np.where(r2 < 0.5, (1.0 - r2) * 900 + 60 * np.sin(9 * x) * np.cos(7 * y) + 50 + 100 * t + 30 * c, 0.0)
    if np.dtype(dtype).kind in "ui":
        info = np.iinfo(dtype)
        v = np.clip(np.rint(v), max(info.min, -30000), min(info.max, 60000))
    return v.astype(dtype)


def compressor(spec):
    if spec is None or spec.get("id") == "none":
        return None
    kind = spec["id"]
    if kind == "blosc":
        return numcodecs.Blosc(cname=spec.get("cname", "lz4"), clevel=spec.get("clevel", 5),
                               shuffle=spec.get("shuffle", 1))
    if kind == "zstd":
        return numcodecs.Zstd(level=spec.get("level", 3))
    if kind == "zlib":
        return numcodecs.Zlib(level=spec.get("level", 5))
    if kind == "gzip":
        return numcodecs.GZip(level=spec.get("level", 5))
    raise SystemExit("unknown compressor " + kind)


def main():
    spec = json.loads(sys.argv[1])
    shape = spec.get("shape", [40, 36, 44])  # z, y, x
    dtype = spec.get("dtype", "<u2")
    axes = spec.get("axes", "zyx")
    times, channels = spec.get("t", 1), spec.get("c", 1)
    levels = spec.get("levels", 1)
    chunks = spec.get("chunks", [16, 16, 16])
    scale = spec.get("scale", [1.0, 1.0, 1.0])
    translation = spec.get("translation", [0.0, 0.0, 0.0])
    fill = spec.get("fill", 0)
    store = zarr.DirectoryStore(spec["out"], dimension_separator=spec.get("separator", "."))
    root = zarr.group(store=store, overwrite=True)
    datasets = []
    dump = []  # level 0's slabs at time 0 and channel 0
    for m in range(levels):
        step = 2 ** m
        level_shape = [(n + step - 1) // step for n in shape]
        lead = [times if a == "t" else channels for a in axes[:-3]]
        arr = root.create_dataset(str(m), shape=lead + level_shape, chunks=spec.get("lead_chunks", [1] * len(lead)) + chunks, dtype=dtype,
                                  compressor=compressor(spec.get("compressor")), order=spec.get("order", "C"),
                                  fill_value=fill, write_empty_chunks=False, overwrite=True)
        zs = np.arange(0, shape[0], step)
        slab = chunks[0] * max(1, 16 // chunks[0])  # whole chunks along z, a bounded slab in memory
        for t in range(times):
            for c in range(channels):
                index = tuple(t if a == "t" else c for a in axes[:-3])
                for z0 in range(0, len(zs), slab):
                    v = volume(shape, dtype, t, c, spec.get("pattern", "ball"), zs[z0:z0 + slab], step)
                    arr[index + (slice(z0, z0 + len(v)),)] = v
                    if m == 0 and t == 0 and c == 0:
                        dump.append(v)
        s = [1.0] * len(lead) + [f * step for f in scale]
        tr = [0.0] * len(lead) + translation
        datasets.append({"path": str(m), "coordinateTransformations": [{"type": "scale", "scale": s},
                                                                       {"type": "translation", "translation": tr}]})
    if "dump" in spec:
        np.concatenate(dump).astype("<f8").tofile(spec["dump"])
    kinds = {"t": "time", "c": "channel", "z": "space", "y": "space", "x": "space"}
    root.attrs["multiscales"] = [{"version": "0.4", "name": "fixture", "datasets": datasets,
                                  "axes": [{"name": a, "type": kinds[a], **({"unit": "micrometer"}
                                            if kinds[a] == "space" else {})} for a in axes]}]


if __name__ == "__main__":
    main()
