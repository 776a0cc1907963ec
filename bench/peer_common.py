"""What the peer benchmarks share (bench/vtk_peer.py for grids, bench/vtk_tet_peer.py for tetrahedral meshes): a
PNG writer without dependencies, the --voxbrick setting parser, running voxbrick, medians and dB formatting."""

import json
import os
import statistics
import struct
import subprocess
import sys
import zlib

import numpy as np


def write_png(path, rgb):
    """8-bit RGB PNG of an (h, w, 3) uint8 array, row 0 at the top."""
    rgb = np.ascontiguousarray(rgb, dtype=np.uint8)
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def split_top_level(text, sep=","):
    """Splits on `sep` outside brackets, braces and double quotes."""
    items, depth, quoted, cur = [], 0, False, ""
    for ch in text:
        if ch == '"':
            quoted = not quoted
        elif not quoted and ch in "[{":
            depth += 1
        elif not quoted and ch in "]}":
            depth -= 1
        if ch == sep and depth == 0 and not quoted:
            items.append(cur)
            cur = ""
        else:
            cur += ch
    items.append(cur)
    return [i.strip() for i in items if i.strip()]


def merge(base, extra):
    out = json.loads(json.dumps(base))
    for k, v in extra.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = merge(out[k], v)
        else:
            out[k] = v
    return out


def median(values):
    return statistics.median(values) if values else float("nan")


def fmt_db(x):
    return "inf" if x == float("inf") else ("—" if x != x else f"{x:.1f}")


def parse_fragment(text, boolean_keys=frozenset()):
    """A --voxbrick value: 'k=v,k2=v2' (v parsed as JSON when it is JSON, else a string; 'a.b=v' nests; 1 and 0 are
    true and false for the keys of `boolean_keys`) or a JSON object. Returns the dict to merge into the scene."""
    text = text.strip()
    if text.startswith("{"):
        obj = json.loads(text)
        if not isinstance(obj, dict):
            raise ValueError(f"--voxbrick {text!r}: not a JSON object")
        return obj
    out = {}
    for item in split_top_level(text):
        if "=" not in item:
            raise ValueError(f"--voxbrick {text!r}: '{item}' is not key=value")
        key, value = (s.strip() for s in item.split("=", 1))
        try:
            parsed = json.loads(value)
        except json.JSONDecodeError:
            parsed = value
        if key in boolean_keys and parsed in (0, 1) and not isinstance(parsed, bool):
            parsed = bool(parsed)
        node = out
        parts = key.split(".")
        for p in parts[:-1]:
            node = node.setdefault(p, {})
        node[parts[-1]] = parsed
    return out


def run(cmd, **kw):
    """Runs cmd, returning its output as UTF-8 text whatever the locale (voxbrick prints non-ASCII characters); a
    failure ends the script with the command, its exit status and the end of its error output."""
    try:
        return subprocess.run(cmd, check=True, capture_output=True, encoding="utf-8", errors="replace", **kw)
    except subprocess.CalledProcessError as e:
        sys.exit(f"{os.path.basename(sys.argv[0])}: {' '.join(cmd)} failed (exit {e.returncode}):\n{(e.stderr or '')[-2000:]}")


def volume_property(vtk, tf, window, reference_length):
    """voxbrick's transfer function as a vtkVolumeProperty: control points at raw values lo + x (hi - lo) of the
    window, straight colours, alpha as opacity per `reference_length` (SetScalarOpacityUnitDistance), linear
    interpolation, no shading. `vtk` is the imported module (the peers import it only once they run)."""
    lo, hi = window
    ctf, otf = vtk.vtkColorTransferFunction(), vtk.vtkPiecewiseFunction()
    ctf.SetColorSpaceToRGB()
    ctf.ClampingOn()
    otf.ClampingOn()
    points = tf["points"]
    for i, (x, r, g, b, a) in enumerate(points):
        v = lo + x * (hi - lo)
        # Two points at one x make a step whose value at x is the later point's: move the earlier one left.
        if i + 1 < len(points) and points[i + 1][0] == x:
            v -= 1e-6 * (hi - lo)
        ctf.AddRGBPoint(v, r, g, b)
        otf.AddPoint(v, a)
    prop = vtk.vtkVolumeProperty()
    prop.SetColor(ctf)
    prop.SetScalarOpacity(otf)
    prop.SetScalarOpacityUnitDistance(reference_length)
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOff()
    prop.SetIndependentComponents(1)
    return prop


def offscreen_window(vtk, mapper, prop, width, height):
    """A volume of `mapper` with `prop` in an offscreen render window of width x height, black background, no
    multisampling, rendered as a still frame (never VTK's interactive settings). Returns (window, renderer)."""
    vol = vtk.vtkVolume()
    vol.SetMapper(mapper)
    vol.SetProperty(prop)
    ren = vtk.vtkRenderer()
    ren.SetBackground(0, 0, 0)
    ren.AddVolume(vol)
    rw = vtk.vtkRenderWindow()
    rw.SetOffScreenRendering(1)
    rw.SetMultiSamples(0)
    rw.SetSize(width, height)
    rw.AddRenderer(ren)
    rw.SetDesiredUpdateRate(1e-4)
    return rw, ren


def gl_description(rw):
    """The renderer and version strings of a render window's GL context (after a Render())."""
    caps = rw.ReportCapabilities() or ""
    gl = [l.split(":", 1)[1].strip() for l in caps.splitlines()
          if l.startswith("OpenGL renderer string") or l.startswith("OpenGL version string")]
    return ", ".join(gl)
