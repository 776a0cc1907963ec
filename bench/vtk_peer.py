#!/usr/bin/python3
"""Peer benchmark: the same scene rendered by VTK (vtkFixedPointVolumeRayCastMapper, vtkGPUVolumeRayCastMapper)
and by voxbrick, every frame judged against voxbrick's CPU reference renderer.

Normally started by bench/run_vtk_peer.sh (which installs VTK, preps the store and provides an X server through
xvfb-run); see bench/README.md, "Peer: VTK". Needs Debian's python3-vtk9 and python3-numpy (/usr/bin/python3).

Geometry, as voxbrick defines it (render/core/Camera.cpp volumeBox, render/reference/ReferenceRenderer.cpp):
  - the volume's world box is dims * spacing, centred on the origin; voxel (i, j, k) of the raw grid (i fastest, as
    stored in the file; no qform/sform) has its centre at ((i, j, k) + 0.5 - dims / 2) * spacing, i along x, j along
    y, k along z. VTK places point samples at origin + index * spacing, so the image's origin is
    (0.5 - dims / 2) * spacing: voxel centres coincide. (VTK's box then ends at the outermost voxel centres, half
    a voxel inside voxbrick's; voxbrick clamps to the edge there.)
  - orbit camera: eye = centre + dist * R * (cos el sin az, sin el, cos el cos az), R = |dims * spacing| / 2, looking
    at the origin, up +Y, vertical field of view fov, perspective.
  - transfer function: piecewise linear over x = (value - lo) / (hi - lo), [lo, hi] the store's value range unless
    a window is given; colours straight; alpha per reference length (default the smallest spacing);
    alpha_step = 1 - (1 - alpha)^(step / reference). In VTK: control points at raw values lo + x (hi - lo),
    SetScalarOpacityUnitDistance(reference length), sample distance = step * smallest spacing (world units).
"""

import argparse
import csv
import datetime
import gzip
import hashlib
import json
import os
import platform
import shutil
import struct
import sys
import time

import numpy as np

from peer_common import (fmt_db, gl_description, median, merge, offscreen_window, parse_fragment, run,
                         split_top_level, volume_property, write_png)

# Keys of a voxbrick scene that define the picture rather than how voxbrick renders it: they are set by this
# script's own options (the same for every renderer), so a --voxbrick fragment may not change them.
SCENE_KEYS = {"camera", "size", "transfer_function", "background", "window", "shading"}
VOXBRICK_DEFAULT_STEP = 0.75  # render/core/Scene.h Scene::step
# Scene keys that take true or false (render/core/Scene.cpp), which a setting may also give as 1 or 0 ('raycast=1').
BOOLEAN_KEYS = {"skip_empty", "cull", "raycast", "pre_integration", "ess", "progressive"}
RAYCAST_LABEL = "VTK FixedPoint (its ray-cast image)"


# ---------------------------------------------------------------------------------------------------------------
# Small helpers


def log(msg):
    print(f"[vtk_peer {time.strftime('%H:%M:%S')}] {msg}", flush=True)


# ---------------------------------------------------------------------------------------------------------------
# The volume, exactly as voxbrick's prep reads it


NIFTI_TYPES = {2: np.uint8, 4: np.int16, 8: np.int32, 16: np.float32, 64: np.float64, 256: np.int8,
               512: np.uint16, 768: np.uint32}


