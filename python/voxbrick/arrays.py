"""Stores from arrays: a NumPy array, a memory map, a Zarr array (or anything sliced like one: h5py, dask) written
slab by slab as a raw file with a detached NRRD header, then `voxbrick prep` on it, the command line's own reader
and prep. Memory stays within about two slabs whatever the array's size. The same slabs are what Client.upload sends
a server (Volume).
"""
from __future__ import annotations

import math
import mmap
import numbers
import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Any, Dict, Iterator, NamedTuple, Optional, Sequence, Union

import numpy as np

from .errors import VoxbrickError

#: NRRD type names of the dtypes prep reads as they are (little- or big-endian).
_NRRD_TYPES = {'u1': 'uint8', 'i1': 'int8', 'u2': 'uint16', 'i2': 'int16', 'u4': 'uint32', 'i4': 'int32',
               'f4': 'float', 'f8': 'double'}
#: dtypes written converted: what they become.
_CONVERTED = {'b1': np.dtype('u1'), 'f2': np.dtype('f4'), 'i8': np.dtype('f8'), 'u8': np.dtype('f8')}


def find_voxbrick(exe: Union[str, os.PathLike, None] = None) -> str:
    """The voxbrick command to run: `exe` if given, else $VOXBRICK, else `voxbrick` on PATH. VoxbrickError saying
    where it looked when there is none."""
    for candidate, where in ((exe, 'the exe argument'), (os.environ.get('VOXBRICK'), '$VOXBRICK')):
        if candidate:
            path = shutil.which(os.fspath(candidate))
            if path is None:
                raise VoxbrickError(f'{where} names {os.fspath(candidate)!r}, which is not an executable file')
            return path
    path = shutil.which('voxbrick')
    if path is None:
        raise VoxbrickError('voxbrick not found: pass exe="path/to/voxbrick", set $VOXBRICK, or put it on PATH '
                            '(a build makes build/voxbrick)')
    return path


def _vector(value: Any, what: str, positive: bool) -> list:
    if isinstance(value, (str, bytes)) or not hasattr(value, '__len__') or len(value) != 3:
        raise ValueError(f'{what} {value!r}: expected three numbers (x, y, z)')
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(v) or (positive and v <= 0):
            raise ValueError(f'{what} {value!r}: each must be a finite{" positive" if positive else ""} number')
        out.append(float(v))
    return out


def _memmap_file_offset(array: np.ndarray) -> Optional[int]:
    """Where a C-contiguous np.memmap (or a view of one) starts in its file, or None if it is not one, or if its file
    may not hold its values: a copy-on-write map (mode "c") keeps its changes in memory."""
    if not isinstance(array, np.memmap) or getattr(array, 'filename', None) is None or array.mode == 'c':
        return None
    buffer = getattr(array, '_mmap', None)
    if buffer is None or not array.flags.c_contiguous:
        return None
    start = np.frombuffer(buffer, dtype=np.uint8).__array_interface__['data'][0]
    # np.memmap maps from the offset rounded down to the allocation granularity.
    mapped_from = array.offset - array.offset % mmap.ALLOCATIONGRANULARITY
    return array.__array_interface__['data'][0] - start + mapped_from


