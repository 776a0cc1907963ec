"""Store seeds for the ingest fuzzer, made by `voxbrick prep` itself: a small brick store (its store.json,
index.bin and bricks.bin; its level-0 OpenVDB file, read live as a .vdb seed) and a mesh store (mesh.json,
mesh-index.bin, mesh-data.bin). The OpenVDB file's header is walked here (file header, metadata, grid descriptors)
so mutations aim at each length, count and position; the index files carry CRCs, so any change there must be
refused."""

import os
import struct
import subprocess

from fuzz.seeds import UINT, Field, Seed


def _read_dir(root):
    files = {}
    for dirpath, _, names in os.walk(root):
        for n in names:
            full = os.path.join(dirpath, n)
            with open(full, "rb") as f:
                files[os.path.relpath(full, root)] = f.read()
    return files


def _vdb_fields(data):
    """The fields of an OpenVDB file up to its first grid's data: (fields, bounds)."""
    fields, bounds, at = [], [0], 0

    def u32(name, must=True):
        nonlocal at
        fields.append(Field(name, at, 4, UINT, must))
        value = struct.unpack_from("<I", data, at)[0]
        at += 4
        bounds.append(at)
        return value

    def string(name):
        nonlocal at
        n = u32(name + " length")
        fields.append(Field(name, at, n, "text", False))
        at += n
        bounds.append(at)

    fields.append(Field("magic", 0, 8, UINT))
    at = 8
    bounds.append(at)
    version = u32("file format version")
    u32("library major", False)
    u32("library minor", False)
    at += 1  # grid offsets flag
    bounds.append(at)
    at += 36  # uuid
    bounds.append(at)
    count = u32("file metadata count")
    for k in range(count):
        string(f"file metadata {k} name")
        string(f"file metadata {k} type")
        n = u32(f"file metadata {k} value size")
        at += n
        bounds.append(at)
    u32("grid count")
    if version >= 219:
        string("grid 0 name")
        string("grid 0 type name")
        string("grid 0 instance parent")
        for name in ("grid position", "block position", "end position"):
            fields.append(Field("grid 0 " + name, at, 8, UINT))
            at += 8
            bounds.append(at)
        u32("grid 0 compression flags")
        count = u32("grid 0 metadata count")
        for k in range(min(count, 64)):
            string(f"grid 0 metadata {k} name")
            string(f"grid 0 metadata {k} type")
            n = u32(f"grid 0 metadata {k} value size")
            at += n
            bounds.append(at)
        string("grid 0 transform type")
    return fields, bounds, at


def store_seeds(exe, work, env):
    """Preps the stores in `work` and returns their seeds."""
    os.makedirs(work, exist_ok=True)
    store, meshes = os.path.join(work, "store"), os.path.join(work, "mesh-store")
    for args, out in ((["synthetic:blobs,n=16", "--brick", "8"], store), (["synthetic-mesh:ball,n=3"], meshes)):
        subprocess.run([exe, "prep", *args, "-q", "--force", "-o", out], check=True, env=env,
                       stdout=subprocess.DEVNULL)
    seeds = []
    sfiles = _read_dir(store)
    index = sfiles["index.bin"]
    # Bytes 48..63 of the header are reserved: no checksum covers them and readers ignore them.
    index_fields = [Field(f"index word {k}", k, 4, UINT, not 48 <= k < 64) for k in range(0, min(len(index), 160), 4)]
    seeds.append(Seed("store-json", sfiles, "store.json", "", "store", [], [], (0, 0), text_ws_ok=True))
    seeds.append(Seed("store-index", sfiles, "index.bin", "", "store", index_fields,
                      list(range(0, 160, 4)) + [len(index) - 32, len(index) - 1], (0, len(index)), guarded=True,
                      unguarded=(48, 64)))
    bricks = sfiles["bricks.bin"]
    seeds.append(Seed("store-bricks", sfiles, "bricks.bin", "", "store", [], [0, 4, 8, 1000, len(bricks) // 2,
                                                                           len(bricks) - 1], (0, len(bricks))))
    vdb_name = next(n for n in sfiles if n.endswith(".vdb"))
    vdb = sfiles[vdb_name]
    fields, bounds, header_end = _vdb_fields(vdb)
    seeds.append(Seed("openvdb", {"g.vdb": vdb}, "g.vdb", "g.vdb", "vdb", fields,
                      bounds + [header_end + 16, len(vdb) // 2, len(vdb) - 1], (header_end + 64, len(vdb))))
    mfiles = _read_dir(meshes)
    mindex = mfiles["mesh-index.bin"]
    seeds.append(Seed("meshstore-json", mfiles, "mesh.json", "", "meshstore", [], [], (0, 0), text_ws_ok=True))
    seeds.append(Seed("meshstore-index", mfiles, "mesh-index.bin", "", "meshstore",
                      [Field(f"index word {k}", k, 4, UINT) for k in range(0, min(len(mindex), 128), 4)],
                      list(range(0, 128, 8)) + [len(mindex) - 1], (0, len(mindex)), guarded=True))
    mdata = mfiles["mesh-data.bin"]
    seeds.append(Seed("meshstore-data", mfiles, "mesh-data.bin", "", "meshstore", [],
                      [0, 4, 8, len(mdata) // 2, len(mdata) - 1], (0, len(mdata)), guarded=True))
    return seeds
