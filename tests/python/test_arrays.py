"""voxbrick.prep: stores from NumPy arrays, memory maps and Zarr arrays, through the real `voxbrick prep`."""
from __future__ import annotations

import json
import tracemalloc

import numpy as np
import pytest
import zarr

import voxbrick
from voxbrick.arrays import _Mapping, _memmap_file_offset
from conftest import run_voxbrick, voxbrick_exe

def field(shape=(20, 24, 28), dtype=np.float32):
    """A smooth field indexed [z, y, x] that differs along every axis."""
    z, y, x = np.mgrid[0:shape[0], 0:shape[1], 0:shape[2]].astype(np.float64)
    return (np.sin(x / 4) * np.cos(y / 5) + z / shape[0] * 2).astype(dtype)


def store_json(path):
    with open(path / 'store.json') as f:
        return json.load(f)


def test_an_array_gives_the_store_the_command_line_makes_of_its_raw_file(tmp_path):
    a = field()
    store = voxbrick.prep(a, tmp_path / 'a.vbs', spacing=(0.5, 1, 2), exe=voxbrick_exe(), vdb=False)
    assert store == tmp_path / 'a.vbs'
    meta = store_json(store)
    assert meta['dims'] == [28, 24, 20]  # x, y, z: the last axis is x
    assert meta['spacing'] == [0.5, 1, 2]
    assert meta['type'] == 'f32'
    assert meta['value_range'] == pytest.approx([float(a.min()), float(a.max())])
    assert meta.get('orientation', {}).get('patient', False) is False  # no origin given: centred, no patient frame
    # The same voxels as a raw file, prepped by the command line: the same store but for the name of its source.
    a.tofile(tmp_path / 'a.raw')
    run_voxbrick('prep', str(tmp_path / 'a.raw'), '--dims', '28,24,20', '--type', 'f32', '--spacing', '0.5,1,2',
                 '--no-vdb', '-q', '-o', str(tmp_path / 'cli.vbs'))
    cli = tmp_path / 'cli.vbs'
    assert sorted(p.name for p in store.iterdir()) == sorted(p.name for p in cli.iterdir())
    for name in ('bricks.bin', 'index.bin'):
        assert (store / name).read_bytes() == (cli / name).read_bytes(), name
    assert {k: v for k, v in meta.items() if k != 'source'} == {k: v for k, v in store_json(cli).items()
                                                                 if k != 'source'}
    # Nothing is left beside the store but the store.
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith('.voxbrick')) == []


def test_axes_name_the_array_axes(tmp_path, monkeypatch):
    monkeypatch.setenv('VOXBRICK', voxbrick_exe())
    a = field()
    zyx = voxbrick.prep(a, tmp_path / 'zyx.vbs', vdb=False)
    xyz = voxbrick.prep(a.transpose(2, 1, 0), tmp_path / 'xyz.vbs', axes='xyz', vdb=False)
    yxz = voxbrick.prep(np.asfortranarray(a.transpose(1, 2, 0)), tmp_path / 'yxz.vbs', axes='yxz', vdb=False,
                        slab_bytes=1000)  # slabs of one z-slice
    reference = (zyx / 'bricks.bin').read_bytes()
    assert (xyz / 'bricks.bin').read_bytes() == reference
    assert (yxz / 'bricks.bin').read_bytes() == reference


def test_types_are_stored_as_prep_stores_them(tmp_path, monkeypatch):
    monkeypatch.setenv('VOXBRICK', voxbrick_exe())
    # One of each path: kept (u2), widened by prep (i1), converted by prep (i4), big-endian (>f4), converted here
    # (i8 through f8, b1 to u1).
    cases = {'u2': 'u16', 'i1': 'i16', 'i4': 'f32', '>f4': 'f32', 'i8': 'f32', 'b1': 'u8'}
    values = (field() * 20).astype(np.int64) % 100
    for dtype, stored in cases.items():
        store = voxbrick.prep(values.astype(dtype), tmp_path / f'{dtype.strip("<>")}.vbs', vdb=False)
        meta = store_json(store)
        assert meta['type'] == stored, dtype
        high = 1 if dtype == 'b1' else 99
        assert meta['value_range'] == [0, high], dtype