class Volume(NamedTuple):
    """A 3-D array checked for prep or upload, and how its voxels are laid out for them: `dims` (x, y, z), `axis`
    (the array axis of each letter), `stored` (the dtype written: the array's, or what _CONVERTED makes of it),
    `spacing` and `origin` in x, y, z order (origin None: the volume centred on the origin)."""

    array: Any
    dims: tuple
    axis: Dict[str, int]
    stored: np.dtype
    spacing: list
    origin: Optional[list]
    patient: bool

    @property
    def type_name(self) -> str:
        """The stored type's NRRD name (uint8, ..., float, double)."""
        return _NRRD_TYPES[self.stored.kind + str(self.stored.itemsize)]

    @property
    def endian(self) -> str:
        """"little" or "big": the stored voxels' byte order."""
        order = self.stored.byteorder if self.stored.byteorder in '<>' else ('<' if np.little_endian else '>')
        return 'big' if order == '>' else 'little'

    @property
    def nbytes(self) -> int:
        """The stored voxels' size in bytes."""
        return math.prod(self.dims) * self.stored.itemsize

    def slabs(self, slab_bytes: int) -> Iterator[memoryview]:
        """The voxels as `stored`, x fastest then y then z, as bytes: one buffer per slab of z-slices of at most about
        `slab_bytes` (whole chunks of a Zarr array along z where they fit), each valid until the next is taken.

        A memory map (or an array viewing one) is read a piece at a time, each piece's pages dropped from this process
        once taken (_Mapping): a page of a file map stays in the resident set once read, and a 4 GiB map read through
        would otherwise leave 4 GiB resident."""
        nx, ny, nz = self.dims
        array, axis, stored = self.array, self.axis, self.stored
        slice_bytes = nx * ny * max(stored.itemsize, np.dtype(array.dtype).itemsize)
        thickness = max(1, slab_bytes // slice_bytes)
        chunks = getattr(array, 'chunks', None)  # a Zarr (or dask) array's chunk shape: read whole chunks along z
        if isinstance(chunks, tuple) and len(chunks) == 3 and all(isinstance(c, int) for c in chunks):
            along = chunks[axis['z']]
            if along <= thickness:
                thickness = thickness // along * along
        # The array's axes in the file's order, slowest first: z, y, x.
        order = (axis['z'], axis['y'], axis['x'])
        mapping = _Mapping.of(array)
        for z0 in range(0, nz, thickness):
            index = [slice(None)] * 3
            index[axis['z']] = slice(z0, min(nz, z0 + thickness))
            slab = np.asarray(array[tuple(index)]).transpose(order)
            if mapping is None:
                yield memoryview(np.ascontiguousarray(slab, dtype=stored)).cast('B')
            elif slab.flags.c_contiguous and slab.dtype == stored:
                yield memoryview(slab).cast('B')  # straight from the map
                mapping.drop(slab)
            else:
                yield memoryview(mapping.gather(slab, stored, slab_bytes)).cast('B')

    def meta(self) -> Dict[str, Any]:
        """The voxels' description as an Upload's meta_json takes it (PROTOCOL.md, Upload): the same volume the NRRD
        header of nrrd_header() describes."""
        meta: Dict[str, Any] = {'dims': list(self.dims), 'type': self.type_name, 'endian': self.endian,
                                'spacing': self.spacing}
        if self.origin is not None:
            meta['origin'] = self.origin
        if self.patient:
            meta['patient'] = True
        return meta

    def nrrd_header(self, data_file: str, byte_skip: int = 0) -> str:
        """A detached NRRD header of the voxels in `data_file` (x fastest, as `stored`), from `byte_skip` on."""
        nx, ny, nz = self.dims
        spacing, origin = self.spacing, self.origin
        lines = ['NRRD0004', '# written by voxbrick.prep from an array', f'type: {self.type_name}', 'dimension: 3',
                 f'sizes: {nx} {ny} {nz}', 'encoding: raw', f'endian: {self.endian}', f'data file: {data_file}']
        if byte_skip:
            lines.append(f'byte skip: {byte_skip}')
        if origin is not None:
            lines += [f'space: {"RAS" if self.patient else "3D-right-handed"}',
                      f'space directions: ({spacing[0]!r},0,0) (0,{spacing[1]!r},0) (0,0,{spacing[2]!r})',
                      f'space origin: ({origin[0]!r},{origin[1]!r},{origin[2]!r})']
        else:
            lines.append(f'spacings: {spacing[0]!r} {spacing[1]!r} {spacing[2]!r}')
        return '\n'.join(lines) + '\n'


def as_volume(array: Any, *, spacing: Sequence[float] = (1, 1, 1), origin: Optional[Sequence[float]] = None,
              axes: str = 'zyx', patient: bool = False, slab_bytes: int = 64 << 20, purpose: str = 'prep') -> Volume:
    """`array` (anything with `shape`, `dtype` and NumPy slicing, or what np.asarray takes) checked as prep and upload
    take it; ValueError naming what is wrong, `purpose` ("prep", "upload") the one refusing. `patient=True` without
    an origin puts voxel (0, 0, 0) at the origin (RAS)."""
    if not hasattr(array, 'shape') or not hasattr(array, 'dtype'):
        array = np.asarray(array)
    shape = tuple(int(n) for n in array.shape)
    dtype = np.dtype(array.dtype)
    if len(shape) != 3:
        raise ValueError(f'array of shape {shape}: {purpose} takes a 3-D volume; pick one first (e.g. array[0, 0] of '
                         'a t, c, z, y, x image)')
    if 0 in shape:
        raise ValueError(f'array of shape {shape}: empty')
    if not isinstance(axes, str) or sorted(axes) != ['x', 'y', 'z']:
        raise ValueError(f'axes {axes!r}: the letters x, y and z in the order of the array\'s axes, e.g. "zyx"')
    spacing = _vector(spacing, 'spacing', positive=True)
    origin = None if origin is None else _vector(origin, 'origin', positive=False)
    if isinstance(slab_bytes, bool) or not isinstance(slab_bytes, int) or slab_bytes < 1:
        raise ValueError(f'slab_bytes {slab_bytes!r}: a positive number of bytes')
    kind = dtype.kind + str(dtype.itemsize)
    if kind not in _NRRD_TYPES and kind not in _CONVERTED:
        raise ValueError(f'array of dtype {dtype}: {purpose} takes integers, floats and bools (convert it first, e.g. '
                         'array.astype(np.float32))')
    # Array axis of x, y and z; the voxels' order is x fastest, then y, then z.
    axis = {letter: axes.index(letter) for letter in 'xyz'}
    if origin is None and patient:
        origin = [0.0, 0.0, 0.0]
    return Volume(array, (shape[axis['x']], shape[axis['y']], shape[axis['z']]), axis, _CONVERTED.get(kind, dtype),
                  spacing, origin, bool(patient))


def prep(array: Any, out: Union[str, os.PathLike], *, spacing: Sequence[float] = (1, 1, 1),
         origin: Optional[Sequence[float]] = None, axes: str = 'zyx', patient: bool = False,
         exe: Union[str, os.PathLike, None] = None, brick: Optional[int] = None, quantise: Optional[str] = None,
         vdb: bool = True, force: bool = False, extra_args: Sequence[str] = (),
         work: Union[str, os.PathLike, None] = None, slab_bytes: int = 64 << 20, quiet: bool = True) -> Path:
    """Writes the brick store `out` from a 3-D array, with `voxbrick prep` (the command line's prep); returns `out`.

    `array`: a NumPy array or memory map, a Zarr array, or anything with `shape`, `dtype` and NumPy slicing.
    `axes`: which array axis is x, y and z: "zyx" (the default: the last axis varies fastest, as NumPy, scikit-image
    and OME-Zarr lay out volumes) or any order of the three letters ("xyz" for arrays indexed [x, y, z], as
    nibabel's). `spacing` and `origin` are in x, y, z order: the voxel size and the world position of voxel
    (0, 0, 0); without `origin` the volume is centred on the origin (with `patient`, voxel (0, 0, 0) is at it).
    `patient=True`: x, y, z are RAS millimetres (right, anterior, superior), so named views mean the patient's.

    Values: uint8, uint16 and int16 are stored as they are; int8 as int16; int32, uint32, float32 and float64 as
    float32 (int64 and uint64 too, through float64; float16 through float32); bool as uint8. NaN and Inf become the
    background (prep's default). `quantise`: "u8" or "u16" stores fewer bits. `brick`, `vdb`, `force` are prep's
    --brick, --no-vdb (vdb=False) and --force; `extra_args` more of its options. `exe`: the voxbrick command
    (default $VOXBRICK, else PATH).

    The array is written to a raw file in `work` (default: a temporary directory beside `out`, removed after) a slab
    of at most `slab_bytes` at a time, whole chunks of a Zarr array along z where they fit; a C-contiguous memory map
    whose axes are "zyx" is read in place, not copied. VoxbrickError with prep's own message when it refuses."""
    command = find_voxbrick(exe)
    volume = as_volume(array, spacing=spacing, origin=origin, axes=axes, patient=patient, slab_bytes=slab_bytes)
    out = Path(out)
    if out.exists() and not force:
        raise VoxbrickError(f'{out} exists: pass force=True to replace it (once the new store is complete)')
    out.parent.mkdir(parents=True, exist_ok=True)

    if work is not None:
        Path(work).mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix='.voxbrick-prep-', dir=work or out.parent))
    try:
        name = out.name.split('.')[0] or 'array'
        header = scratch / f'{name}.nhdr'
        array = volume.array
        in_place = _memmap_file_offset(array) if axes == 'zyx' and volume.stored == array.dtype else None
        if in_place is not None:
            data_file, byte_skip = os.path.abspath(array.filename), in_place
        else:
            data_file, byte_skip = os.path.abspath(scratch / f'{name}.raw'), 0  # the header's folder is not the cwd
            _write_slabs(volume, data_file, slab_bytes)
        header.write_text(volume.nrrd_header(data_file, byte_skip))
        args = [command, 'prep', str(header), '-o', str(out)]
        args += ['-q'] if quiet else []
        args += ['--force'] if force else []
        args += ['--no-vdb'] if not vdb else []
        args += ['--brick', str(int(brick))] if brick is not None else []
        args += ['--quantise', str(quantise)] if quantise is not None else []
        args += [str(a) for a in extra_args]
        result = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if result.returncode != 0:
            said = (result.stderr.strip() or result.stdout.strip()).splitlines()
            raise VoxbrickError(f'voxbrick prep refused the array (exit {result.returncode}): '
                                f'{said[-1] if said else "no message"}')
        if not quiet and result.stdout:
            print(result.stdout, end='')
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return out


