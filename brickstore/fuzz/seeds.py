"""Seed inputs for the ingest fuzzer (brickstore/fuzz/fuzz_ingest.py), written here with the Python standard library:
small volume files (NIfTI-1 plain and gzip, NRRD attached raw and gzip, NRRD detached, a multi-page TIFF, DICOM
series in explicit VR little endian, RLE and deflated transfer syntaxes) and tetrahedral meshes (VTK legacy ASCII and
binary, gmsh 2.2 and 4.1 ASCII). Each seed lists its header fields (offset, size, encoding) and its structure
boundaries, so mutations can aim at them; stores and OpenVDB files come from `voxbrick prep` (store_seeds.py)."""

import gzip
import struct
import zlib
from dataclasses import dataclass, field

# How a field's bytes are written: little-endian integers and floats of their size, or text.
INT, UINT, FLOAT, TEXT = "int", "uint", "float", "text"


@dataclass
class Field:
    """A header field of the mutated file: `size` bytes at `offset`. `must` says an absurd value there must be
    refused (the readers use it); otherwise the mutant may be accepted."""
    name: str
    offset: int
    size: int
    enc: str
    must: object = True  # True, False, or the labels of the absurd values that must be refused


@dataclass
class Seed:
    """One input: `files` (relative path -> bytes) written into the mutant's input directory; `target` is the file
    mutated and `arg` what is given to voxbrick ("" for the directory itself). `kind` picks the commands run."""
    fmt: str
    files: dict
    target: str
    arg: str
    kind: str  # volume, vdb, mesh, store, meshstore
    fields: list = field(default_factory=list)
    bounds: list = field(default_factory=list)  # offsets where a truncation cuts between structures
    data: tuple = (0, 0)  # [start, end) of voxel or cell data: flips there may leave a valid input
    text_ws_ok: bool = False  # a text format: a truncation that removes only whitespace leaves it valid
    guarded: bool = False  # a checksum covers every byte: any change must be refused (by render, at least)
    unguarded: tuple = (0, 0)  # [start, end) of bytes no checksum covers and no reader reads (reserved)
    extra: list = field(default_factory=list)  # command-line options for prep


def _volume_values(nx, ny, nz):
    """A small smooth pattern, so readers see varied values."""
    return [(i * 7 + j * 13 + k * 29) % 251 for k in range(nz) for j in range(ny) for i in range(nx)]


# --- NIfTI-1 ----------------------------------------------------------------------------------------------------