def read_nifti(path):
    """NIfTI-1 single file (.nii or .nii.gz): raw voxel grid (x fastest), scl_slope/inter applied as prep does."""
    data = gzip.open(path).read() if path.endswith(".gz") else open(path, "rb").read()
    e = "<" if struct.unpack("<i", data[0:4])[0] == 348 else ">"
    if struct.unpack(e + "i", data[0:4])[0] != 348:
        raise ValueError(f"{path}: not a NIfTI-1 file")
    dim = struct.unpack(e + "8h", data[40:56])
    datatype = struct.unpack(e + "h", data[70:72])[0]
    pixdim = struct.unpack(e + "8f", data[76:108])
    vox_offset = int(struct.unpack(e + "f", data[108:112])[0])
    slope, inter = struct.unpack(e + "2f", data[112:120])
    if datatype not in NIFTI_TYPES:
        raise ValueError(f"{path}: NIfTI datatype {datatype} not supported here")
    dims = [int(d) for d in dim[1:4]]
    n = dims[0] * dims[1] * dims[2]
    dt = np.dtype(NIFTI_TYPES[datatype]).newbyteorder(e)
    vox = np.frombuffer(data, dtype=dt, count=n, offset=vox_offset).astype(dt.newbyteorder("="))
    if np.isfinite(slope) and slope != 0 and (slope != 1 or inter != 0):
        vox = vox.astype(np.float32) * np.float32(slope) + np.float32(inter)
    if vox.dtype in (np.int8,):
        vox = vox.astype(np.int16)
    elif vox.dtype in (np.int32, np.uint32, np.float64):
        vox = vox.astype(np.float32)
    return vox, dims, [abs(float(p)) for p in pixdim[1:4]]


def read_raw(path, dims, store_type, header_bytes=0):
    dtype = {"u8": np.uint8, "u16": np.uint16, "i16": np.int16, "f32": np.float32}[store_type]
    return np.fromfile(path, dtype=dtype, offset=header_bytes, count=dims[0] * dims[1] * dims[2]), dims, None


# ---------------------------------------------------------------------------------------------------------------
# voxbrick


class Voxbrick:
    def __init__(self, binary, store, frames_dir):
        self.bin, self.store, self.frames = binary, store, frames_dir
        self.info = json.loads(run([binary, "info", store, "--json"]).stdout)
        self.description = None

    def render(self, scene, png, stats_json, reference_step=None, scene_path=None):
        scene_path = scene_path or png[:-4] + ".scene.json"
        with open(scene_path, "w") as f:
            json.dump(scene, f, indent=1)
        cmd = [self.bin, "render", self.store, "--scene", scene_path, "-o", png, "--stats", stats_json]
        if reference_step is not None:
            cmd += ["--backend", "reference", "--reference-step", str(reference_step)]
        else:
            cmd += ["--warm-up", "1"]  # the timed frame is a warm one, as VTK's is
        t0 = time.perf_counter()
        p = run(cmd)
        wall = (time.perf_counter() - t0) * 1e3
        for line in p.stderr.splitlines():
            if line.startswith("render: ") and self.description is None and reference_step is None:
                self.description = line[len("render: "):].strip()
        with open(stats_json) as f:
            return json.load(f), wall

    def compare(self, a, b, heatmap=None):
        cmd = [self.bin, "compare", "--json", a, b]
        if heatmap:
            cmd += ["--heatmap", heatmap]
        r = json.loads(run(cmd).stdout)
        psnr = r.get("psnr")
        return (float("inf") if psnr is None else float(psnr)), float(r["rmse"]), float(r["max_abs"])


# ---------------------------------------------------------------------------------------------------------------
# VTK