def _write_slabs(volume: Volume, path: str, slab_bytes: int) -> None:
    """The volume's voxels to the raw file `path` (Volume.slabs), a slab at a time."""
    with open(path, 'wb') as f:
        for buffer in volume.slabs(slab_bytes):
            f.write(buffer)


class _Mapping:
    """The shared file mapping under an np.memmap, whose pages this process may drop once read: the file (or the page
    cache) keeps them, and a later read maps them again. Not a copy-on-write map (mode "c"): dropping its pages would
    lose the changes made to it."""

    def __init__(self, buffer: mmap.mmap):
        self.buffer = buffer
        self.start = np.frombuffer(buffer, dtype=np.uint8).__array_interface__['data'][0]

    @classmethod
    def of(cls, array: Any) -> Optional['_Mapping']:
        """The mapping `array` views (an np.memmap, a view or slice of one, an ndarray whose base is one), or None."""
        if not hasattr(mmap, 'MADV_DONTNEED') or not hasattr(mmap.mmap, 'madvise'):
            return None
        for _ in range(32):  # the chain of bases
            if array is None:
                return None
            if isinstance(array, np.memmap) and getattr(array, '_mmap', None) is not None:
                if array.mode not in ('r', 'r+', 'w+'):
                    return None
                try:
                    return cls(array._mmap)
                except (TypeError, ValueError):  # closed
                    return None
            array = getattr(array, 'base', None)
        return None

    def drop(self, view: np.ndarray) -> None:
        """Drops the pages `view` spans from this process's resident set."""
        low = high = view.__array_interface__['data'][0]
        for n, stride in zip(view.shape, view.strides):
            if stride < 0:
                low += (n - 1) * stride
            else:
                high += (n - 1) * stride
        begin = max(0, (low - self.start) // mmap.PAGESIZE * mmap.PAGESIZE)
        end = min(len(self.buffer), high + view.itemsize - self.start)
        if end > begin:
            try:
                self.buffer.madvise(mmap.MADV_DONTNEED, begin, end - begin)
            except (OSError, ValueError):
                pass

    def gather(self, view: np.ndarray, dtype: np.dtype, piece_bytes: int) -> np.ndarray:
        """`view` copied into a new C-contiguous array of `dtype`, a piece along its outermost axis (in the map) at a
        time, each piece's pages dropped once copied: the pages mapped at once stay within about `piece_bytes`, however
        the view's axes lie in the file."""
        out = np.empty(view.shape, dtype=dtype)
        outer = max(range(view.ndim), key=lambda k: abs(view.strides[k]) if view.shape[k] > 1 else -1)
        step = max(1, piece_bytes // max(1, abs(view.strides[outer])))
        for i in range(0, view.shape[outer], step):
            index = [slice(None)] * view.ndim
            index[outer] = slice(i, i + step)
            piece = view[tuple(index)]
            out[tuple(index)] = piece
            self.drop(piece)
        return out