def nifti_seeds():
    nx, ny, nz = 6, 5, 4
    hdr = bytearray(352)
    struct.pack_into("<i", hdr, 0, 348)
    struct.pack_into("<8h", hdr, 40, 3, nx, ny, nz, 1, 1, 1, 1)
    struct.pack_into("<hh", hdr, 70, 4, 16)  # int16
    struct.pack_into("<8f", hdr, 76, 1, 0.8, 0.9, 1.5, 1, 1, 1, 1)
    struct.pack_into("<fff", hdr, 108, 352.0, 1.0, 0.0)  # vox_offset, scl_slope, scl_inter
    struct.pack_into("<hh", hdr, 252, 1, 1)  # qform_code, sform_code
    struct.pack_into("<3f3f", hdr, 256, 0, 0, 0, -2.0, 3.0, 4.0)
    struct.pack_into("<12f", hdr, 280, 0.8, 0, 0, -2.0, 0, 0.9, 0, 3.0, 0, 0, 1.5, 4.0)
    hdr[344:348] = b"n+1\0"
    data = struct.pack(f"<{nx * ny * nz}h", *[v - 100 for v in _volume_values(nx, ny, nz)])
    body = bytes(hdr) + data
    fields = [Field("sizeof_hdr", 0, 4, INT), Field("dim[0]", 40, 2, INT)]
    fields += [Field(f"dim[{k}]", 40 + 2 * k, 2, INT) for k in (1, 2, 3)]
    fields += [Field(f"dim[{k}]", 40 + 2 * k, 2, INT, must=False) for k in (4, 5)]
    fields += [Field("datatype", 70, 2, INT), Field("bitpix", 72, 2, INT, must=False)]
    fields += [Field(f"pixdim[{k}]", 76 + 4 * k, 4, FLOAT, must=False) for k in range(4)]  # sform wins
    fields += [Field("vox_offset", 108, 4, FLOAT, must=("-1", "nan", "inf", "huge")), Field("scl_slope", 112, 4, FLOAT, must=False),
               Field("scl_inter", 116, 4, FLOAT, must=False), Field("qform_code", 252, 2, INT, must=False),
               Field("sform_code", 254, 2, INT, must=False)]
    fields += [Field(f"quatern/qoffset[{k}]", 256 + 4 * k, 4, FLOAT, must=False) for k in range(6)]
    fields += [Field(f"srow[{k}]", 280 + 4 * k, 4, FLOAT, must=False) for k in range(12)]
    fields += [Field("magic", 344, 4, TEXT)]
    bounds = [0, 4, 40, 56, 70, 76, 108, 112, 252, 256, 280, 328, 344, 348, 352, 353, 352 + len(data) // 2]
    plain = Seed("nifti", {"v.nii": body}, "v.nii", "v.nii", "volume", fields, bounds, (352, len(body)))
    gz = Seed("nifti-gz", {"v.nii.gz": gzip.compress(body, mtime=0)}, "v.nii.gz", "v.nii.gz", "volume", [],
              [0, 2, 3, 4, 10, 20, 40], (0, 0))
    return [plain, gz]


# --- NRRD -------------------------------------------------------------------------------------------------------

def _text_fields(text, specs, must_default=True):
    """Fields of a text header: for each (name, regex-free key) the value after 'key' up to the line's end."""
    fields = []
    for name, key, must in specs:
        at = text.find(key)
        if at < 0:
            continue
        start = at + len(key)
        end = text.find("\n", start)
        fields.append(Field(name, start, end - start, TEXT, must if must is not None else must_default))
    return fields


def _line_bounds(text, limit=None):
    out, at = [0], 0
    while True:
        at = text.find("\n", at)
        if at < 0 or (limit is not None and at >= limit):
            return out
        at += 1
        out.append(at)


NRRD_KEYS = [("type", "type: ", True), ("dimension", "dimension: ", True), ("sizes", "sizes: ", True),
             ("space", "space: ", True), ("space directions", "space directions: ", True),
             ("space origin", "space origin: ", None), ("encoding", "encoding: ", True),
             ("endian", "endian: ", True), ("spacings", "spacings: ", True), ("byte skip", "byte skip: ", ("nan", "huge", "x")),
             ("data file", "data file: ", True)]


def nrrd_seeds():
    nx, ny, nz = 6, 5, 4
    data = struct.pack(f"<{nx * ny * nz}H", *[v * 3 for v in _volume_values(nx, ny, nz)])
    base = (f"NRRD0004\ntype: ushort\ndimension: 3\nsizes: {nx} {ny} {nz}\nspace: left-posterior-superior\n"
            "space directions: (0.8,0,0) (0,0.9,0) (0,0,1.5)\nspace origin: (1,2,3)\n")
    seeds = []
    attached = base + "endian: little\nencoding: raw\n\n"
    seeds.append(Seed("nrrd", {"v.nrrd": attached.encode() + data}, "v.nrrd", "v.nrrd", "volume",
                      _text_fields(attached, NRRD_KEYS), _line_bounds(attached) + [len(attached) + 9],
                      (len(attached), len(attached) + len(data))))
    gzipped = base + "endian: little\nencoding: gzip\n\n"
    seeds.append(Seed("nrrd-gzip", {"g.nrrd": gzipped.encode() + gzip.compress(data, mtime=0)}, "g.nrrd", "g.nrrd",
                      "volume", _text_fields(gzipped, NRRD_KEYS), _line_bounds(gzipped) + [len(gzipped) + 10],
                      (len(gzipped) + 10, len(gzipped) + 20)))
    spacing = f"NRRD0004\ntype: ushort\ndimension: 3\nsizes: {nx} {ny} {nz}\nspacings: 0.5 0.5 2\n"
    detached = spacing + "endian: little\nencoding: raw\ndata file: d.raw\n"
    seeds.append(Seed("nrrd-detached", {"d.nhdr": detached.encode(), "d.raw": data}, "d.nhdr", "d.nhdr", "volume",
                      _text_fields(detached, NRRD_KEYS), _line_bounds(detached), (0, 0), text_ws_ok=True))
    seeds.append(Seed("nrrd-detached-data", {"d.nhdr": detached.encode(), "d.raw": data}, "d.raw", "d.nhdr",
                      "volume", [], [0, 1, len(data) // 2, len(data) - 1], (0, len(data))))
    return seeds


# --- TIFF -------------------------------------------------------------------------------------------------------

# Which absurd values of a TIFF tag must be refused: a strip at offset 0 is still inside the file, one strip of
# 0xFFFFFFFF rows is the whole page, and libtiff estimates a missing strip size.
_TIFF_MUST = {"Compression": ("0", "-1", "max"), "PlanarConfiguration": False, "PhotometricInterpretation": False,
              "StripOffsets": ("-1", "max"), "RowsPerStrip": ("0",), "StripByteCounts": False, "SampleFormat": False}


def tiff_seed():
    """Three 6x5 uint16 pages, classic little-endian TIFF, one strip a page."""
    nx, ny, pages = 6, 5, 3
    values = _volume_values(nx, ny, pages)
    out = bytearray(b"II*\0\0\0\0\0")
    fields, bounds = [Field("first IFD offset", 4, 4, UINT)], [0, 2, 4, 8]
    ifd_link = 4
    tags = [(256, 3, nx, "ImageWidth"), (257, 3, ny, "ImageLength"), (258, 3, 16, "BitsPerSample"),
            (259, 3, 1, "Compression"), (262, 3, 1, "PhotometricInterpretation"), (273, 4, 0, "StripOffsets"),
            (277, 3, 1, "SamplesPerPixel"), (278, 4, ny, "RowsPerStrip"), (279, 4, nx * ny * 2, "StripByteCounts"),
            (284, 3, 1, "PlanarConfiguration"), (339, 3, 1, "SampleFormat")]
    for p in range(pages):
        strip = len(out)
        out += struct.pack(f"<{nx * ny}H", *[v * 100 for v in values[p * nx * ny:(p + 1) * nx * ny]])
        ifd = len(out)
        struct.pack_into("<I", out, ifd_link, ifd)
        bounds += [strip, ifd, ifd + 2]
        out += struct.pack("<H", len(tags))
        fields.append(Field(f"page {p + 1} entry count", ifd, 2, UINT))
        for tag, typ, value, name in tags:
            entry = len(out)
            value = strip if tag == 273 else value
            out += struct.pack("<HHI", tag, typ, 1)
            out += struct.pack("<HH", value, 0) if typ == 3 else struct.pack("<I", value)
            fields += [Field(f"page {p + 1} {name} type", entry + 2, 2, UINT, must=False),
                       Field(f"page {p + 1} {name} count", entry + 4, 4, UINT, must=False),
                       Field(f"page {p + 1} {name}", entry + 8, 2 if typ == 3 else 4, UINT,
                             must=_TIFF_MUST.get(name, True))]
            if p < pages - 1 or tag != tags[-1][0]:  # cut before the last offset (0): libtiff reads the chain's end
                bounds.append(entry + 12)
        ifd_link = len(out)
        # 0 ends the chain: a shorter, valid file.
        fields.append(Field(f"page {p + 1} next IFD offset", ifd_link, 4, UINT, must=("-1", "max", "min")))
        out += b"\0\0\0\0"
    return Seed("tiff", {"s.tif": bytes(out)}, "s.tif", "s.tif", "volume", fields, bounds, (8, 8 + nx * ny * 2))


# --- DICOM ------------------------------------------------------------------------------------------------------

LONG_VRS = {"OB", "OW", "OF", "SQ", "UT", "UN"}
TS_EXPLICIT, TS_RLE, TS_DEFLATED = "1.2.840.10008.1.2.1", "1.2.840.10008.1.2.5", "1.2.840.10008.1.2.1.99"


def _element(group, elem, vr, value):
    """An explicit VR little-endian element; returns (bytes, offset of the value's length field, value offset)."""
    if isinstance(value, str):
        value = value.encode()
        value += (b"\0" if vr == "UI" else b" ") * (len(value) % 2)
    head = struct.pack("<HH", group, elem) + vr.encode()
    if vr in LONG_VRS:
        length = 0xFFFFFFFF if value is None else len(value)
        head += b"\0\0" + struct.pack("<I", length)
        return head + (value or b""), 8, 12
    return head + struct.pack("<H", len(value)) + value, 6, 8


def _rle_fragment(pixels16, nx, ny):
    """DICOM RLE: two segments (high bytes, then low bytes), each row a literal PackBits run."""
    segments = []
    for shift in (8, 0):
        seg = bytearray()
        for y in range(ny):
            row = bytes((v >> shift) & 0xFF for v in pixels16[y * nx:(y + 1) * nx])
            seg += bytes([len(row) - 1]) + row
        if len(seg) % 2:
            seg += b"\0"
        segments.append(bytes(seg))
    header = struct.pack("<I", 2) + struct.pack("<I", 64) + struct.pack("<I", 64 + len(segments[0])) + bytes(52)
    return header + segments[0] + segments[1]


DICOM_FIELDS = {(0x0028, 0x0010): ("Rows", True), (0x0028, 0x0011): ("Columns", True),
                (0x0028, 0x0100): ("BitsAllocated", True), (0x0028, 0x0101): ("BitsStored", True),
                (0x0028, 0x0102): ("HighBit", True), (0x0028, 0x0103): ("PixelRepresentation", False),
                (0x0028, 0x0002): ("SamplesPerPixel", True), (0x0028, 0x0030): ("PixelSpacing", True),
                (0x0020, 0x0032): ("ImagePositionPatient", True), (0x0020, 0x0037): ("ImageOrientationPatient", True),
                (0x0028, 0x1053): ("RescaleSlope", False), (0x0028, 0x1052): ("RescaleIntercept", False),
                (0x0020, 0x000E): ("SeriesInstanceUID", False), (0x0002, 0x0010): ("TransferSyntaxUID", True),
                (0x0028, 0x0004): ("PhotometricInterpretation", False), (0x0028, 0x0008): ("NumberOfFrames", True)}


def dicom_slice(k, nx, ny, syntax):
    """One slice file; returns (bytes, fields, bounds, pixel data range)."""
    uid = f"1.2.826.0.1.3680043.9.7777.2.{k + 1}"
    pixels = [(v * 5 + 100) for v in _volume_values(nx, ny, 4)[k * nx * ny:(k + 1) * nx * ny]]
    meta_elems = [(0x0002, 0x0001, "OB", b"\0\1"), (0x0002, 0x0002, "UI", "1.2.840.10008.5.1.4.1.1.2"),
                  (0x0002, 0x0003, "UI", uid), (0x0002, 0x0010, "UI", syntax),
                  (0x0002, 0x0012, "UI", "1.2.826.0.1.3680043.9.7777.9")]
    native = struct.pack(f"<{nx * ny}h", *pixels)
    if syntax == TS_RLE:
        frag = _rle_fragment(pixels, nx, ny)
        pixel_value = (struct.pack("<HHI", 0xFFFE, 0xE000, 0) + struct.pack("<HHI", 0xFFFE, 0xE000, len(frag)) + frag +
                       struct.pack("<HHI", 0xFFFE, 0xE0DD, 0))
        pixel = _element(0x7FE0, 0x0010, "OB", None)[0] + pixel_value
    else:
        pixel = _element(0x7FE0, 0x0010, "OW", native)[0]
    ds_elems = [(0x0008, 0x0016, "UI", "1.2.840.10008.5.1.4.1.1.2"), (0x0008, 0x0018, "UI", uid),
                (0x0008, 0x0060, "CS", "CT"), (0x0008, 0x103E, "LO", "fuzz seed"), (0x0010, 0x0010, "PN", "Fuzz^Seed"),
                (0x0020, 0x000D, "UI", "1.2.826.0.1.3680043.9.7777.3"),
                (0x0020, 0x000E, "UI", "1.2.826.0.1.3680043.9.7777.4"), (0x0020, 0x0013, "IS", str(k + 1)),
                (0x0020, 0x0032, "DS", f"-10\\-20\\{30 + 2.5 * k:g}"), (0x0020, 0x0037, "DS", "1\\0\\0\\0\\1\\0"),
                (0x0028, 0x0002, "US", struct.pack("<H", 1)), (0x0028, 0x0004, "CS", "MONOCHROME2"),
                (0x0028, 0x0010, "US", struct.pack("<H", ny)), (0x0028, 0x0011, "US", struct.pack("<H", nx)),
                (0x0028, 0x0030, "DS", "0.7\\0.6"), (0x0028, 0x0100, "US", struct.pack("<H", 16)),
                (0x0028, 0x0101, "US", struct.pack("<H", 12)), (0x0028, 0x0102, "US", struct.pack("<H", 11)),
                (0x0028, 0x0103, "US", struct.pack("<H", 1)), (0x0028, 0x1052, "DS", "-1024"),
                (0x0028, 0x1053, "DS", "1")]
    fields, bounds = [], [0, 128, 132]

    def emit(elems, base):
        blob = bytearray()
        for g, e, vr, value in elems:
            at = base + len(blob)
            raw, len_at, val_at = _element(g, e, vr, value)
            name, must = DICOM_FIELDS.get((g, e), (f"({g:04X},{e:04X})", False))
            fields.append(Field(f"{name} length", at + len_at, 4 if vr in LONG_VRS else 2, UINT, must))
            fields.append(Field(f"{name} VR", at + 4, 2, TEXT, True))
            enc = UINT if vr == "US" else TEXT
            fields.append(Field(name, at + val_at, len(raw) - val_at, enc, must and (g, e) in DICOM_FIELDS))
            bounds.extend([at, at + 4, at + val_at])
            blob += raw
        return bytes(blob)

    meta_body = emit(meta_elems, 132 + 12)
    meta = _element(0x0002, 0x0000, "UL", struct.pack("<I", len(meta_body)))[0]
    fields.append(Field("FileMetaInformationGroupLength", 132 + 8, 4, UINT, must=False))
    head = b"\0" * 128 + b"DICM" + meta + meta_body
    if syntax == TS_DEFLATED:
        dataset = bytes(emit(ds_elems, 0)) + pixel
        fields.clear()
        bounds = [0, 128, 132, len(head)]
        c = zlib.compressobj(9, zlib.DEFLATED, -15)
        body = head + c.compress(dataset) + c.flush()
        bounds += [len(head) + 4, len(head) + 16, len(body) - 8]
        return body, fields, bounds, (0, 0)
    ds = emit(ds_elems, len(head))
    pixel_at = len(head) + len(ds)
    fields.append(Field("PixelData length", pixel_at + 8, 4, UINT, True))
    bounds.append(pixel_at)
    if syntax == TS_RLE:
        fields.append(Field("RLE fragment length", pixel_at + 12 + 8 + 4, 4, UINT, True))
        fields.append(Field("RLE segment count", pixel_at + 12 + 16, 4, UINT, True))
        bounds += [pixel_at + 12, pixel_at + 20, pixel_at + 28, pixel_at + 28 + 64]
    body = head + ds + pixel
    return body, fields, bounds, (pixel_at + 12 + (16 + 64 if syntax == TS_RLE else 0), len(body))


def dicom_seeds():
    seeds = []
    for fmt, syntax in (("dicom", TS_EXPLICIT), ("dicom-rle", TS_RLE), ("dicom-deflated", TS_DEFLATED)):
        files, target = {}, None
        for k in range(4):
            body, fields, bounds, data = dicom_slice(k, 6, 5, syntax)
            files[f"ct/im{k + 1}.dcm"] = body
            if k == 1:
                target = (fields, bounds, data)
        seeds.append(Seed(fmt, files, "ct/im2.dcm", "ct", "volume", *target))
    return seeds


def volume_seeds():
    return nifti_seeds() + nrrd_seeds() + [tiff_seed()] + dicom_seeds()