class VtkPeer:
    """One offscreen render window per mapper, sharing one vtkImageData and one vtkVolumeProperty."""

    def __init__(self, vox, dims, spacing, tf, window, reference_length, width, height, log_file, pad=True):
        import vtk
        from vtkmodules.util import numpy_support

        self.vtk = vtk
        self.np_support = numpy_support
        out = vtk.vtkFileOutputWindow()
        out.SetFileName(log_file)
        out.SetFlush(1)
        vtk.vtkOutputWindow.SetInstance(out)
        self.log_file = log_file
        self.width, self.height = width, height

        # VTK's volume ends at the outermost voxel centres, half a voxel inside voxbrick's box, where voxbrick
        # clamps to the edge. With `pad`, one layer of edge voxels is added on every side (the same clamp-to-edge
        # values under trilinear interpolation) and both mappers crop to voxbrick's box exactly.
        grid = vox.reshape(dims[2], dims[1], dims[0])
        if pad:
            grid = np.pad(grid, 1, mode="edge")
        vdims = [grid.shape[2], grid.shape[1], grid.shape[0]]
        border = 1 if pad else 0
        img = vtk.vtkImageData()
        img.SetDimensions(*vdims)
        img.SetSpacing(*spacing)
        img.SetOrigin(*[(0.5 - 0.5 * dims[a] - border) * spacing[a] for a in range(3)])
        self.crop = None
        if pad:
            self.crop = [v for a in range(3) for v in (-0.5 * dims[a] * spacing[a], 0.5 * dims[a] * spacing[a])]
        self.scalars = numpy_support.numpy_to_vtk(np.ascontiguousarray(grid).ravel(), deep=1)
        self.scalars.SetName("scalars")
        img.GetPointData().SetScalars(self.scalars)
        self.image = img

        self.prop = volume_property(vtk, tf, window, reference_length)
        self.windows = {}

    def _window(self, kind):
        if kind in self.windows:
            return self.windows[kind]
        vtk = self.vtk
        if kind == "fixed":
            m = vtk.vtkFixedPointVolumeRayCastMapper()
            m.SetIntermixIntersectingGeometry(0)  # nothing to intermix; skips reading the depth buffer
            m.SetLockSampleDistanceToInputSpacing(0)
        else:
            m = vtk.vtkGPUVolumeRayCastMapper()
            m.SetUseJittering(0)
            m.SetLockSampleDistanceToInputSpacing(0)
        m.SetInputData(self.image)
        if self.crop:
            m.SetCroppingRegionPlanes(*self.crop)
            m.SetCroppingRegionFlagsToSubVolume()
            m.CroppingOn()
        m.SetBlendModeToComposite()
        m.SetAutoAdjustSampleDistances(0)
        m.SetImageSampleDistance(1.0)
        rw, ren = offscreen_window(vtk, m, self.prop, self.width, self.height)
        self.windows[kind] = (rw, ren, m)
        return self.windows[kind]

    def describe(self, kind):
        rw, _, m = self._window(kind)
        rw.Render()
        d = {"gl": gl_description(rw)}
        if kind == "fixed":
            d["threads"] = m.GetNumberOfThreads()
        else:
            d["supported"] = bool(m.IsRenderSupported(rw, self.prop))
        return d

    def set_view(self, kind, eye, center, up, fov, orthographic, step_world):
        rw, ren, m = self._window(kind)
        m.SetSampleDistance(step_world)
        if kind == "fixed":
            m.SetInteractiveSampleDistance(step_world)
            m.SetMinimumImageSampleDistance(1.0)
            m.SetMaximumImageSampleDistance(1.0)
        cam = ren.GetActiveCamera()
        cam.SetPosition(*eye)
        cam.SetFocalPoint(*center)
        cam.SetViewUp(*up)
        cam.SetViewAngle(fov)
        cam.SetParallelProjection(1 if orthographic else 0)
        if orthographic:
            cam.SetParallelScale(np.linalg.norm(np.subtract(center, eye)) * np.tan(np.radians(fov) / 2))
        ren.ResetCameraClippingRange()

    def frame(self, kind):
        """Render + read back into memory; returns (ms, (h, w, 3) uint8 with row 0 at the top)."""
        rw, _, _ = self._window(kind)
        arr = self.vtk.vtkUnsignedCharArray()
        t0 = time.perf_counter()
        rw.Render()
        rw.GetPixelData(0, 0, self.width - 1, self.height - 1, 1, arr, 0)
        ms = (time.perf_counter() - t0) * 1e3
        rgb = self.np_support.vtk_to_numpy(arr).reshape(self.height, self.width, 3)[::-1]
        return ms, rgb

    def raycast_image(self):
        """The FixedPoint mapper's own ray-cast image of the last frame, placed on the window's pixels (row 0 at the
        top), without the display step: vtkOpenGLRayCastImageDisplayHelper draws the N texels of that image over N
        pixels with texture coordinates from the first to the last texel *centre*, so the window shows it stretched
        by one pixel and linearly resampled (up to half a pixel at the edges of its in-use rectangle)."""
        import ctypes
        _, _, m = self._window("fixed")
        img = m.GetRayCastImage()
        mem, view = img.GetImageMemorySize(), img.GetImageViewportSize()
        use, origin = img.GetImageInUseSize(), img.GetImageOrigin()
        pointer = img.GetImage()  # '_<hex address>_p_void'
        address = int(pointer[1:pointer.index("_p_")], 16)
        buf = np.ctypeslib.as_array((ctypes.c_uint16 * (mem[0] * mem[1] * 4)).from_address(address))
        buf = buf.reshape(mem[1], mem[0], 4)[:use[1], :use[0], :3].astype(np.float64)
        out = np.zeros((view[1], view[0], 3))
        out[origin[1]:origin[1] + use[1], origin[0]:origin[0] + use[0]] = buf
        # 15-bit fixed point (VTKKW_FP_SCALE 32767), premultiplied; the display helper scales by 2 / 65535.
        return np.clip(np.rint(out * (2.0 / 65535.0) * 255.0), 0, 255).astype(np.uint8)[::-1]

    def errors(self):
        try:
            with open(self.log_file, errors="replace") as f:
                return [l.strip() for l in f if "ERROR" in l or "Error" in l]
        except OSError:
            return []


