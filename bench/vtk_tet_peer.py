#!/usr/bin/python3
"""Peer benchmark for tetrahedral meshes: the same mesh, camera, transfer function and image size rendered by VTK's
vtkProjectedTetrahedraMapper and vtkUnstructuredGridVolumeRayCastMapper and by voxbrick, every frame judged against
voxbrick's CPU reference renderer (`voxbrick render --backend reference`).

Normally started by bench/run_tet_peer.sh (which installs VTK and gmsh, makes the meshes with
bench/make_tet_meshes.py, preps the store and provides an X server through xvfb-run); see bench/README.md, "Peer: VTK,
tetrahedral meshes". Needs Debian's python3-vtk9 and python3-numpy (/usr/bin/python3).

Both sides read the same file: --mesh, a VTK legacy UNSTRUCTURED_GRID of tetrahedra with a point scalar, which VTK
reads with vtkUnstructuredGridReader and `voxbrick prep` turned into --store. The script checks the store against
the file (tet and point counts, bounds, value range, reference length from `voxbrick info --json`) before rendering.

Geometry and optics, as voxbrick defines them for a mesh (render/tets/TetMeshSource.cpp, render/core/Camera.cpp):
  - mesh coordinates are used as they are (no re-centring, no scaling). The box is the points' axis-aligned bounds,
    its centre c = (min + max) / 2, its radius R = |max - min| / 2 (half the diagonal).
  - orbit camera: eye = c + dist * R * (cos el sin az, sin el, cos el cos az), looking at c, up +Y, vertical field of
    view fov, perspective. In VTK: vtkCamera position, focal point, view up and view angle set to exactly these,
    clipping range from ResetCameraClippingRange (the whole mesh lies between the planes).
  - transfer function (config/tf/*.json): piecewise linear over x = (value - lo) / (hi - lo), [lo, hi] the mesh's
    scalar range unless --window; colours straight (not premultiplied); alpha is the opacity of a segment of the
    reference length L, i.e. an extinction of -ln(1 - alpha) / L per world unit. L defaults to the MEAN EDGE LENGTH
    of the mesh (every tet's six edges, shared edges counted once per tet; render/tets/TetMeshSource.cpp) unless the preset
    gives "reference_length". In VTK: colour and opacity control points at raw values lo + x (hi - lo) (two points
    at one x, a step, are split by 1e-6 of the window), clamping on, RGB colour space, SetScalarOpacityUnitDistance(L)
    (the same convention: opacity per L), linear interpolation, shading off, black background.
  - image: W x H pixels, the window's frame read back with GetPixelData (RGB, row 0 at the top once flipped).

The two VTK mappers as configured here:
  - vtkProjectedTetrahedraMapper (Shirley-Tuchman projected tetrahedra, the OpenGL2 implementation): its default
    visibility sort (vtkCellCenterDepthSort: cells by centroid depth, back to front, re-sorted every frame) and its
    default floating-point frame buffer. Colours and opacities are classified at the vertices (8 bits each) and
    interpolated over each tet's projected triangles, the thickness turned into opacity with L.
  - vtkUnstructuredGridVolumeRayCastMapper (Bunyk ray-cast function, one ray per pixel: ImageSampleDistance 1,
    AutoAdjustSampleDistances off, IntermixIntersectingGeometry off, vtkMultiThreader's default thread count = cores)
    with the ray integrator(s) of --integrators: 'pre' vtkUnstructuredGridPreIntegration (what VTK picks itself for
    point scalars with independent components: a table over front value, back value and length), 'partial'
    vtkUnstructuredGridPartialPreIntegration (Moreland and Angel: exact for piecewise-linear transfer functions),
    'linear' vtkUnstructuredGridLinearRayIntegrator (integrates each segment of the piecewise-linear function),
    'homogeneous' vtkUnstructuredGridHomogeneousRayIntegrator (one value per segment). Its image is drawn into the
    window by VTK's ray-cast display helper, stretched by one pixel (texture coordinates from the first to the last
    texel centre) and resampled bilinearly: that frame is what a VTK user gets. The mapper's own image of the same
    frame (read from the object, see VtkTetPeer.raycast_image) is judged too, as "its ray-cast image".

The issue's criterion, in the summary: voxbrick's median time at most half the projected-tetrahedra mapper's median
time, and its median PSNR at least the ray-cast mapper's (the first of --integrators), taking the better of that
mapper's window frame and its own ray-cast image.

Timing: per view and renderer one warm-up frame (discarded: sorting structures, textures, shaders, the Bunyk
mapper's face tables), then --repeats timed frames (Render() + GetPixelData), median. voxbrick: one
`voxbrick render --warm-up 1` process per view and setting, its timed frame's `ms.total` from --stats. Renderers are
interleaved view by view, the order alternating, so that drift of a shared machine falls on all alike.

--vtk-only renders and times the VTK side alone (no store, no voxbrick): frames and times are written, and each
frame is judged against the first ray-cast frame instead of a voxbrick reference (labelled so).
"""

