"""Mutations of a seed for the ingest fuzzer: truncation at every structure boundary (and a few cuts in the data),
absurd values in every known header field (0, -1, the largest value, NaN, Inf, huge, garbage text), JSON values of
the wrong size or type in a store's metadata, and random bit and byte flips. Each mutant says whether it must be
refused (`must`) or may be accepted (a flip in voxel data, a field no reader uses)."""

import json
import math
import struct
from dataclasses import dataclass

from fuzz.seeds import FLOAT, INT, TEXT


@dataclass
class Mutant:
    fmt: str
    label: str  # what was done, e.g. "truncate@352", "field dim[1]=-1", "flip bit 3 @ 17"
    data: bytes  # the mutated target file
    must: bool  # an input that must be refused


# Absurd values by encoding: (label, value). Integers are written in the field's size (two's complement).
_INT_VALUES = [("0", 0), ("-1", -1), ("max", None), ("min", "min")]
_FLOAT_VALUES = [("0", 0.0), ("-1", -1.0), ("nan", math.nan), ("inf", math.inf), ("huge", 3.0e38)]
_TEXT_VALUES = [("0", "0"), ("-1", "-1"), ("max", "4294967295"), ("nan", "nan"), ("huge", "1e308"),
                ("overflow", "99999999999999999999"), ("empty", ""), ("x", "x")]
_FIXED_TEXT = ("dicom", "nifti", "openvdb")  # binary containers: a text value keeps its length


def _int_bytes(value, size):
    if value is None:  # the largest unsigned value: all bits set but the sign's for a 2-byte field
        return b"\xff" * size
    if value == "min":
        return b"\0" * (size - 1) + b"\x80"
    return (value % (1 << (8 * size))).to_bytes(size, "little")


def _must(field, label):
    return field.must if isinstance(field.must, bool) else label in field.must


def field_mutants(seed, data):
    out = []
    for f in seed.fields:
        if f.offset + f.size > len(data):
            continue
        if f.enc in (INT, "uint") or (f.enc == FLOAT and f.size not in (4, 8)):
            values = [(label, _int_bytes(v, f.size)) for label, v in _INT_VALUES]
        elif f.enc == FLOAT:
            values = [(label, struct.pack("<f" if f.size == 4 else "<d", v)) for label, v in _FLOAT_VALUES]
        elif seed.fmt.startswith(_FIXED_TEXT):
            values = [(label, v.encode().ljust(f.size, b" ")[:f.size]) for label, v in _TEXT_VALUES if f.size]
        else:
            values = [(label, v.encode()) for label, v in _TEXT_VALUES]
        for label, raw in values:
            if raw == data[f.offset:f.offset + f.size]:
                continue
            mutated = data[:f.offset] + raw + data[f.offset + f.size:]
            out.append(Mutant(seed.fmt, f"field {f.name}={label}", mutated, _must(f, label)))
    return out


def truncation_mutants(seed, data):
    cuts = sorted({b for b in seed.bounds if 0 <= b < len(data)})
    out = []
    for at in cuts:
        removed = data[at:]
        harmless = seed.text_ws_ok and removed.strip() == b""
        out.append(Mutant(seed.fmt, f"truncate@{at}", data[:at], not harmless))
    return out