def test_origin_and_patient_frame(tmp_path, monkeypatch):
    monkeypatch.setenv('VOXBRICK', voxbrick_exe())
    store = voxbrick.prep(field(), tmp_path / 'o.vbs', spacing=(1, 2, 3), origin=(-10, 5.5, 7), patient=True,
                          vdb=False)
    o = store_json(store)['orientation']
    assert o['origin'] == [-10, 5.5, 7]
    assert o['axes'] == [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    assert o['patient'] is True


def test_a_memory_map_is_read_in_place(tmp_path, monkeypatch):
    monkeypatch.setenv('VOXBRICK', voxbrick_exe())
    a = field(dtype=np.uint16)
    mm = np.memmap(tmp_path / 'mm.raw', dtype='<u2', mode='w+', shape=a.shape, offset=4099)
    mm[:] = a
    mm.flush()
    assert _memmap_file_offset(mm) == 4099
    assert _memmap_file_offset(mm[3:]) == 4099 + 3 * a.shape[1] * a.shape[2] * 2
    assert _memmap_file_offset(mm[:, 1:]) is None  # not contiguous: copied
    assert _memmap_file_offset(np.asarray(mm)) is None
    copied = voxbrick.prep(np.array(a[3:]), tmp_path / 'copied.vbs', vdb=False)

    def no_copy(*args):
        raise AssertionError('a contiguous memory map is read in place, not copied')

    monkeypatch.setattr(voxbrick.arrays, '_write_slabs', no_copy)
    whole = voxbrick.prep(mm, tmp_path / 'mm.vbs', vdb=False, work=tmp_path / 'work')
    part = voxbrick.prep(mm[3:], tmp_path / 'part.vbs', vdb=False)
    assert store_json(whole)['dims'] == [28, 24, 20]
    assert (part / 'bricks.bin').read_bytes() == (copied / 'bricks.bin').read_bytes()
    with pytest.raises(AssertionError, match='read in place'):
        voxbrick.prep(mm[:, 1:], tmp_path / 'strided.vbs', vdb=False)


def mapped_bytes(path) -> int:
    """The bytes of `path` resident in this process's mappings of it (/proc/self/smaps)."""
    total, inside = 0, False
    with open('/proc/self/smaps') as f:
        for line in f:
            head = line.split(maxsplit=5)
            if len(head) >= 5 and '-' in head[0] and not head[0].endswith(':'):
                inside = len(head) == 6 and head[5].strip() == str(path)
            elif inside and line.startswith('Rss:'):
                total += int(line.split()[1]) * 1024
    return total


def test_a_memory_map_read_slab_by_slab_stays_mapped_a_slab_at_a_time(tmp_path, monkeypatch):
    # A map prep cannot read in place (a type it converts, an array viewing the map, another axis order, a strided
    # view) is copied slab by slab; each page of a file map read stays in the resident set until dropped, so without
    # dropping them a 4 GiB map read through would leave 4 GiB resident (bench/results/python/prep-memory.md).
    monkeypatch.setenv('VOXBRICK', voxbrick_exe())
    rng = np.random.default_rng(2)
    volume = rng.random((64, 256, 256), dtype=np.float32)  # z, y, x: 16 MiB
    slab = 1 << 20
    seen = []
    drop = _Mapping.drop

    def watched(self, view):
        seen.append(mapped_bytes(path))
        drop(self, view)

    for name, data, make, axes in [
        ('int64', (volume * 1000).astype(np.int64), lambda mm: mm, 'zyx'),  # converted, through float64
        ('view', volume, np.asarray, 'zyx'),  # an ndarray whose base is the map
        ('xyz', np.ascontiguousarray(volume.transpose()), lambda mm: mm, 'xyz'),  # z fastest in the file
        ('strided', np.concatenate([volume, volume], axis=2), lambda mm: mm[:, :, ::2], 'zyx'),
    ]:
        path = tmp_path / f'{name}.raw'
        data.tofile(path)
        mm = np.memmap(path, dtype=data.dtype, mode='r', shape=data.shape)
        array = make(mm)
        reference = voxbrick.prep(np.array(make(data)), tmp_path / f'{name}-reference.vbs', axes=axes, vdb=False)
        seen.clear()
        monkeypatch.setattr(_Mapping, 'drop', watched)
        store = voxbrick.prep(array, tmp_path / f'{name}.vbs', axes=axes, vdb=False, slab_bytes=slab)
        monkeypatch.setattr(_Mapping, 'drop', drop)
        assert (store / 'bricks.bin').read_bytes() == (reference / 'bricks.bin').read_bytes(), name
        assert seen, f'{name}: the map was read through _Mapping'
        # At most about a slab of the map resident at once, and what one fault maps beyond it (a large folio of the
        # page cache: up to 2 MiB), against 16 to 32 MiB without dropping; as little once prep is done.
        assert max(seen) <= slab + (2 << 20), f'{name}: {max(seen)} bytes of the map resident at once'
        assert mapped_bytes(path) <= 2 << 20, f'{name}: {mapped_bytes(path)} bytes left resident'
        del mm, array


def test_a_copy_on_write_map_is_prepped_with_its_changes(tmp_path, monkeypatch):
    # A map of mode "c" keeps its changes in memory: its file does not hold them, so it is copied, not read in place,
    # and its pages are not dropped (that would lose the changes).
    monkeypatch.setenv('VOXBRICK', voxbrick_exe())
    a = field()
    a.tofile(tmp_path / 'a.raw')
    mm = np.memmap(tmp_path / 'a.raw', dtype=a.dtype, mode='c', shape=a.shape)
    mm[5, 6, 7] = 100.0
    assert _memmap_file_offset(mm) is None and _Mapping.of(mm) is None
    store = voxbrick.prep(mm, tmp_path / 'c.vbs', vdb=False, slab_bytes=1000)
    assert store_json(store)['value_range'][1] == 100.0
    assert mm[5, 6, 7] == 100.0


def test_a_relative_output_path(tmp_path, monkeypatch):
    monkeypatch.setenv('VOXBRICK', voxbrick_exe())
    monkeypatch.chdir(tmp_path)
    a = field()
    assert voxbrick.prep(a, 'data/a.vbs', vdb=False) == type(tmp_path)('data/a.vbs')
    voxbrick.prep(a, 'b.vbs', vdb=False, work='scratch')
    for store in (tmp_path / 'data' / 'a.vbs', tmp_path / 'b.vbs'):
        assert store_json(store)['dims'] == [28, 24, 20]


def test_a_zarr_array_is_written_chunk_by_chunk_in_bounded_memory(tmp_path, monkeypatch):
    monkeypatch.setenv('VOXBRICK', voxbrick_exe())
    rng = np.random.default_rng(1)
    volume = rng.random((64, 128, 128), dtype=np.float32)  # 4 MiB
    z = zarr.open(str(tmp_path / 'v.zarr'), mode='w', shape=volume.shape, chunks=(8, 64, 64), dtype='f4')
    z[:] = volume
    tracemalloc.start()
    try:
        store = voxbrick.prep(z, tmp_path / 'z.vbs', vdb=False, slab_bytes=256 << 10)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1 << 20, f'{peak} bytes at most at once for a 4 MiB array read in slabs of 256 KiB'
    reference = voxbrick.prep(volume, tmp_path / 'n.vbs', vdb=False)
    assert (store / 'bricks.bin').read_bytes() == (reference / 'bricks.bin').read_bytes()


def test_bad_input_is_refused_naming_the_problem(tmp_path, monkeypatch):
    monkeypatch.setenv('VOXBRICK', voxbrick_exe())
    out = tmp_path / 'x.vbs'
    for array, kwargs, words in [
        (np.zeros((4, 4)), {}, 'shape (4, 4): prep takes a 3-D volume'),
        (np.zeros((4, 4, 4), complex), {}, 'dtype complex128'),
        (np.zeros((4, 4, 4)), {'spacing': (1, 0, 1)}, 'spacing (1, 0, 1)'),
        (np.zeros((4, 4, 4)), {'spacing': (1, 1)}, 'expected three numbers'),
        (np.zeros((4, 4, 4)), {'origin': (0, float('nan'), 0)}, 'origin'),
        (np.zeros((4, 4, 4)), {'axes': 'zyy'}, "axes 'zyy'"),
        (np.zeros((0, 4, 4)), {}, 'empty'),
    ]:
        with pytest.raises(ValueError, match=words.replace('(', r'\(').replace(')', r'\)')):
            voxbrick.prep(array, out, **kwargs)
    assert not out.exists()
    # prep's own refusal comes back in its words.
    nan = np.zeros((4, 4, 4), np.float32)
    nan[1, 2, 3] = np.nan
    with pytest.raises(voxbrick.VoxbrickError, match=r'voxbrick prep refused the array \(exit 1\): .*(NaN|non-finite)'):
        voxbrick.prep(nan, out, extra_args=['--nonfinite', 'error'], vdb=False)
    voxbrick.prep(nan, out, vdb=False)
    with pytest.raises(voxbrick.VoxbrickError, match='exists: pass force=True'):
        voxbrick.prep(nan, out)
    voxbrick.prep(nan, out, force=True, vdb=False)
    # No command to run.
    monkeypatch.setenv('PATH', str(tmp_path))
    monkeypatch.delenv('VOXBRICK')
    with pytest.raises(voxbrick.VoxbrickError, match=r'voxbrick not found: pass exe=.*\$VOXBRICK.*PATH'):
        voxbrick.prep(nan, tmp_path / 'y.vbs')
    with pytest.raises(voxbrick.VoxbrickError, match="'/nowhere/voxbrick', which is not an executable"):
        voxbrick.prep(nan, tmp_path / 'y.vbs', exe='/nowhere/voxbrick')