import argparse
import csv
import datetime
import hashlib
import json
import os
import platform
import struct
import subprocess
import sys
import time

import numpy as np

from peer_common import (fmt_db, gl_description, median, merge, offscreen_window, parse_fragment, run,
                         split_top_level, volume_property, write_png)

# Keys of a voxbrick scene that define the picture (set by this script's options, the same for every renderer).
SCENE_KEYS = {"camera", "size", "transfer_function", "background", "window", "shading"}
BOOLEAN_KEYS = {"skip_empty", "cull", "raycast", "pre_integration", "ess", "progressive"}
INTEGRATORS = {
    "pre": "vtkUnstructuredGridPreIntegration",
    "partial": "vtkUnstructuredGridPartialPreIntegration",
    "linear": "vtkUnstructuredGridLinearRayIntegrator",
    "homogeneous": "vtkUnstructuredGridHomogeneousRayIntegrator",
}
PT_LABEL = "VTK ProjectedTetrahedra"
RC_LABEL = "VTK UGridRayCast"
RC_IMAGE_LABEL = "VTK UGridRayCast, its ray-cast image"


# ---------------------------------------------------------------------------------------------------------------
# Small helpers (as bench/vtk_peer.py)


def log(msg):
    print(f"[vtk_tet_peer {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def image_error(a, b):
    """(psnr dB, rmse, max |diff|) over RGB in [0, 1], as `voxbrick compare` computes them."""
    d = a.astype(np.float64) / 255.0 - b.astype(np.float64) / 255.0
    rmse = float(np.sqrt(np.mean(d * d)))
    return (float("inf") if rmse == 0 else 20 * np.log10(1 / rmse)), rmse, float(np.abs(d).max())


# ---------------------------------------------------------------------------------------------------------------
# The mesh, as VTK reads it, and what voxbrick derives from it


def mesh_constants(grid, field):
    """Bounds, scalar range, mean and longest edge length of a vtkUnstructuredGrid of tetrahedra, computed the way
    render/tets/TetMeshSource.cpp does (double arithmetic on the float positions, every tet's six edges)."""
    from vtkmodules.util import numpy_support as ns

    pts = ns.vtk_to_numpy(grid.GetPoints().GetData()).astype(np.float64)
    cells = grid.GetCells()
    conn = ns.vtk_to_numpy(cells.GetConnectivityArray()).astype(np.int64)
    offsets = ns.vtk_to_numpy(cells.GetOffsetsArray()).astype(np.int64)
    types = ns.vtk_to_numpy(grid.GetCellTypesArray())
    if not (np.all(types == 10) and np.all(np.diff(offsets) == 4)):
        sys.exit("vtk_tet_peer: the mesh has cells other than linear tetrahedra (VTK type 10)")
    tets = conn.reshape(-1, 4)
    scalars = ns.vtk_to_numpy(grid.GetPointData().GetArray(field)).astype(np.float64)
    total, longest = 0.0, 0.0
    for a in range(4):
        for b in range(a + 1, 4):
            e = np.linalg.norm(pts[tets[:, a]] - pts[tets[:, b]], axis=1)
            total += float(e.sum())
            longest = max(longest, float(e.max()))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return {"tets": int(tets.shape[0]), "points": int(pts.shape[0]), "bounds": [lo.tolist(), hi.tolist()],
            "value_range": [float(scalars.min()), float(scalars.max())],
            "mean_edge": total / (6.0 * tets.shape[0]), "longest_edge": longest}


def orbit_camera(az, el, dist, bounds):
    lo, hi = np.array(bounds[0]), np.array(bounds[1])
    centre = 0.5 * (lo + hi)
    radius = 0.5 * np.linalg.norm(hi - lo)
    a, e = np.radians(az), np.radians(el)
    direction = np.array([np.cos(e) * np.sin(a), np.sin(e), np.cos(e) * np.cos(a)])
    return list(centre + dist * radius * direction), list(centre), [0.0, 1.0, 0.0]


# ---------------------------------------------------------------------------------------------------------------
# voxbrick


class Voxbrick:
    def __init__(self, binary, store):
        self.bin, self.store = binary, store
        self.description = None
        try:
            self.info = json.loads(run([binary, "info", store, "--json"]).stdout)
        except (subprocess.CalledProcessError, json.JSONDecodeError) as e:
            log(f"voxbrick info {store} --json failed ({e}); the store is not checked against the mesh")
            self.info = {}

    def render(self, scene, png, stats_json, reference=False, reference_step=None, scene_path=None):
        scene_path = scene_path or png[:-4] + ".scene.json"
        with open(scene_path, "w") as f:
            json.dump(scene, f, indent=1)
        cmd = [self.bin, "render", self.store, "--scene", scene_path, "-o", png, "--stats", stats_json]
        if reference:
            cmd += ["--backend", "reference"]
            if reference_step is not None:
                cmd += ["--reference-step", str(reference_step)]
        else:
            cmd += ["--warm-up", "1"]  # the timed frame is a warm one, as VTK's is
        t0 = time.perf_counter()
        p = run(cmd)
        wall = (time.perf_counter() - t0) * 1e3
        for line in p.stderr.splitlines():
            if line.startswith("render: ") and self.description is None and not reference:
                self.description = line[len("render: "):].strip()
        try:
            with open(stats_json) as f:
                return json.load(f), wall
        except (OSError, json.JSONDecodeError):
            return {}, wall

    def compare(self, a, b, heatmap=None):
        cmd = [self.bin, "compare", "--json", a, b]
        if heatmap:
            cmd += ["--heatmap", heatmap]
        r = json.loads(run(cmd).stdout)
        psnr = r.get("psnr")
        return (float("inf") if psnr is None else float(psnr)), float(r["rmse"]), float(r["max_abs"])


# ---------------------------------------------------------------------------------------------------------------
# VTK


class VtkTetPeer:
    """One offscreen render window per renderer (the projected-tetrahedra mapper; the ray-cast mapper once per
    integrator), sharing one vtkUnstructuredGrid and one vtkVolumeProperty."""

    def __init__(self, grid, tf, window, reference_length, width, height, log_file):
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
        self.grid = grid

        self.prop = volume_property(vtk, tf, window, reference_length)
        self.windows = {}

    def _window(self, kind):
        """kind: 'pt', or 'rc:<integrator>'."""
        if kind in self.windows:
            return self.windows[kind]
        vtk = self.vtk
        if kind == "pt":
            m = vtk.vtkProjectedTetrahedraMapper()  # the OpenGL2 override
        else:
            m = vtk.vtkUnstructuredGridVolumeRayCastMapper()
            m.SetAutoAdjustSampleDistances(0)
            m.SetImageSampleDistance(1.0)
            m.SetMinimumImageSampleDistance(1.0)
            m.SetMaximumImageSampleDistance(1.0)
            m.SetIntermixIntersectingGeometry(0)  # nothing to intermix; skips reading the depth buffer
            integrator = kind.split(":", 1)[1]
            m.SetRayIntegrator(getattr(vtk, INTEGRATORS[integrator])())
        m.SetInputData(self.grid)
        m.SetBlendModeToComposite()
        rw, ren = offscreen_window(vtk, m, self.prop, self.width, self.height)
        self.windows[kind] = (rw, ren, m)
        return self.windows[kind]

    def describe(self, kind):
        rw, _, m = self._window(kind)
        rw.Render()
        d = {"gl": gl_description(rw), "class": m.GetClassName()}
        if kind == "pt":
            d["supported"] = bool(m.IsSupported(rw))
            d["float_framebuffer"] = bool(m.GetUseFloatingPointFrameBuffer())
            d["sort"] = m.GetVisibilitySort().GetClassName()
        else:
            d["threads"] = m.GetNumberOfThreads()
            d["integrator"] = m.GetRayIntegrator().GetClassName()
        return d

    def set_view(self, kind, eye, center, up, fov):
        _, ren, _ = self._window(kind)
        cam = ren.GetActiveCamera()
        cam.SetPosition(*eye)
        cam.SetFocalPoint(*center)
        cam.SetViewUp(*up)
        cam.SetViewAngle(fov)
        cam.SetParallelProjection(0)
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

    def raycast_image(self, kind):
        """The ray-cast mapper's own image of its last frame (RGB, premultiplied over black as it is drawn; row 0 at
        the top), without the display step, or None where it cannot be found.

        vtkUnstructuredGridVolumeRayCastMapper has no getter for it (unlike the FixedPoint mapper's
        GetRayCastImage), so it is found in the object: the header declares, one after the other, int
        ImageViewportSize[2], ImageMemorySize[2], ImageInUseSize[2], ImageOrigin[2] and then unsigned char *Image
        (RGBA, ImageMemorySize). The first three pairs and the last are known from the public getters and the
        memory size is the power of two (at least 32) the mapper picks, so the eight ints are searched for in the
        object's first kilobyte and the pointer after them is read. Checked against the window: this image, put
        through the display helper's resampling, gives the window's frame to 62 dB (8-bit rounding)."""
        import ctypes

        _, _, m = self._window(kind)
        vp, use, origin = m.GetImageViewportSize(), m.GetImageInUseSize(), m.GetImageOrigin()
        mem = [32, 32]
        for a in range(2):
            while mem[a] < use[a]:
                mem[a] *= 2
        this = m.__this__  # '_<hex address>_p_vtkUnstructuredGridVolumeRayCastMapper'
        address = int(this[1:this.index("_p_")], 16)
        head = ctypes.string_at(address, 1024)
        at = head.find(struct.pack("8i", *vp, *mem, *use, *origin))
        if at < 0 or at % 4:
            return None
        ptr_at = (at + 32 + ctypes.sizeof(ctypes.c_void_p) - 1) // ctypes.sizeof(ctypes.c_void_p) * \
            ctypes.sizeof(ctypes.c_void_p)
        pointer = ctypes.c_void_p.from_buffer_copy(head, ptr_at).value
        if not pointer:
            return None
        img = np.frombuffer(ctypes.string_at(pointer, mem[0] * mem[1] * 4), np.uint8).reshape(mem[1], mem[0], 4)
        out = np.zeros((vp[1], vp[0], 3), np.uint8)
        out[origin[1]:origin[1] + use[1], origin[0]:origin[0] + use[0]] = img[:use[1], :use[0], :3]
        return out[::-1].copy()

    def errors(self):
        try:
            with open(self.log_file, errors="replace") as f:
                return [l.strip() for l in f if "ERROR" in l or "Error" in l]
        except OSError:
            return []


def read_mesh(path, field):
    import vtk

    r = vtk.vtkUnstructuredGridReader()
    r.SetFileName(path)
    r.ReadAllScalarsOn()
    r.Update()
    grid = r.GetOutput()
    if grid is None or grid.GetNumberOfCells() == 0:
        sys.exit(f"vtk_tet_peer: VTK read no cells from {path}")
    pd = grid.GetPointData()
    names = [pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())]
    if field is None:
        if not names:
            sys.exit(f"vtk_tet_peer: {path} has no point data")
        field = names[0]
    if field not in names:
        sys.exit(f"vtk_tet_peer: {path} has no point array {field!r} (it has {names})")
    pd.SetActiveScalars(field)
    return grid, field