# ---------------------------------------------------------------------------------------------------------------


def orbit_camera(az, el, dist, dims, spacing):
    extent = np.array(dims, float) * np.array(spacing, float)
    radius = 0.5 * np.linalg.norm(extent)
    a, e = np.radians(az), np.radians(el)
    direction = np.array([np.cos(e) * np.sin(a), np.sin(e), np.cos(e) * np.cos(a)])
    return list(dist * radius * direction), [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--voxbrick-bin", default="build/voxbrick")
    ap.add_argument("--store", required=True, help="store directory made by voxbrick prep from --volume")
    ap.add_argument("--volume", required=True, help=".nii/.nii.gz (or raw with --raw) that the store was made from")
    ap.add_argument("--raw", action="store_true", help="--volume is raw voxels of the store's dims and type")
    ap.add_argument("--raw-header-bytes", type=int, default=0)
    ap.add_argument("--work", required=True, help="frames, reference cache, logs")
    ap.add_argument("--out", required=True, help="peer-vtk.csv and peer-vtk.md go here")
    ap.add_argument("--name", default="peer-vtk")
    ap.add_argument("--views", type=int, default=8, help="azimuths 0, 360/N, ...")
    ap.add_argument("--elevation", type=float, default=20)
    ap.add_argument("--distance", type=float, default=2.2, help="bounding-sphere radii")
    ap.add_argument("--fov", type=float, default=30)
    ap.add_argument("--size", default="512x512")
    ap.add_argument("--tf", default="mri", help="preset of config/tf or a JSON file")
    ap.add_argument("--config-dir", default="config")
    ap.add_argument("--window", default=None, help="LO,HI (default the store's value range)")
    ap.add_argument("--voxbrick", action="append", default=[],
                    help="a voxbrick setting: comma list of key=value merged into the scene JSON (repeatable), e.g. "
                         "step=0.5,raycast=1")
    ap.add_argument("--vtk-steps", default=None, help="VTK steps in voxels (default: the voxbrick settings' steps)")
    ap.add_argument("--mappers", default="fixed,gpu")
    ap.add_argument("--no-pad", action="store_true",
                    help="give VTK the bare grid (its box then ends at the outer voxel centres) instead of one padded "
                         "layer of edge voxels cropped to voxbrick's box")
    ap.add_argument("--repeats", type=int, default=1, help="timed frames per view after the warm-up")
    ap.add_argument("--reference-step", type=float, default=0.125)
    ap.add_argument("--heatmaps", type=int, default=1, help="write heat maps for the first N views")
    ap.add_argument("--command", default=None, help="the command line to quote in the report")
    ap.add_argument("--voxbrick-source", default=None, help="where --voxbrick-bin was copied from (for the report)")
    args = ap.parse_args()

    started = time.time()
    load_start = os.getloadavg()
    width, height = (int(v) for v in args.size.lower().split("x"))
    os.makedirs(args.work, exist_ok=True)
    os.makedirs(args.out, exist_ok=True)
    tf_label = os.path.splitext(os.path.basename(args.tf))[0]
    frames_dir = os.path.join(args.work, "frames", f"{args.name}-{tf_label}")
    ref_dir = os.path.join(args.work, "reference")
    os.makedirs(frames_dir, exist_ok=True)
    for old in os.listdir(frames_dir):  # this run's frames only
        os.remove(os.path.join(frames_dir, old))
    os.makedirs(ref_dir, exist_ok=True)

    vb = Voxbrick(args.voxbrick_bin, args.store, frames_dir)
    info = vb.info
    dims, spacing = [int(d) for d in info["dims"]], [float(s) for s in info["spacing"]]
    value_range = [float(v) for v in info["value_range"]]
    window = [float(v) for v in args.window.split(",")] if args.window else value_range
    if not window[1] > window[0]:
        window = [window[0], window[0] + 1]  # render/volume/FramePlan.cpp valueWindow: a constant volume

    # The transfer function, inline in every scene (the reference cache key then covers its content).
    tf_path = args.tf if (args.tf.endswith(".json") or "/" in args.tf) else os.path.join(
        args.config_dir, "tf", args.tf + ".json")
    with open(tf_path) as f:
        tf = json.load(f)
    min_spacing = min(spacing)
    reference_length = float(tf.get("reference_length", min_spacing))

    # The volume VTK renders: the same voxels as the store, checked against it.
    if args.raw:
        vox, vdims, _ = read_raw(args.volume, dims, info["type"], args.raw_header_bytes)
    else:
        vox, vdims, _ = read_nifti(args.volume)
    if list(vdims) != dims:
        sys.exit(f"vtk_peer: {args.volume} has dims {vdims}, the store {dims}")
    vmin, vmax = float(vox.min()), float(vox.max())
    if abs(vmin - value_range[0]) > 1e-6 * max(1, abs(vmin)) or abs(vmax - value_range[1]) > 1e-6 * max(1, abs(vmax)):
        sys.exit(f"vtk_peer: {args.volume} has values {vmin}..{vmax}, the store {value_range}: not the same volume")

    # Settings.
    settings = []
    for text in args.voxbrick or ["step=0.75"]:
        frag = parse_fragment(text, BOOLEAN_KEYS)
        bad = SCENE_KEYS & set(frag)
        if bad:
            sys.exit(f"vtk_peer: --voxbrick {text!r} sets {sorted(bad)}: these define the scene (the same for every "
                     "renderer), use this script's options instead")
        settings.append((text, frag))
    if args.vtk_steps:
        vtk_steps = [float(s) for s in args.vtk_steps.split(",")]
    else:
        vtk_steps = sorted({float(f.get("step", VOXBRICK_DEFAULT_STEP)) for _, f in settings}, reverse=True)
    mappers = [m for m in args.mappers.split(",") if m]

    views = [i * 360.0 / args.views for i in range(args.views)]
    base_scene = {"size": [width, height], "transfer_function": tf, "background": [0, 0, 0], "shading": False}
    if args.window:
        base_scene["window"] = window

    def scene_for(az):
        # The orbit as orbit_camera places VTK's: up +Y (voxbrick's default up axis is +z).
        return merge(base_scene, {"camera": {"orbit": [az, args.elevation, args.distance], "fov": args.fov,
                                             "up_axis": "+y"}})

    # The store's identity for the cache: its metadata file.
    with open(os.path.join(args.store, "store.json"), "rb") as f:
        store_digest = hashlib.sha256(f.read()).hexdigest()

    # 1. References (cached by scene content, store and reference step).
    refs, ref_ms = {}, []
    for az in views:
        scene = scene_for(az)
        key = hashlib.sha256(json.dumps({"scene": scene, "store": store_digest, "reference_step": args.reference_step},
                                        sort_keys=True).encode()).hexdigest()[:16]
        png = os.path.join(ref_dir, f"ref-{key}.png")
        if not os.path.exists(png):
            log(f"reference az {az:g}: rendering (step {args.reference_step} voxels)")
            tmp = png[:-4] + ".tmp.png"
            stats, wall = vb.render(scene, tmp, png[:-4] + ".stats.json", reference_step=args.reference_step,
                                    scene_path=png[:-4] + ".scene.json")
            os.replace(tmp, png)
            ref_ms.append(wall)
            log(f"reference az {az:g}: {wall / 1e3:.1f} s")
        else:
            log(f"reference az {az:g}: cached {png}")
        refs[az] = png

    # 2. VTK set-up.
    vtk_log = os.path.join(args.work, "vtk-output.log")
    if os.path.exists(vtk_log):
        os.remove(vtk_log)
    peer = VtkPeer(vox, dims, spacing, tf, window, reference_length, width, height, vtk_log, pad=not args.no_pad)
    import vtk
    vtk_version = vtk.vtkVersion.GetVTKVersion()
    mapper_info, mapper_failed = {}, {}
    for m in mappers:
        try:
            mapper_info[m] = peer.describe(m)
            if m == "gpu" and not mapper_info[m].get("supported", True):
                mapper_failed[m] = "IsRenderSupported() is false on this OpenGL context"
        except Exception as e:  # noqa: BLE001 - any failure is recorded and the mapper skipped
            mapper_failed[m] = f"{type(e).__name__}: {e}"
    log(f"VTK {vtk_version}: {mapper_info} {mapper_failed or ''}")

    # 3. Frames, interleaved view by view so that drift of the shared machine falls on every renderer alike.
    rows = []
    mapper_label = {"fixed": "VTK FixedPoint", "gpu": "VTK GPU"}
    for vi, az in enumerate(views):
        cam_eye, cam_center, cam_up = orbit_camera(az, args.elevation, args.distance, dims, spacing)
        def run_voxbrick():
            for si, (text, frag) in enumerate(settings):
                scene = merge(scene_for(az), frag)
                png = os.path.join(frames_dir, f"voxbrick-s{si}-az{az:g}.png")
                stats, wall = vb.render(scene, png, png[:-4] + ".stats.json")
                ms = stats["ms"]
                phases = sum(v for k, v in ms.items() if k != "total")
                rows.append({"renderer": "voxbrick", "setting": text, "view": vi, "azimuth": az,
                             "ms": ms["total"], "ms_excl_paging": ms["total"] - ms.get("paging", 0.0),
                             "ms_unattributed": ms["total"] - phases, "process_ms": wall, "png": png})
                log(f"az {az:g} voxbrick [{text}]: {ms['total']:.0f} ms (paging {ms.get('paging', 0):.0f})")

        def run_vtk():
            for m in mappers:
                if m in mapper_failed:
                    continue
                for step in vtk_steps:
                    try:
                        peer.set_view(m, cam_eye, cam_center, cam_up, args.fov, False, step * min_spacing)
                        peer.frame(m)  # warm-up
                        times, rgb = [], None
                        for _ in range(args.repeats):
                            t, rgb = peer.frame(m)
                            times.append(t)
                    except Exception as e:  # noqa: BLE001
                        mapper_failed[m] = f"{type(e).__name__}: {e}"
                        break
                    if not rgb.any():
                        errs = peer.errors()
                        mapper_failed[m] = "blank frame" + (f"; VTK said: {errs[-1][:300]}" if errs else "")
                        break
                    png = os.path.join(frames_dir, f"vtk-{m}-step{step:g}-az{az:g}.png")
                    write_png(png, rgb)
                    rows.append({"renderer": mapper_label[m], "setting": f"step={step:g}", "view": vi, "azimuth": az,
                                 "ms": median(times), "ms_excl_paging": median(times), "process_ms": "", "png": png})
                    if m == "fixed":
                        png2 = os.path.join(frames_dir, f"vtk-fixed-raycast-step{step:g}-az{az:g}.png")
                        write_png(png2, peer.raycast_image())
                        rows.append({"renderer": RAYCAST_LABEL, "setting": f"step={step:g}", "view": vi,
                                     "azimuth": az, "ms": median(times), "ms_excl_paging": median(times),
                                     "process_ms": "", "png": png2})
                    log(f"az {az:g} {mapper_label[m]} step {step:g}: {median(times):.0f} ms")

        # Alternate the order view by view, so that neither side always runs first.
        for part in ((run_voxbrick, run_vtk) if vi % 2 == 0 else (run_vtk, run_voxbrick)):
            part()

    # 4. Accuracy against the reference (after all timing, so that compare never runs beside a timed frame).
    for r in rows:
        heat = None
        if r["view"] < args.heatmaps:
            heat = r["png"][:-4] + ".heat.png"
        r["psnr"], r["rmse"], r["max_abs"] = vb.compare(r["png"], refs[r["azimuth"]], heat)

    # 5. Output.
    csv_path = os.path.join(args.out, f"{args.name}.csv")
    with open(csv_path, "w") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["renderer", "setting", "view", "azimuth", "ms", "ms_excl_paging", "process_ms", "psnr_db",
                    "rmse", "max_abs"])
        for r in rows:
            w.writerow([r["renderer"], r["setting"], r["view"], f"{r['azimuth']:g}", f"{r['ms']:.1f}",
                        f"{r['ms_excl_paging']:.1f}", f"{r['process_ms']:.0f}" if r["process_ms"] != "" else "",
                        f"{r['psnr']:.2f}", f"{r['rmse']:.6f}", f"{r['max_abs']:.4f}"])

    groups = []
    for r in rows:
        k = (r["renderer"], r["setting"])
        if k not in groups:
            groups.append(k)

    def group_rows(k):
        return [r for r in rows if (r["renderer"], r["setting"]) == k]

    def step_of(k):
        if k[0] == "voxbrick":
            return float(dict(settings)[k[1]].get("step", VOXBRICK_DEFAULT_STEP))
        return float(k[1].split("=")[1])

    fixed_ms = {step_of(k): median([r["ms"] for r in group_rows(k)]) for k in groups if k[0] == "VTK FixedPoint"}

    def loads(values):
        return ", ".join(f"{x:.1f}" for x in values)

    unattributed = median([r["ms_unattributed"] for r in rows if r["renderer"] == "voxbrick"])
    lines = []
    cores = os.cpu_count()
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(l.split(":", 1)[1].strip() for l in f if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    fp = mapper_info.get("fixed", {})
    gpu = mapper_info.get("gpu", {})
    lines.append(f"# Peer: VTK — {args.name}")
    lines.append("")
    lines.append(f"Machine: {cores} cores ({cpu}); voxbrick's GL: {vb.description or '?'}; VTK {vtk_version} "
                 f"(python3-vtk9) under Xvfb, its GL: {gpu.get('gl') or fp.get('gl') or '?'}; "
                 f"FixedPoint threads: {fp.get('threads', '?')} (vtkMultiThreader default = cores). "
                 f"Load average (1, 5, 15 min) at the start: {loads(load_start)}, "
                 f"at the end: {loads(os.getloadavg())}.")
    lines.append("")
    lines.append(f"Command: `{args.command or ' '.join(sys.argv)}`")
    with open(args.voxbrick_bin, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()[:12]
    source = args.voxbrick_source or args.voxbrick_bin
    built = datetime.datetime.fromtimestamp(os.path.getmtime(args.voxbrick_bin)).strftime("%Y-%m-%d %H:%M")
    lines.append("")
    lines.append(f"voxbrick binary: `{source}` built {built} (sha256 {digest}…), run from a copy.")
    lines.append("")
    lines.append(f"Scene: `{os.path.basename(args.volume)}` {dims[0]}×{dims[1]}×{dims[2]}, spacing "
                 f"{'/'.join(f'{s:g}' for s in spacing)}, values {value_range[0]:g}…{value_range[1]:g}, "
                 f"transfer function `{args.tf}` over window [{window[0]:g}, {window[1]:g}], reference length "
                 f"{reference_length:g} (world), unshaded, black background, {width}×{height}, {args.views} views "
                 f"(azimuth 0…{views[-1]:g}°, elevation {args.elevation:g}°, {args.distance:g} R, fov "
                 f"{args.fov:g}°, perspective). Reference: `voxbrick render --backend reference` at "
                 f"{args.reference_step:g} voxel. Steps in voxels (1 voxel = {min_spacing:g} world units). "
                 f"{datetime.datetime.now().strftime('%Y-%m-%d %H:%M')}, {(time.time() - started) / 60:.1f} min.")
    lines.append("")
    lines.append("| renderer | setting | median ms | voxbrick: median ms excl. paging | worst view dB | median dB | "
                 "time / VTK FixedPoint (same step) |")
    lines.append("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    for k in groups:
        g = group_rows(k)
        ms = median([r["ms"] for r in g])
        ms_ex = median([r["ms_excl_paging"] for r in g])
        ps = [r["psnr"] for r in g]
        st = step_of(k)
        ratio = f"{ms / fixed_ms[st]:.2f}" if st in fixed_ms else f"— (no FixedPoint at step {st:g})"
        if k[0] == RAYCAST_LABEL:
            ratio = "(the same frames)"
        ex = f"{ms_ex:.0f}" if k[0] == "voxbrick" else ""
        lines.append(f"| {k[0]} | {k[1]} | {ms:.0f} | {ex} | {fmt_db(min(ps))} | {fmt_db(median(ps))} | {ratio} |")
    lines.append("")
    for m, why in mapper_failed.items():
        lines.append(f"- **{mapper_label[m]} failed**: {why}")
    lines.append("- VTK: per view one warm-up frame, then the timed frame(s) (`Render()` + `GetPixelData`, "
                 f"{args.repeats} per view, median); the table gives the median over the views.")
    lines.append("- voxbrick: one `voxbrick render --warm-up 1` process per view and setting: a warm-up frame (paging, "
                 "program builds), then the timed frame, whose `ms.total` (from `--stats`) is the time given; "
                 "\"excl. paging\" subtracts its `ms.paging` (what is left outside the listed phases: median "
                 f"{unattributed:.0f} ms).")
    lines.append(f"- `{RAYCAST_LABEL}`: the FixedPoint mapper's own image of the same timed frame, read from the "
                 "mapper (`GetRayCastImage()`) instead of the window. VTK draws that image into the window as a "
                 "texture whose coordinates run from the first to the last texel *centre* over the full pixel "
                 "rectangle (vtkOpenGLRayCastImageDisplayHelper), i.e. stretched by one pixel and resampled "
                 "bilinearly; the window's frame is what a VTK user gets, the ray-cast image isolates the mapper's "
                 "sampling and compositing from that display step.")
    lines.append("- VTK renders the same voxels (read from the NIfTI file, checked against the store's dims and value "
                 "range), voxel centres placed where voxbrick places them; "
                 + ("bare grid (its box ends at the outer voxel centres)." if args.no_pad else
                    "with one layer of edge voxels added and cropping to voxbrick's box (clamp-to-edge, as voxbrick)."))
    lines.append(f"- Renderers are interleaved view by view (order alternating). Frames, heat maps (first "
                 f"{args.heatmaps} view(s)) and references are in `{args.work}`.")
    md_path = os.path.join(args.out, f"{args.name}.md")
    with open(md_path, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    log(f"wrote {csv_path} and {md_path} in {(time.time() - started) / 60:.1f} min")


if __name__ == "__main__":
    main()
