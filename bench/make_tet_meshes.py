#!/usr/bin/python3
"""Tetrahedral test meshes for the tet peer benchmark (bench/run_tet_peer.sh): a ball or a box meshed by gmsh to
about --tets tetrahedra, an analytic scalar on its vertices, written as a VTK legacy UNSTRUCTURED_GRID file that
both VTK and `voxbrick prep` read.

    python3 bench/make_tet_meshes.py --tets 50000 --out bench/work/tets [--shape ball|box] [--centre X,Y,Z]
                                     [--size S] [--tolerance 0.05] [--gmsh gmsh] [--force]

Python 3 standard library only; needs the gmsh command (Debian's gmsh, 4.8 in Debian 12).

The mesh. A .geo file (OpenCASCADE kernel) describes the shape: a ball of radius S (default 1) or a cube of edge
2 S, centred on --centre (default 0.5,0.25,-0.25: off the origin on purpose, so a renderer that re-centres the mesh
or looks at the origin instead of the box centre shows it). Every mesh size source but the global one is turned off
(MeshSizeFromPoints / FromCurvature / ExtendFromBoundary = 0) so that the whole volume is meshed with one
characteristic length h (MeshSizeMin = MeshSizeMax = h), 3-D algorithm Delaunay (1), gmsh's default optimisation.
The tet count of such a mesh is close to k V / h^3 for a constant k (about 4.5 for gmsh 4.8's Delaunay on the
unit ball: 4.58 at 50 k tets, 4.46 at 1 M); h starts from that guess and is corrected by the cube root of
(count / target) until the count is within --tolerance of the target (at most --max-runs gmsh runs).
`gmsh -3 -format msh22` writes ASCII MSH 2.2 (Mesh.Binary = 0 in the .geo: gmsh 4.8 takes no value after -bin);
nodes and 4-node tetrahedra (element type 4) are read, every other element type (points, lines, triangles) is
ignored, and vertices that no tet uses (gmsh keeps none for these shapes, but a reader would keep them) are dropped.
Measured here (2 shared cores, gmsh niced): 50 k tets in 2 runs, 3 s; 1 M tets in 2 runs, 94 s, 0.6 GB peak.

The field ("blobs_ring"), a function of the normalised position p = (x - centre) / S (so |p| <= 1 in the ball):

    g(p) = 0.9 G(p; ( 0.35,  0.20,  0.10), 0.30)
         + 0.7 G(p; (-0.40, -0.25,  0.30), 0.25)
         + 0.6 G(p; ( 0.05,  0.10, -0.45), 0.35)
         + 0.35 exp(-((rho - 0.65)^2 + p_y^2) / (2 * 0.12^2)),   rho = sqrt(p_x^2 + p_z^2)   (a ring around y)
    G(p; a, s) = exp(-|p - a|^2 / (2 s^2))
    f(p) = 1 - exp(-2 g(p))                                                       (smooth, in [0, 1))

three Gaussians and a gentle torus, evaluated in double at each vertex and stored as float32.

The output, in --out (default bench/work/tets), for NAME = SHAPE-TARGET (e.g. ball-50000):
  NAME.vtk   VTK legacy 3.0, BINARY (big-endian, as the format defines it), DATASET UNSTRUCTURED_GRID:
             POINTS n float, CELLS m 5m (4 a b c d as int32), CELL_TYPES m (10 = VTK_TETRA), POINT_DATA n with
             SCALARS blobs_ring float 1 / LOOKUP_TABLE default.
  NAME.json  what was made: field name, its formula, tet and point counts, h, gmsh runs and version, bounds,
             scalar range. Its "field" is what `voxbrick prep --field` takes.
  NAME.geo, NAME.msh   gmsh's input and output of the last run (kept for reproduction; the .msh is removed unless
             --keep-msh).
An existing NAME.vtk with its NAME.json is reused unless --force.
"""

import argparse
import array
import json
import math
import os
import subprocess
import sys
import time

FIELD = "blobs_ring"
FIELD_FORMULA = ("f = 1 - exp(-2 g), g = 0.9 G(p; (0.35, 0.20, 0.10), 0.30) + 0.7 G(p; (-0.40, -0.25, 0.30), 0.25) "
                 "+ 0.6 G(p; (0.05, 0.10, -0.45), 0.35) + 0.35 exp(-((rho - 0.65)^2 + p_y^2) / (2 * 0.12^2)), "
                 "G(p; a, s) = exp(-|p - a|^2 / (2 s^2)), rho = sqrt(p_x^2 + p_z^2), p = (x - centre) / size")
GAUSSIANS = [(0.9, (0.35, 0.20, 0.10), 0.30), (0.7, (-0.40, -0.25, 0.30), 0.25), (0.6, (0.05, 0.10, -0.45), 0.35)]
RING = (0.35, 0.65, 0.12)  # weight, radius, width (sigma)
TETS_PER_H3 = 4.5  # first guess of k in count = k V / h^3 (gmsh 4.8 Delaunay, uniform size: 4.58 at 50k, 4.46 at 1M)


