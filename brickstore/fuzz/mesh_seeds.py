"""Mesh seeds for the ingest fuzzer: a few tetrahedra with point scalars as VTK legacy (ASCII and big-endian
binary) and gmsh (2.2 and 4.1 ASCII), written as mesh/MeshWriters.cpp writes them. Their numeric header tokens
(counts, types, sizes) are the fields mutations aim at."""

import re
import struct

from fuzz.seeds import TEXT, Field, Seed

# A unit cube cut into 5 tetrahedra, with one scalar a point.
POINTS = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0), (0, 0, 1), (1, 0, 1), (0, 1, 1), (1, 1, 1)]
TETS = [(0, 1, 2, 4), (1, 3, 2, 7), (1, 5, 4, 7), (2, 4, 6, 7), (1, 2, 4, 7)]
SCALARS = [0.1 * (i + 1) for i in range(len(POINTS))]


def _token_fields(text, lines):
    """Each whitespace-separated token of the given header lines (by their first word) as a field; a SCALARS
    line's name may be anything."""
    fields = []
    at = 0
    for line in text.split("\n"):
        words = line.split()
        if words and (words[0] in lines or line in lines):
            for k, m in enumerate(re.finditer(r"\S+", line)):
                if m.group() not in lines:
                    must = not (words[0] == "SCALARS" and k in (1, 3))  # the name; the optional component count
                    fields.append(Field(f"{words[0]} token {k}", at + m.start(), len(m.group()), TEXT, must))
        at += len(line) + 1
    return fields


def _bounds(text, limit=None):
    out = [0]
    for m in re.finditer(r"\n", text):
        if limit is not None and m.end() > limit:
            break
        out.append(m.end())
    return out


def vtk_seeds():
    n, m = len(POINTS), len(TETS)
    ascii_text = ("# vtk DataFile Version 3.0\nfuzz seed\nASCII\nDATASET UNSTRUCTURED_GRID\n"
                  f"POINTS {n} float\n" + "".join(f"{x} {y} {z}\n" for x, y, z in POINTS) +
                  f"CELLS {m} {5 * m}\n" + "".join("4 " + " ".join(map(str, t)) + "\n" for t in TETS) +
                  f"CELL_TYPES {m}\n" + "10\n" * m + f"POINT_DATA {n}\nSCALARS s float 1\nLOOKUP_TABLE default\n" +
                  "".join(f"{s:g}\n" for s in SCALARS))
    keys = {"POINTS", "CELLS", "CELL_TYPES", "POINT_DATA", "SCALARS"}
    fields = _token_fields(ascii_text, keys)
    # The cell types and connectivity: absurd ones must be refused too (an index out of range, type -1).
    # (Type 0 is VTK's empty cell: dropped, and said so.)
    for mt in re.finditer(r"^(4 \d+ \d+ \d+ \d+|10)$", ascii_text, re.M):
        must = True if mt.group() != "10" else ("-1", "max", "nan", "huge", "overflow", "empty", "x")
        fields.append(Field(f"cell line at {mt.start()}", mt.start(), len(mt.group()), TEXT, must))
    seeds = [Seed("vtk-ascii", {"m.vtk": ascii_text.encode()}, "m.vtk", "m.vtk", "mesh", fields, _bounds(ascii_text),
                  (0, 0), text_ws_ok=True)]
    head = b"# vtk DataFile Version 3.0\nfuzz seed\nBINARY\nDATASET UNSTRUCTURED_GRID\n"
    body = bytearray(head + f"POINTS {n} float\n".encode())
    bounds = [0, len(head), len(body)]
    body += b"".join(struct.pack(">3f", *p) for p in POINTS)
    cells_at = len(body)
    body += f"\nCELLS {m} {5 * m}\n".encode()
    bounds += [cells_at, len(body)]
    body += b"".join(struct.pack(">5i", 4, *t) for t in TETS)
    types_at = len(body)
    body += f"\nCELL_TYPES {m}\n".encode()
    bounds += [types_at, len(body)]
    body += struct.pack(f">{m}i", *([10] * m))
    data_at = len(body)
    body += f"\nPOINT_DATA {n}\nSCALARS s float 1\nLOOKUP_TABLE default\n".encode()
    bounds += [data_at, len(body)]
    scalars_at = len(body)
    body += struct.pack(f">{n}f", *SCALARS) + b"\n"
    text = body.decode("latin-1")
    fields = _token_fields(text, keys)
    seeds.append(Seed("vtk-binary", {"b.vtk": bytes(body)}, "b.vtk", "b.vtk", "mesh", fields, bounds,
                      (scalars_at, scalars_at + 4 * n)))
    return seeds