def _json_leaves(value, path=()):
    """Paths to the leaves of a JSON document (the first two items of a list stand for it)."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _json_leaves(v, path + (k,))
    elif isinstance(value, list) and value:
        yield path
        for i, v in enumerate(value[:2]):
            yield from _json_leaves(v, path + (i,))
    else:
        yield path


# Which values of a metadata key must be refused: a value of the wrong JSON type (null, text, a list) for every key a
# reader reads; of the numbers 0, -1, 4294967295 and 1e308 those listed (the others may be valid: a background of
# 0, a spacing of 4294967295). Keys no reader reads (a description, sums shown by info) may take anything.
_WRONG_TYPE = ("null", "x", "list")
_ALL_NUMBERS = ("0", "-1", "max", "huge")
_JSON_MUST = {
    "store-json": {"format": _ALL_NUMBERS, "version": _ALL_NUMBERS, "dims": _ALL_NUMBERS,
                   "spacing": ("0", "-1", "huge"), "type": _ALL_NUMBERS, "brick_size": _ALL_NUMBERS,
                   "levels": _ALL_NUMBERS, "bytes_raw": _ALL_NUMBERS, "vdb_files": _ALL_NUMBERS,
                   "active_voxels": ("-1", "max", "huge"), "bytes_stored": ("-1",), "bytes_vdb": ("-1",),
                   "value_range": (), "background": (), "histogram": (), "nonfinite_replaced": ("-1",)},
    "meshstore-json": {"format": _ALL_NUMBERS, "version": _ALL_NUMBERS, "field": _ALL_NUMBERS,
                       "vertices": _ALL_NUMBERS, "tets": _ALL_NUMBERS, "boundaryFaces": _ALL_NUMBERS,
                       "chunks": _ALL_NUMBERS, "tetsPerChunk": ("0", "-1"), "zstdLevel": (),
                       "edgeLengths": ("0", "-1")},
}
_JSON_VALUES = [("0", 0), ("-1", -1), ("max", 4294967295), ("huge", 1e308), ("null", None), ("x", "x"), ("list", [])]


def _json_must(fmt, path, label, old):
    rules = _JSON_MUST.get(fmt, {})
    if path[0] not in rules or path[-1] == "bricks_total":  # a level's bricks_total is written for people, not read
        return False
    if label in _WRONG_TYPE:
        return not (label == "x" and isinstance(old, str)) and not (label == "list" and isinstance(old, list))
    return label in rules[path[0]]


def json_mutants(seed, data):
    doc = json.loads(data)
    out = []
    for path in _json_leaves(doc):
        if not path:
            continue
        for label, value in _JSON_VALUES:
            mutated = json.loads(data)
            node = mutated
            for p in path[:-1]:
                node = node[p]
            old = node[path[-1]]
            if old == value:
                continue
            node[path[-1]] = value
            name = "/".join(str(p) for p in path)
            must = _json_must(seed.fmt, path, label, old)
            out.append(Mutant(seed.fmt, f"json {name}={label}", json.dumps(mutated, indent=1).encode(), must))
    text = data.decode()
    for k in range(1, 9):  # cuts through the text: no longer JSON
        at = len(text) * k // 9
        out.append(Mutant(seed.fmt, f"truncate@{at}", data[:at], True))
    return out


def flip_mutant(seed, data, rng):
    """One random flip: a bit, a byte set to 0x00/0xFF/random, anywhere in the file. Only a checksummed file must
    refuse it: a flip elsewhere may leave a valid input (a voxel's value, a description's letter)."""
    if not data:
        return None
    at = rng.randrange(len(data))
    kind = rng.randrange(4)
    b = bytearray(data)
    if kind == 0:
        bit = rng.randrange(8)
        b[at] ^= 1 << bit
        label = f"flip bit {bit} @{at}"
    else:
        value = (0, 0xFF, rng.randrange(256))[kind - 1]
        if b[at] == value:
            value ^= 0x55
        b[at] = value
        label = f"set byte @{at}={value:#04x}"
    return Mutant(seed.fmt, label, bytes(b), seed.guarded and not seed.unguarded[0] <= at < seed.unguarded[1])


def systematic_mutants(seed):
    """Every truncation and absurd field (or JSON value) of a seed, in a fixed order."""
    data = seed.files[seed.target]
    if seed.target.endswith(".json"):
        return json_mutants(seed, data)
    return truncation_mutants(seed, data) + field_mutants(seed, data)


__all__ = ["Mutant", "systematic_mutants", "flip_mutant", "TEXT"]