def log(msg):
    print(f"[make_tet_meshes {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def field(p):
    """The analytic field at normalised position p (a 3-tuple)."""
    g = 0.0
    for w, a, s in GAUSSIANS:
        d2 = (p[0] - a[0]) ** 2 + (p[1] - a[1]) ** 2 + (p[2] - a[2]) ** 2
        g += w * math.exp(-d2 / (2 * s * s))
    w, r, s = RING
    rho = math.hypot(p[0], p[2])
    g += w * math.exp(-((rho - r) ** 2 + p[1] ** 2) / (2 * s * s))
    return 1.0 - math.exp(-2.0 * g)


def shape_volume(shape, size):
    return 4.0 / 3.0 * math.pi * size ** 3 if shape == "ball" else (2.0 * size) ** 3


def write_geo(path, shape, centre, size, h):
    cx, cy, cz = centre
    if shape == "ball":
        solid = f"Sphere(1) = {{{cx!r}, {cy!r}, {cz!r}, {size!r}}};"
    else:
        solid = f"Box(1) = {{{cx - size!r}, {cy - size!r}, {cz - size!r}, {2 * size!r}, {2 * size!r}, {2 * size!r}}};"
    with open(path, "w") as f:
        f.write(f"""// bench/make_tet_meshes.py: a {shape} meshed with one characteristic length
SetFactory("OpenCASCADE");
{solid}
Mesh.MeshSizeMin = {h!r};
Mesh.MeshSizeMax = {h!r};
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.Algorithm3D = 1;
Mesh.Binary = 0;
""")


def run_gmsh(gmsh, geo, msh, log_path):
    cmd = [gmsh, "-3", "-format", "msh22", geo, "-o", msh]
    t0 = time.time()
    with open(log_path, "w") as lf:
        p = subprocess.run(cmd, stdout=lf, stderr=subprocess.STDOUT)
    if p.returncode != 0 or not os.path.exists(msh):
        with open(log_path, errors="replace") as lf:
            tail = lf.read()[-2000:]
        sys.exit(f"make_tet_meshes: {' '.join(cmd)} failed (exit {p.returncode}):\n{tail}")
    return time.time() - t0


def read_msh22(path):
    """ASCII MSH 2.2: returns (points as a list of (x, y, z), tets as a list of 4-tuples of indices into points).
    Node numbers may be sparse; elements other than 4-node tetrahedra (type 4) are ignored."""
    with open(path) as f:
        lines = iter(f)
        tags, points, tets = {}, [], []
        for line in lines:
            s = line.strip()
            if s == "$MeshFormat":
                version, file_type = next(lines).split()[:2]
                if not version.startswith("2.") or file_type != "0":
                    sys.exit(f"make_tet_meshes: {path}: MSH {version} type {file_type}, expected ASCII 2.2")
            elif s == "$Nodes":
                n = int(next(lines))
                for i in range(n):
                    parts = next(lines).split()
                    tags[int(parts[0])] = i
                    points.append((float(parts[1]), float(parts[2]), float(parts[3])))
            elif s == "$Elements":
                n = int(next(lines))
                for _ in range(n):
                    parts = next(lines).split()
                    if parts[1] != "4":
                        continue
                    ntags = int(parts[2])
                    nodes = parts[3 + ntags:3 + ntags + 4]
                    tets.append(tuple(tags[int(v)] for v in nodes))
    if not points or not tets:
        sys.exit(f"make_tet_meshes: {path}: {len(points)} nodes, {len(tets)} tetrahedra")
    return points, tets


def compact(points, tets):
    """Drops vertices no tet uses, renumbering the tets."""
    used = [False] * len(points)
    for t in tets:
        for v in t:
            used[v] = True
    if all(used):
        return points, tets
    remap, out = [-1] * len(points), []
    for i, p in enumerate(points):
        if used[i]:
            remap[i] = len(out)
            out.append(p)
    return out, [tuple(remap[v] for v in t) for t in tets]


def big_endian(typecode, values):
    """The bytes of `values` as a big-endian array of `typecode` ('f' float32, 'i' int32)."""
    a = array.array(typecode, values)
    if sys.byteorder == "little":
        a.byteswap()
    return a.tobytes()


def write_vtk(path, points, tets, scalars, name, title):
    """VTK legacy 3.0, BINARY (big-endian), UNSTRUCTURED_GRID of tetrahedra with one float point scalar."""
    n, m = len(points), len(tets)
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(f"# vtk DataFile Version 3.0\n{title[:255]}\nBINARY\nDATASET UNSTRUCTURED_GRID\n".encode())
        f.write(f"POINTS {n} float\n".encode())
        f.write(big_endian("f", (c for p in points for c in p)))
        f.write(f"\nCELLS {m} {5 * m}\n".encode())
        f.write(big_endian("i", (v for t in tets for v in (4, t[0], t[1], t[2], t[3]))))
        f.write(f"\nCELL_TYPES {m}\n".encode())
        f.write(big_endian("i", [10]) * m)
        f.write(f"\nPOINT_DATA {n}\nSCALARS {name} float 1\nLOOKUP_TABLE default\n".encode())
        f.write(big_endian("f", scalars))
        f.write(b"\n")
    os.replace(tmp, path)


def gmsh_version(gmsh):
    try:
        p = subprocess.run([gmsh, "--version"], capture_output=True, text=True)
        return (p.stdout + p.stderr).strip().splitlines()[-1]
    except (OSError, IndexError):
        return "?"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tets", type=int, required=True, help="target tet count, e.g. 50000 or 1000000")
    ap.add_argument("--out", default="bench/work/tets")
    ap.add_argument("--shape", choices=["ball", "box"], default="ball")
    ap.add_argument("--centre", default="0.5,0.25,-0.25", help="X,Y,Z of the shape's centre")
    ap.add_argument("--size", type=float, default=1.0, help="ball radius, or half the box's edge")
    ap.add_argument("--tolerance", type=float, default=0.05, help="accepted relative miss of the tet count")
    ap.add_argument("--max-runs", type=int, default=5, help="gmsh runs at most")
    ap.add_argument("--gmsh", default="gmsh")
    ap.add_argument("--name", default=None, help="output base name (default SHAPE-TETS)")
    ap.add_argument("--keep-msh", action="store_true")
    ap.add_argument("--force", action="store_true", help="remake even when NAME.vtk and NAME.json exist")
    args = ap.parse_args()

    centre = tuple(float(v) for v in args.centre.split(","))
    if len(centre) != 3 or not args.size > 0 or args.tets < 1:
        sys.exit("make_tet_meshes: --centre needs X,Y,Z, --size and --tets must be positive")
    os.makedirs(args.out, exist_ok=True)
    name = args.name or f"{args.shape}-{args.tets}"
    base = os.path.join(args.out, name)
    vtk_path, meta_path = base + ".vtk", base + ".json"
    if not args.force and os.path.exists(vtk_path) and os.path.exists(meta_path):
        with open(meta_path) as f:
            meta = json.load(f)
        if (meta.get("target_tets") == args.tets and meta.get("shape") == args.shape
                and meta.get("centre") == list(centre) and meta.get("size") == args.size):
            log(f"{vtk_path}: cached ({meta['tets']} tets, field {meta['field']})")
            print(json.dumps(meta, indent=1))
            return

    started = time.time()
    volume = shape_volume(args.shape, args.size)
    h = (TETS_PER_H3 * volume / args.tets) ** (1.0 / 3.0)
    geo, msh, gmsh_log = base + ".geo", base + ".msh", base + ".gmsh.log"
    runs = []
    for run in range(args.max_runs):
        write_geo(geo, args.shape, centre, args.size, h)
        seconds = run_gmsh(args.gmsh, geo, msh, gmsh_log)
        points, tets = read_msh22(msh)
        count = len(tets)
        runs.append({"h": h, "tets": count, "seconds": round(seconds, 2)})
        log(f"gmsh run {run + 1}: h = {h:.6g} -> {count} tets, {len(points)} nodes ({seconds:.1f} s)")
        miss = count / args.tets - 1.0
        if abs(miss) <= args.tolerance:
            break
        h *= (count / args.tets) ** (1.0 / 3.0)
    else:
        log(f"no run within {args.tolerance:.0%} of {args.tets}; keeping the last ({count} tets)")

    points, tets = compact(points, tets)
    scalars = [field(tuple((p[a] - centre[a]) / args.size for a in range(3))) for p in points]
    # What the file holds: float32 positions and values (bounds and range as a reader will see them).
    flat32 = array.array("f", (c for p in points for c in p))
    points32 = [tuple(flat32[3 * i:3 * i + 3]) for i in range(len(points))]
    scalars32 = array.array("f", scalars)
    lo = [min(p[a] for p in points32) for a in range(3)]
    hi = [max(p[a] for p in points32) for a in range(3)]
    title = (f"voxbrick bench/make_tet_meshes.py: {args.shape} centre {args.centre} size {args.size:g}, "
             f"{len(tets)} tets, field {FIELD}")
    write_vtk(vtk_path, points32, tets, scalars32, FIELD, title)
    if not args.keep_msh:
        os.remove(msh)
    meta = {
        "file": os.path.basename(vtk_path),
        "shape": args.shape, "centre": list(centre), "size": args.size,
        "target_tets": args.tets, "tets": len(tets), "points": len(points),
        "field": FIELD, "field_formula": FIELD_FORMULA,
        "scalar_range": [min(scalars32), max(scalars32)], "bounds": [lo, hi],
        "h": h, "gmsh_runs": runs, "gmsh": gmsh_version(args.gmsh),
        "gmsh_command": f"{args.gmsh} -3 -format msh22 {os.path.basename(geo)} -o {os.path.basename(msh)}",
        "seconds": round(time.time() - started, 1),
    }
    with open(meta_path + ".tmp", "w") as f:
        json.dump(meta, f, indent=1)
    os.replace(meta_path + ".tmp", meta_path)
    log(f"wrote {vtk_path} ({len(tets)} tets, {len(points)} points, field {FIELD} in "
        f"[{meta['scalar_range'][0]:.4g}, {meta['scalar_range'][1]:.4g}]) in {meta['seconds']} s")
    print(json.dumps(meta, indent=1))


if __name__ == "__main__":
    main()