# ---------------------------------------------------------------------------------------------------------------


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--voxbrick-bin", default="build/voxbrick")
    ap.add_argument("--mesh", required=True, help="VTK legacy unstructured grid of tetrahedra (the file prep read)")
    ap.add_argument("--field", default=None, help="point scalar to render (default: the .json beside --mesh, "
                                                  "else the file's first point array)")
    ap.add_argument("--store", default=None, help="mesh store made by `voxbrick prep MESH -o STORE --field NAME`")
    ap.add_argument("--vtk-only", action="store_true", help="VTK side only: no store, no voxbrick")
    ap.add_argument("--work", required=True, help="frames, reference cache, logs")
    ap.add_argument("--out", required=True, help="NAME.csv and NAME.md go here")
    ap.add_argument("--name", default="peer-tets")
    ap.add_argument("--views", type=int, default=4, help="azimuths 0, 360/N, ...")
    ap.add_argument("--elevation", type=float, default=20)
    ap.add_argument("--distance", type=float, default=2.5, help="bounding-sphere radii")
    ap.add_argument("--fov", type=float, default=30)
    ap.add_argument("--size", default="512x512")
    ap.add_argument("--tf", default="hot", help="preset of config/tf or a JSON file")
    ap.add_argument("--config-dir", default="config")
    ap.add_argument("--window", default=None, help="LO,HI (default the mesh's scalar range)")
    ap.add_argument("--voxbrick", action="append", default=[],
                    help="a voxbrick setting: comma list of key=value merged into the scene JSON (repeatable), e.g. "
                         "visibility=centroid; default one setting, visibility=raycast (the renderer's default)")
    ap.add_argument("--mappers", default="pt,rc", help="pt (projected tetrahedra), rc (unstructured-grid ray cast)")
    ap.add_argument("--integrators", default="pre",
                    help="ray integrators of the ray-cast mapper, comma list of " + ", ".join(INTEGRATORS) +
                         "; the first is the one the summary judges against (default pre: VTK's own choice)")
    ap.add_argument("--repeats", type=int, default=3, help="timed frames per view after the warm-up")
    ap.add_argument("--reference-step", type=float, default=None,
                    help="passed to the reference renderer when given (default: its own, exact for a mesh)")
    ap.add_argument("--heatmaps", type=int, default=1, help="write heat maps for the first N views")
    ap.add_argument("--command", default=None, help="the command line to quote in the report")
    ap.add_argument("--voxbrick-source", default=None, help="where --voxbrick-bin was copied from (for the report)")
    args = ap.parse_args()
    sys.stdout.reconfigure(encoding="utf-8")  # the report has non-ASCII characters; a C locale would refuse them

    started = time.time()
    load_start = os.getloadavg()
    width, height = (int(v) for v in args.size.lower().split("x"))
    if not args.vtk_only and not args.store:
        sys.exit("vtk_tet_peer: --store is needed (or --vtk-only)")
    os.makedirs(args.work, exist_ok=True)
    os.makedirs(args.out, exist_ok=True)
    tf_label = os.path.splitext(os.path.basename(args.tf))[0]
    frames_dir = os.path.join(args.work, "frames", f"{args.name}-{tf_label}")
    ref_dir = os.path.join(args.work, "reference")
    os.makedirs(frames_dir, exist_ok=True)
    for old in os.listdir(frames_dir):  # this run's frames only
        os.remove(os.path.join(frames_dir, old))
    os.makedirs(ref_dir, exist_ok=True)

    # The mesh, read by VTK; the field name from the .json make_tet_meshes.py wrote beside it when there is one.
    meta = {}
    meta_path = os.path.splitext(args.mesh)[0] + ".json"
    if os.path.exists(meta_path):
        with open(meta_path) as f:
            meta = json.load(f)
    t0 = time.perf_counter()
    grid, field = read_mesh(args.mesh, args.field or meta.get("field"))
    consts = mesh_constants(grid, field)
    log(f"{args.mesh}: {consts['tets']} tets, {consts['points']} points, field {field} in "
        f"[{consts['value_range'][0]:.6g}, {consts['value_range'][1]:.6g}], mean edge {consts['mean_edge']:.6g} "
        f"(read in {time.perf_counter() - t0:.1f} s)")

    vb = None
    if not args.vtk_only:
        vb = Voxbrick(args.voxbrick_bin, args.store)
        info = vb.info
        problems = []
        for key, mine in (("tets", consts["tets"]), ("points", consts["points"])):
            if key in info and int(info[key]) != mine:
                problems.append(f"{key} {info[key]} (the file {mine})")
        if "field" in info and info["field"] != field:
            problems.append(f"field {info['field']!r} (rendered here: {field!r})")
        for key, mine in (("value_range", consts["value_range"]), ("bounds", consts["bounds"])):
            if key in info:
                theirs = np.array(info[key], float).ravel()
                if theirs.shape != np.array(mine).ravel().shape or np.abs(theirs - np.ravel(mine)).max() > 1e-5:
                    problems.append(f"{key} {info[key]} (the file {mine})")
        if "reference_length" in info and abs(info["reference_length"] / consts["mean_edge"] - 1) > 1e-6:
            problems.append(f"reference_length {info['reference_length']} (mean edge here {consts['mean_edge']})")
        if problems:
            sys.exit(f"vtk_tet_peer: the store {args.store} is not the mesh {args.mesh}: " + "; ".join(problems))

    value_range = consts["value_range"]
    window = [float(v) for v in args.window.split(",")] if args.window else list(value_range)
    if not window[1] > window[0]:
        window = [window[0], window[0] + 1]  # render/gl/tets/TetRenderer.cpp: a constant field

    tf_path = args.tf if (args.tf.endswith(".json") or "/" in args.tf) else os.path.join(
        args.config_dir, "tf", args.tf + ".json")
    with open(tf_path) as f:
        tf = json.load(f)
    reference_length = float(tf.get("reference_length", consts["mean_edge"]))

    settings = []
    for text in args.voxbrick or ["visibility=raycast"]:
        frag = parse_fragment(text, BOOLEAN_KEYS)
        bad = SCENE_KEYS & set(frag)
        if bad:
            sys.exit(f"vtk_tet_peer: --voxbrick {text!r} sets {sorted(bad)}: these define the scene (the same for "
                     "every renderer), use this script's options instead")
        settings.append((text, frag))
    mappers = [m for m in args.mappers.split(",") if m]
    integrators = [i for i in args.integrators.split(",") if i]
    for i in integrators:
        if i not in INTEGRATORS:
            sys.exit(f"vtk_tet_peer: --integrators: {i!r} is not one of {', '.join(INTEGRATORS)}")
    kinds = (["pt"] if "pt" in mappers else []) + ([f"rc:{i}" for i in integrators] if "rc" in mappers else [])
    if not kinds:
        sys.exit("vtk_tet_peer: --mappers names neither pt nor rc")

    def label(kind):
        return PT_LABEL if kind == "pt" else RC_LABEL

    def setting_of(kind):
        return "default sort" if kind == "pt" else f"integrator={kind.split(':', 1)[1]}"

    views = [i * 360.0 / args.views for i in range(args.views)]
    base_scene = {"size": [width, height], "transfer_function": tf, "background": [0, 0, 0], "shading": False}
    if args.window:
        base_scene["window"] = window

    def scene_for(az):
        # The orbit as orbit_camera places VTK's: up +Y (voxbrick's default up axis is +z).
        return merge(base_scene, {"camera": {"orbit": [az, args.elevation, args.distance], "fov": args.fov,
                                             "orthographic": False, "up_axis": "+y"}})

    # 1. References (cached by scene content, store and reference step).
    refs, ref_ms = {}, []
    if vb:
        store_meta = next((os.path.join(args.store, n) for n in ("mesh.json", "store.json")
                           if os.path.exists(os.path.join(args.store, n))), None)
        with open(store_meta or args.mesh, "rb") as f:
            store_digest = hashlib.sha256(f.read()).hexdigest()
        for az in views:
            scene = scene_for(az)
            key = hashlib.sha256(json.dumps({"scene": scene, "store": store_digest,
                                             "reference_step": args.reference_step},
                                            sort_keys=True).encode()).hexdigest()[:16]
            png = os.path.join(ref_dir, f"ref-{key}.png")
            if not os.path.exists(png):
                log(f"reference az {az:g}: rendering")
                tmp = png[:-4] + ".tmp.png"
                _, wall = vb.render(scene, tmp, png[:-4] + ".stats.json", reference=True,
                                    reference_step=args.reference_step, scene_path=png[:-4] + ".scene.json")
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
    peer = VtkTetPeer(grid, tf, window, reference_length, width, height, vtk_log)
    import vtk
    vtk_version = vtk.vtkVersion.GetVTKVersion()
    info_of, failed = {}, {}
    for k in kinds:
        try:
            info_of[k] = peer.describe(k)
            if k == "pt" and not info_of[k].get("supported", True):
                failed[k] = "IsSupported() is false on this OpenGL context"
        except Exception as e:  # noqa: BLE001 - any failure is recorded and the mapper skipped
            failed[k] = f"{type(e).__name__}: {e}"
    log(f"VTK {vtk_version}: {info_of} {failed or ''}")

    # 3. Frames, interleaved view by view.
    rows, no_image = [], set()
    for vi, az in enumerate(views):
        eye, centre, up = orbit_camera(az, args.elevation, args.distance, consts["bounds"])

        def run_voxbrick():
            if not vb:
                return
            for si, (text, frag) in enumerate(settings):
                scene = merge(scene_for(az), frag)
                png = os.path.join(frames_dir, f"voxbrick-s{si}-az{az:g}.png")
                stats, wall = vb.render(scene, png, png[:-4] + ".stats.json")
                ms = stats.get("ms", {})
                total = float(ms.get("total", wall))
                rows.append({"renderer": "voxbrick", "setting": text, "view": vi, "azimuth": az, "ms": total,
                             "process_ms": wall, "phases": {k: v for k, v in ms.items() if k != "total"},
                             "png": png})
                log(f"az {az:g} voxbrick [{text}]: {total:.0f} ms (process {wall:.0f} ms)")

        def run_vtk():
            for k in kinds:
                if k in failed:
                    continue
                try:
                    peer.set_view(k, eye, centre, up, args.fov)
                    peer.frame(k)  # warm-up, discarded
                    times, rgb = [], None
                    for _ in range(args.repeats):
                        t, rgb = peer.frame(k)
                        times.append(t)
                except Exception as e:  # noqa: BLE001
                    failed[k] = f"{type(e).__name__}: {e}"
                    continue
                if not rgb.any():
                    errs = peer.errors()
                    failed[k] = "blank frame" + (f"; VTK said: {errs[-1][:300]}" if errs else "")
                    continue
                png = os.path.join(frames_dir, f"vtk-{k.replace(':', '-')}-az{az:g}.png")
                write_png(png, rgb)
                rows.append({"renderer": label(k), "setting": setting_of(k), "kind": k, "view": vi, "azimuth": az,
                             "ms": median(times), "times": times, "process_ms": "", "png": png,
                             "rgb": None if vb else rgb.copy()})
                own = peer.raycast_image(k) if k.startswith("rc:") else None
                if own is not None:
                    png2 = os.path.join(frames_dir, f"vtk-{k.replace(':', '-')}-raycast-az{az:g}.png")
                    write_png(png2, own)
                    rows.append({"renderer": RC_IMAGE_LABEL, "setting": setting_of(k), "kind": k + ":image",
                                 "view": vi, "azimuth": az, "ms": median(times), "times": times, "process_ms": "",
                                 "png": png2, "rgb": None if vb else own})
                elif k.startswith("rc:"):
                    no_image.add(k)
                log(f"az {az:g} {label(k)} [{setting_of(k)}]: {median(times):.0f} ms "
                    f"({', '.join(f'{t:.0f}' for t in times)})")

        for part in ((run_voxbrick, run_vtk) if vi % 2 == 0 else (run_vtk, run_voxbrick)):
            part()

    # 4. Accuracy (after all timing, so that compare never runs beside a timed frame).
    judge_kind = next((k for k in kinds if k.startswith("rc:") and k not in failed), None)
    if vb:
        judge = "voxbrick reference (`voxbrick render --backend reference`)"
    else:
        judge = f"{RC_LABEL} [{setting_of(judge_kind)}] (--vtk-only: no voxbrick)" if judge_kind else None
    for r in rows:
        if vb:
            heat = r["png"][:-4] + ".heat.png" if r["view"] < args.heatmaps else None
            r["psnr"], r["rmse"], r["max_abs"] = vb.compare(r["png"], refs[r["azimuth"]], heat)
        elif judge_kind:
            ref = next(x["rgb"] for x in rows if x.get("kind") == judge_kind and x["azimuth"] == r["azimuth"])
            r["psnr"], r["rmse"], r["max_abs"] = image_error(r["rgb"], ref)
        else:
            r["psnr"] = r["rmse"] = r["max_abs"] = float("nan")

    # 5. Output.
    csv_path = os.path.join(args.out, f"{args.name}.csv")
    with open(csv_path, "w") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["renderer", "setting", "view", "azimuth", "ms", "ms_sorting", "ms_drawing", "process_ms",
                    "psnr_db", "rmse", "max_abs", "judge"])
        for r in rows:
            ph = r.get("phases", {})
            w.writerow([r["renderer"], r["setting"], r["view"], f"{r['azimuth']:g}", f"{r['ms']:.1f}",
                        f"{ph['sorting']:.1f}" if "sorting" in ph else "",
                        f"{ph['drawing']:.1f}" if "drawing" in ph else "",
                        f"{r['process_ms']:.0f}" if r["process_ms"] != "" else "", f"{r['psnr']:.2f}",
                        f"{r['rmse']:.6f}", f"{r['max_abs']:.4f}", "reference" if vb else "vtk-rc"])

    groups = []
    for r in rows:
        k = (r["renderer"], r["setting"])
        if k not in groups:
            groups.append(k)

    def group_rows(k):
        return [r for r in rows if (r["renderer"], r["setting"]) == k]

    pt_ms = median([r["ms"] for r in rows if r.get("kind") == "pt"]) if any(r.get("kind") == "pt" for r in rows) \
        else None

    def loads(values):
        return ", ".join(f"{x:.1f}" for x in values)

    cores = os.cpu_count()
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(l.split(":", 1)[1].strip() for l in f if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    any_info = next(iter(info_of.values()), {})
    rc_info = next((info_of[k] for k in kinds if k.startswith("rc:") and k in info_of), {})
    pt_info = info_of.get("pt", {})
    lines = [f"# Peer: VTK, tetrahedral mesh — {args.name}", ""]
    vb_gl = (vb and vb.description) or "—"
    lines.append(f"Machine: {cores} cores ({cpu}); voxbrick's GL: {vb_gl}; VTK {vtk_version} "
                 f"(python3-vtk9) under Xvfb, its GL: {any_info.get('gl') or '?'}; ray-cast threads: "
                 f"{rc_info.get('threads', '—')}. Load average (1, 5, 15 min) at the start: {loads(load_start)}, at "
                 f"the end: {loads(os.getloadavg())}.")
    lines.append("")
    lines.append(f"Command: `{args.command or ' '.join(sys.argv)}`")
    lines.append("")
    if vb:
        with open(args.voxbrick_bin, "rb") as f:
            digest = hashlib.sha256(f.read()).hexdigest()[:12]
        source = args.voxbrick_source or args.voxbrick_bin
        built = datetime.datetime.fromtimestamp(os.path.getmtime(args.voxbrick_bin)).strftime("%Y-%m-%d %H:%M")
        lines.append(f"voxbrick binary: `{source}` built {built} (sha256 {digest}…), run from a copy; store "
                     f"`{args.store}`.")
    else:
        lines.append("voxbrick: not run (--vtk-only); PSNR is against the VTK ray-cast frame named below.")
    lines.append("")
    b = consts["bounds"]
    made = ""
    if meta:
        made = (f" ({meta.get('shape', '?')} of {meta.get('target_tets', '?')} tets asked, gmsh "
                f"{meta.get('gmsh', '?')}, h {meta.get('h', 0):.4g}; field: {meta.get('field_formula', '?')})")
    lines.append(f"Mesh: `{os.path.basename(args.mesh)}`{made}: {consts['tets']:,} tets, {consts['points']:,} points, "
                 f"bounds ({', '.join(f'{v:.4g}' for v in b[0])}) … ({', '.join(f'{v:.4g}' for v in b[1])}), field "
                 f"`{field}` in [{value_range[0]:.4g}, {value_range[1]:.4g}], mean edge length "
                 f"{consts['mean_edge']:.5g}, longest {consts['longest_edge']:.5g}.")
    lines.append("")
    lines.append(f"Scene: transfer function `{args.tf}` over window [{window[0]:.4g}, {window[1]:.4g}], reference "
                 f"length {reference_length:.5g} (world; "
                 f"{'the preset' if 'reference_length' in tf else 'the mean edge length'}), unshaded, black "
                 f"background, {width}×{height}, {args.views} views (azimuth 0…{views[-1]:g}°, elevation "
                 f"{args.elevation:g}°, {args.distance:g} R about the bounds' centre, fov {args.fov:g}°, "
                 f"perspective). Judge: {judge or '—'}"
                 + (f" (reference step {args.reference_step:g})" if args.reference_step is not None and vb else "")
                 + f". {datetime.datetime.now().strftime('%Y-%m-%d %H:%M')}, {(time.time() - started) / 60:.1f} min.")
    lines.append("")
    lines.append("| renderer | setting | median ms | worst view dB | median dB | time / ProjectedTetrahedra |")
    lines.append("| --- | --- | ---: | ---: | ---: | ---: |")
    for k in groups:
        g = group_rows(k)
        ms = median([r["ms"] for r in g])
        ps = [r["psnr"] for r in g]
        ratio = f"{ms / pt_ms:.2f}" if pt_ms else "—"
        lines.append(f"| {k[0]} | {k[1]} | {ms:.0f} | {fmt_db(min(ps))} | {fmt_db(median(ps))} | {ratio} |")
    lines.append("")

    # The criterion: voxbrick at most half the time of the projected-tetrahedra mapper, PSNR at least the
    # ray-cast mapper's (the first integrator of --integrators: VTK's own choice unless told otherwise).
    first_rc = next((k for k in kinds if k.startswith("rc:") and k not in failed), None)
    judges = [g for g in ((RC_LABEL, setting_of(first_rc)), (RC_IMAGE_LABEL, setting_of(first_rc)))
              if first_rc and g in groups]
    if vb and pt_ms and judges:
        judge_db = {g: (median([r["psnr"] for r in group_rows(g)]), min(r["psnr"] for r in group_rows(g)))
                    for g in judges}
        best = max(judges, key=lambda g: judge_db[g][0])
        said = "; ".join(f"{g[0]} median {fmt_db(judge_db[g][0])} dB, worst view {fmt_db(judge_db[g][1])} dB"
                         for g in judges)
        lines.append(f"Criterion (same run): voxbrick ≤ 0.5 × the time of {PT_LABEL} (median {pt_ms:.0f} ms), and "
                     f"median PSNR ≥ the ray-cast mapper's [{setting_of(first_rc)}], taken as the better of its "
                     f"window frame and its own ray-cast image ({said}):")
        lines.append("")
        lines.append("| voxbrick setting | time / ProjectedTetrahedra | median dB − ray cast's | "
                     "worst view dB − ray cast's | met |")
        lines.append("| --- | ---: | ---: | ---: | --- |")
        for k in groups:
            if k[0] != "voxbrick":
                continue
            g = group_rows(k)
            ratio = median([r["ms"] for r in g]) / pt_ms
            d_med = median([r["psnr"] for r in g]) - judge_db[best][0]
            d_worst = min(r["psnr"] for r in g) - judge_db[best][1]
            met = ratio <= 0.5 and d_med >= 0
            lines.append(f"| {k[1]} | {ratio:.3f} | {d_med:+.1f} | {d_worst:+.1f} | {'yes' if met else 'no'} |")
        lines.append("")
    for k, why in failed.items():
        lines.append(f"- **{label(k)} [{setting_of(k)}] failed**: {why}")
    if pt_info:
        lines.append(f"- {PT_LABEL}: `{pt_info.get('class')}`, visibility sort `{pt_info.get('sort')}` (its default, "
                     f"re-sorted every frame), floating-point frame buffer "
                     f"{'on' if pt_info.get('float_framebuffer') else 'off'}.")
    for k in kinds:
        if k.startswith("rc:") and k in info_of:
            lines.append(f"- {RC_LABEL} [{setting_of(k)}]: `{info_of[k].get('class')}` with "
                         f"`{info_of[k].get('integrator')}`, one ray per pixel (ImageSampleDistance 1, no "
                         f"auto-adjust), {info_of[k].get('threads')} threads; its image reaches the window through "
                         "VTK's ray-cast display helper.")
    if any(k.startswith("rc:") for k in kinds):
        lines.append(f"- `{RC_IMAGE_LABEL}`: the ray-cast mapper's own image of the same timed frame, read from the "
                     "mapper's memory (it has no getter) instead of the window. VTK draws that image into the window "
                     "as a texture whose coordinates run from the first to the last texel *centre* over the full "
                     "pixel rectangle (vtkOpenGLRayCastImageDisplayHelper), i.e. stretched by one pixel and "
                     "resampled bilinearly; the window's frame is what a VTK user gets, the ray-cast image isolates "
                     "the mapper's sampling and compositing from that display step."
                     + (f" Not found for {', '.join(sorted(no_image))}." if no_image else ""))
    lines.append(f"- VTK: per view one warm-up frame (discarded), then {args.repeats} timed frame(s) (`Render()` + "
                 "`GetPixelData`), median; the table gives the median over the views.")
    if vb:
        phases = []
        for k in groups:
            if k[0] == "voxbrick":
                g = group_rows(k)
                names = [n for n in ("sorting", "pre_integration", "drawing", "readback")
                         if all(n in r["phases"] for r in g)]
                phases.append(f"`{k[1]}`: " + ", ".join(
                    f"{n.replace('_', '-')} {median([r['phases'][n] for r in g]):.0f}" for n in names))
        lines.append("- voxbrick: one `voxbrick render --warm-up 1` process per view and setting: a warm-up frame, "
                     "then the timed frame, whose `ms.total` (from `--stats`) is the time given. Its phases, median "
                     "ms over the views: " + "; ".join(phases) + ".")
        if ref_ms:
            lines.append(f"- References rendered in this run: median {median(ref_ms) / 1e3:.1f} s each (cached "
                         f"afterwards in `{ref_dir}`).")
    lines.append(f"- Renderers are interleaved view by view (order alternating). Frames"
                 f"{' and heat maps (first ' + str(args.heatmaps) + ' view(s))' if vb else ''} are in "
                 f"`{frames_dir}`.")
    md_path = os.path.join(args.out, f"{args.name}.md")
    with open(md_path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    log(f"wrote {csv_path} and {md_path} in {(time.time() - started) / 60:.1f} min")


if __name__ == "__main__":
    main()