def _gmsh_token_must(fmt, section, prev, line, k):
    """Whether an absurd value of token k of a gmsh line must be refused; None: not a field. Tags (element and
    entity numbers, physical groups) are not read, so they may take any value."""
    counts = prev.startswith("$") and not prev.startswith("$End")
    v41 = fmt == "gmsh-4.1"
    if section == "$MeshFormat":
        return k < 2
    if counts:  # the count line after a section opener
        return k < 2
    if v41 and section in ("$Nodes", "$Elements") and re.fullmatch(r"3 1 \d+ \d+", line):  # a block header
        return k >= 2
    if section == "$Elements" and re.fullmatch(r"\d+( \d+){4,}", line):
        # 2.2: the tag count may change with the tags (a line's extra numbers are not read).
        return k >= 1 if v41 else k == 1 or k >= 5
    return None


def gmsh_seeds():
    n, m = len(POINTS), len(TETS)
    nodes22 = f"$Nodes\n{n}\n" + "".join(f"{i + 1} {x} {y} {z}\n" for i, (x, y, z) in enumerate(POINTS)) + "$EndNodes\n"
    elems22 = (f"$Elements\n{m}\n" + "".join(f"{t + 1} 4 2 0 1 " + " ".join(str(v + 1) for v in tet) + "\n"
                                             for t, tet in enumerate(TETS)) + "$EndElements\n")
    data = ("$NodeData\n1\n\"s\"\n1\n0\n3\n0\n1\n" + f"{n}\n" +
            "".join(f"{i + 1} {s:g}\n" for i, s in enumerate(SCALARS)) + "$EndNodeData\n")
    v22 = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n" + nodes22 + elems22 + data
    ents = "$Entities\n0 0 0 1\n1 0 0 0 1 1 1 0 0\n$EndEntities\n"
    nodes41 = (f"$Nodes\n1 {n} 1 {n}\n3 1 0 {n}\n" + "".join(f"{i + 1}\n" for i in range(n)) +
               "".join(f"{x} {y} {z}\n" for x, y, z in POINTS) + "$EndNodes\n")
    elems41 = (f"$Elements\n1 {m} 1 {m}\n3 1 4 {m}\n" +
               "".join(f"{t + 1} " + " ".join(str(v + 1) for v in tet) + "\n" for t, tet in enumerate(TETS)) +
               "$EndElements\n")
    v41 = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n" + ents + nodes41 + elems41 + data
    seeds = []
    for fmt, text in (("gmsh-2.2", v22), ("gmsh-4.1", v41)):
        fields = []
        lines = text.split("\n")
        at, section = 0, ""
        for i, line in enumerate(lines):
            prev = lines[i - 1] if i else ""
            if line.startswith("$"):
                section = line
            elif line and section != "$Entities":
                for k, mt in enumerate(re.finditer(r"\S+", line)):
                    must = _gmsh_token_must(fmt, section, prev, line, k)
                    if must is not None:
                        fields.append(Field(f"line {i + 1} token {k}", at + mt.start(), len(mt.group()), TEXT, must))
            at += len(line) + 1
        seeds.append(Seed(fmt, {"m.msh": text.encode()}, "m.msh", "m.msh", "mesh", fields, _bounds(text), (0, 0),
                          text_ws_ok=True))
    return seeds


def mesh_seeds():
    return vtk_seeds() + gmsh_seeds()
