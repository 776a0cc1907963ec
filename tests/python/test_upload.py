"""Arrays sent to a server as new datasets (protocol version 6, PROTOCOL.md Session 13): Client.upload and
voxbrick.view(array) against the real `voxbrick serve` with `[upload]` configured and two tokens of `[[tokens]]` (one
that may upload datasets named up-*, one that may not) beside the single `--http-token`. An upload's store is the one
`voxbrick.prep` makes of the same array, byte for byte, and its frames those `voxbrick render` draws of that store;
every refusal is in the server's words and leaves the datasets folder as it was (hidden entries included), as does a
client that goes away part way and a server that stops part way."""
from __future__ import annotations

import hashlib
import json
import os
import re
import time
from pathlib import Path
from typing import Optional

import numpy as np
import pytest

import voxbrick
from voxbrick import ErrorCode, ServerError
from voxbrick.protocol import HEADER, MAGIC, Encoding, MessageType, encode
from voxbrick.session import Session
from conftest import TOKEN, Scripted, Server, largest_difference, render_cli, run_voxbrick, voxbrick_exe

UPLOADER = 'uploader-Secret_1'  # may upload, and open, datasets named up-*
VIEWER = 'viewer-Secret_2'  # opens every dataset, may not upload
MAX_BYTES = 3_000_000  # [upload] max_bytes: the quota of one upload
SCENE = dict(camera=(30, 20), tf='hot', size=(64, 48))


def blobs(shape=(24, 28, 32), dtype=np.float32, seed=0) -> np.ndarray:
    """A few Gaussian blobs in a volume indexed [z, y, x], different along every axis, scaled to half an integer
    type's range."""
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n) for n in shape), indexing='ij')
    rng = np.random.default_rng(seed)
    v = np.zeros(shape)
    for _ in range(4):
        c, r = rng.uniform(-0.6, 0.6, 3), rng.uniform(0.2, 0.4)
        v += np.exp(-((z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2) / (2 * r * r)) * rng.uniform(0.5, 1)
    v += x * 0.1  # no symmetry an axis mix-up could hide behind
    dtype = np.dtype(dtype)
    if dtype.kind in 'iu':
        v = (v - v.min()) / (v.max() - v.min()) * (np.iinfo(dtype).max // 2)
    return v.astype(dtype)


def listing(folder: Path) -> list:
    """The datasets folder's entries, hidden ones (an upload's scratch, .upload-*) included."""
    return sorted(os.listdir(folder))


def settles(folder: Path, expected: list, seconds: float = 10) -> list:
    """The folder's listing once it is `expected`, or as it is after `seconds`. (An upload's scratch should be gone by
    its answer; test_uploads_one_after_another holds the server to that, the others wait for it.)"""
    deadline = time.monotonic() + seconds
    while listing(folder) != expected and time.monotonic() < deadline:
        time.sleep(0.05)
    return listing(folder)


def sha(secret: str) -> str:
    return hashlib.sha256(secret.encode()).hexdigest()


def start(work: Path, name: str, max_concurrent: int = 2, certs: Optional[Path] = None) -> tuple:
    """(Server, its datasets folder): a server taking uploads of up to MAX_BYTES, over a folder holding `sparse`; inside
    TLS with the certificate of `certs` (conftest's certs())."""
    own = work / name
    folder = own / 'datasets'
    folder.mkdir(parents=True)
    run_voxbrick('prep', 'synthetic:sparse,n=32', '--brick', '16', '--no-vdb', '-q', '-o', str(folder / 'sparse'))
    config = own / 'server.toml'
    tls = f'[tls]\ncert = "{certs / "server.pem"}"\nkey = "{certs / "server.key"}"\n\n' if certs else ''
    config.write_text(f'{tls}[upload]\nmax_bytes = {MAX_BYTES}\nmax_concurrent = {max_concurrent}\n\n'
                      f'[[tokens]]\nid = "uploader"\nsha256 = "{sha(UPLOADER)}"\ndatasets = ["up-*"]\nupload = true\n\n'
                      f'[[tokens]]\nid = "viewer"\nsha256 = "{sha(VIEWER)}"\ndatasets = ["*"]\n')
    return Server(folder, own, extra=('--config', str(config))), folder


@pytest.fixture(scope='module')
def up(work):
    """The server taking uploads, and its datasets folder."""
    s, folder = start(work, 'upload-server')
    yield s, folder
    s.stop()


def store_json(path: Path) -> dict:
    return json.loads((path / 'store.json').read_text())


def same_store(uploaded: Path, reference: Path) -> None:
    """The uploaded store is the one voxbrick.prep made: the same files, bricks and index byte for byte, the same
    store.json but for the name of its source."""
    assert sorted(p.name for p in uploaded.iterdir()) == sorted(p.name for p in reference.iterdir())
    for name in ('bricks.bin', 'index.bin'):
        assert (uploaded / name).read_bytes() == (reference / name).read_bytes(), name
    assert ({k: v for k, v in store_json(uploaded).items() if k != 'source'} ==
            {k: v for k, v in store_json(reference).items() if k != 'source'})


def server_error(call, *args, **kwargs) -> ServerError:
    with pytest.raises(ServerError) as e:
        call(*args, **kwargs)
    return e.value


@pytest.mark.parametrize('name, dtype, axes, transport', [
    ('up-float', np.float32, 'zyx', 'tcp'),
    ('up-u16', np.uint16, 'zyx', 'ws'),
    ('up-xyz', np.float32, 'xyz', 'tcp'),
])
def test_an_upload_is_the_store_prep_makes_and_renders_as_voxbrick_render_does(up, tmp_path, name, dtype, axes,
                                                                               transport):
    server, folder = up
    # uint16: 1.6 MB in one slab, more than one chunk of the server's (its body limit is 1 MiB); the others in slabs
    # of a few z-slices.
    shape, slab_bytes = ((40, 128, 160), 64 << 20) if dtype == np.uint16 else ((24, 28, 32), 10000)
    a = blobs(shape, dtype)
    if axes == 'xyz':
        a = np.ascontiguousarray(a.transpose())  # indexed [x, y, z]
    before = listing(folder)
    address = server.address if transport == 'tcp' else server.ws
    with voxbrick.connect(address, token=UPLOADER) as c:
        assert c.version == 9
        info = c.upload(name, a, spacing=(0.5, 1, 2), axes=axes, slab_bytes=slab_bytes)
        assert c.dataset is None  # the session's open dataset does not change
        x, y, z = (shape[2], shape[1], shape[0])
        assert info['kind'] == 'brick-store' and info['dims'] == [x, y, z] and info['spacing'] == [0.5, 1, 2]
        assert info['type'] == ('u16' if dtype == np.uint16 else 'f32')
        assert name in c.datasets()
        assert c.info(name) == info
        frame = c.render_frame(name, **SCENE)  # the dataset's first frame: the atlas of a fresh `voxbrick render`
    assert settles(folder, sorted(before + [name])) == sorted(before + [name])
    reference = voxbrick.prep(a, tmp_path / 'reference.vbs', spacing=(0.5, 1, 2), axes=axes, exe=voxbrick_exe())
    same_store(folder / name, reference)
    expected = voxbrick.read_png(str(render_cli(reference, frame.scene, tmp_path / 'cli.png')))
    assert np.array_equal(frame.image, expected)  # byte for byte, every channel
    assert frame.image[..., :3].max() > 50  # the blobs are there, not a black frame


def test_uploads_inside_tls(work, certs):
    # Both transports inside TLS, in several chunks: between chunks the client looks for an Error without waiting,
    # which inside TLS also means the bytes the SSL object holds decrypted.
    server, folder = start(work, 'upload-server-tls', certs=certs)
    try:
        a = blobs((40, 128, 160), np.uint16, seed=5)
        for address, name in [(f'tls://127.0.0.1:{server.port}', 'up-tls'),
                              (f'wss://127.0.0.1:{server.http_port}', 'up-wss')]:
            with voxbrick.connect(address, token=UPLOADER, ca=str(certs / 'ca.pem')) as c:
                assert c.upload(name, a, slab_bytes=300_000)['dims'] == [160, 128, 40]
                assert c.render(name, size=(16, 16)).shape == (16, 16, 4)
        assert (folder / 'up-tls' / 'bricks.bin').read_bytes() == (folder / 'up-wss' / 'bricks.bin').read_bytes()
    finally:
        server.stop()


def test_types_and_orientation_are_stored_as_prep_stores_them(up, tmp_path):
    server, folder = up
    values = blobs((10, 12, 14), np.float64)
    values = (values - values.min()) / (values.max() - values.min()) * 100  # 0 to 100
    # Kept (u1), widened by the server's prep (i1), converted by it (u4, >f4 big-endian), converted here (i8 through
    # double, b1 to uint8).
    cases = {'u1': 'u8', 'i1': 'i16', 'u4': 'f32', '>f4': 'f32', 'i8': 'f32', 'b1': 'u8'}
    with voxbrick.connect(server.address, token=UPLOADER) as c:
        for dtype, stored in cases.items():
            a = (values > 60) if dtype == 'b1' else (values - (50 if dtype == 'i1' else 0)).astype(dtype)
            name = f'up-type-{dtype.strip("<>")}' + ('-be' if dtype.startswith('>') else '')
            assert c.upload(name, a)['type'] == stored, dtype
            same_store(folder / name, voxbrick.prep(a, tmp_path / f'{name}.vbs', exe=voxbrick_exe()))
        # Where it lies: an origin, the patient's frame (with and without an origin), as prep puts them.
        a = values.astype(np.float32)
        for name, kwargs in [('up-origin', dict(spacing=(1, 2, 3), origin=(-10, 5.5, 7))),
                             ('up-patient', dict(spacing=(0.5, 0.5, 1), origin=(1, 2, 3), patient=True)),
                             ('up-patient-0', dict(patient=True))]:
            info = c.upload(name, a, **kwargs)
            reference = voxbrick.prep(a, tmp_path / f'{name}.vbs', exe=voxbrick_exe(), **kwargs)
            assert info['orientation'] == store_json(reference)['orientation'], name
            same_store(folder / name, reference)


def test_refusals_are_in_the_servers_words_and_leave_nothing(up):
    server, folder = up
    a = blobs((8, 8, 8), np.uint8)
    before = listing(folder)
    # Over the quota: refused before a byte is sent (a broadcast array holds no memory).
    with voxbrick.connect(server.address, token=UPLOADER) as c:
        big = np.broadcast_to(np.float32(1), (100, 100, 100))  # 4 MB
        e = server_error(c.upload, 'up-big', big)
        assert e.code == ErrorCode.LimitExceeded and str(MAX_BYTES) in e.message, e
        # A name the token may not open: Forbidden, as for any name outside its datasets.
        e = server_error(c.upload, 'other', a)
        assert e.code == ErrorCode.Forbidden, e
        assert c.datasets() is not None  # the session goes on (version 6)
    # A token that may not upload: Forbidden, and the session goes on.
    with voxbrick.connect(server.address, token=VIEWER) as c:
        e = server_error(c.upload, 'up-viewer', a)
        assert e.code == ErrorCode.Forbidden and e.request_id > 0, e
        assert c.render('sparse', size=(16, 16)).shape == (16, 16, 4)
    with voxbrick.connect(server.ws, token=VIEWER) as c:
        assert server_error(c.upload, 'up-viewer', a).code == ErrorCode.Forbidden
        assert c.render('sparse', size=(16, 16)).shape == (16, 16, 4)
    # No token at all (the server has [[tokens]]: an anonymous session sees nothing, and may not upload).
    with voxbrick.connect(server.address) as c:
        assert server_error(c.upload, 'up-anonymous', a).code == ErrorCode.Forbidden
        assert c.datasets() == []
    # Names that are not one, from the token that may upload any name (the server's single token).
    with voxbrick.connect(server.address, token=TOKEN) as c:
        for name in ('../x', '.hidden', 'a/b', 'up x', 'x' * 256, '.', '..', 'a\\b'):
            e = server_error(c.upload, name, a)
            assert e.code == ErrorCode.Malformed, (name, e)
        # A dataset that exists.
        e = server_error(c.upload, 'sparse', a)
        assert e.code == ErrorCode.AlreadyExists and 'sparse' in e.message, e
        assert c.render('sparse', size=(16, 16)).shape == (16, 16, 4)
    assert listing(folder) == before
    # What this client refuses before anything is sent.
    with voxbrick.connect(server.address, token=UPLOADER) as c:
        for array, kwargs, words in [
            (np.zeros((4, 4)), {}, 'shape (4, 4): upload takes a 3-D volume'),
            (np.zeros((4, 4, 4), complex), {}, 'dtype complex128: upload takes integers, floats and bools'),
            (np.zeros((4, 4, 4)), {'spacing': (1, 0, 1)}, 'spacing (1, 0, 1)'),
            (np.zeros((4, 4, 4)), {'origin': (0, float('inf'), 0)}, 'origin'),
            (np.zeros((4, 4, 4)), {'axes': 'zyy'}, "axes 'zyy'"),
            (np.zeros((4, 4, 4)), {'slab_bytes': 0}, 'slab_bytes 0'),
        ]:
            with pytest.raises(ValueError, match=re.escape(words)):
                c.upload('up-refused', array, **kwargs)
        with pytest.raises(ValueError, match='name'):
            c.upload('', a)
    # An upload of a name that exists, once uploaded: AlreadyExists, and the first stays as it was.
    with voxbrick.connect(server.ws, token=UPLOADER) as c:
        first = c.upload('up-twice', a)
        e = server_error(c.upload, 'up-twice', a[::-1].copy())
        assert e.code == ErrorCode.AlreadyExists and 'up-twice' in e.message, e
        assert c.info('up-twice') == first
    assert settles(folder, sorted(before + ['up-twice'])) == sorted(before + ['up-twice'])


def test_progress_is_reported_chunk_by_chunk_and_the_answer_may_take_its_own_timeout(up):
    server, folder = up
    a = blobs((40, 128, 160), np.uint16)  # 1.6 MB: two chunks of the server's 1 MiB messages
    calls = []
    with voxbrick.connect(server.address, token=UPLOADER, timeout=30) as c:
        info = c.upload('up-progress', a, progress=lambda sent, total: calls.append((sent, total)), timeout=90)
        assert c.session._transport.sock.gettimeout() == 30  # the session's own timeout again after the answer
        assert info['dims'] == [160, 128, 40]
    total = a.nbytes
    assert calls[-1] == (total, total) and len(calls) >= 2
    assert all(t == total for _, t in calls)
    sent = [s for s, _ in calls]
    assert sent == sorted(sent) and 0 < sent[0] < total


def test_a_name_of_255_bytes_is_one(up):
    # PROTOCOL.md, Upload: a name of at most 255 bytes; one byte more is Malformed.
    server, folder = up
    before = listing(folder)
    name = 'up-' + 'n' * 252
    with voxbrick.connect(server.address, token=UPLOADER) as c:
        assert server_error(c.upload, name + 'n', blobs((4, 4, 4), np.uint8)).code == ErrorCode.Malformed
        assert c.upload(name, blobs((4, 4, 4), np.uint8))['dims'] == [4, 4, 4]
        assert name in c.datasets()
    assert settles(folder, sorted(before + [name])) == sorted(before + [name])


def test_a_zarr_array_is_sent_slab_by_slab_in_bounded_memory(up, tmp_path):
    import tracemalloc
    import zarr
    server, folder = up
    volume = blobs((64, 128, 64), np.float32, seed=7)  # 2 MiB
    z = zarr.open(str(tmp_path / 'v.zarr'), mode='w', shape=volume.shape, chunks=(8, 64, 64), dtype='f4')
    z[:] = volume
    with voxbrick.connect(server.ws, token=UPLOADER) as c:
        tracemalloc.start()
        try:
            c.upload('up-zarr', z, slab_bytes=128 << 10)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    assert peak < 1 << 20, f'{peak} bytes at most at once for a 2 MiB array sent in slabs of 128 KiB'
    same_store(folder / 'up-zarr', voxbrick.prep(volume, tmp_path / 'reference.vbs', exe=voxbrick_exe()))


class Failing:
    """An array whose reading fails part way (a Zarr chunk that does not decode, say)."""

    def __init__(self, array: np.ndarray, after: int):
        self.array, self.after, self.shape, self.dtype = array, after, array.shape, array.dtype

    def __getitem__(self, index):
        self.after -= 1
        if self.after < 0:
            raise OSError('chunk 3 does not decode')
        return self.array[index]


def test_an_array_that_fails_part_way_is_abandoned_and_the_session_goes_on(up):
    server, folder = up
    before = listing(folder)
    a = blobs((16, 32, 32), np.uint8)
    for address in (server.address, server.ws):
        with voxbrick.connect(address, token=UPLOADER) as c:
            with pytest.raises(OSError, match='chunk 3 does not decode'):
                c.upload('up-failing', Failing(a, 2), slab_bytes=32 * 32 * 2)  # two slabs sent, the third fails
            assert settles(folder, before) == before
            assert 'up-failing' not in c.datasets()
    with voxbrick.connect(server.address, token=UPLOADER) as c:
        assert c.upload('up-failing', a)['dims'] == [32, 32, 16]  # the name was free again


def raw_upload(s: Session, name: str, meta, size: int) -> int:
    """Sends an Upload as it is given; the UploadReady's chunk_bytes (an Error raises ServerError)."""
    text = meta if isinstance(meta, str) else json.dumps(meta)
    return s._call(MessageType.Upload, MessageType.UploadReady, name=name, meta_json=text, bytes=size)['chunk_bytes']


def raw_chunk(s: Session, data: bytes) -> int:
    return s._send(MessageType.UploadChunk, data=data)


def test_meta_sizes_and_chunks_are_checked_at_the_session_level(up):
    server, folder = up
    before = listing(folder)
    good = {'dims': [4, 4, 4], 'type': 'uint8'}
    with Session(server.address, token=TOKEN) as s:
        assert s.version == 9
        for meta, key in [
            ({'dims': [4, 4], 'type': 'uint8'}, 'dims'),
            ({'dims': [4, 0, 4], 'type': 'uint8'}, 'dims'),
            ({'dims': [4, 4, 4.5], 'type': 'uint8'}, 'dims'),
            ({'dims': [4, 4, 4]}, 'type'),
            ({'type': 'uint8'}, 'dims'),
            ({'dims': [4, 4, 4], 'type': 'complex'}, 'type'),
            (dict(good, endian='middle'), 'endian'),
            (dict(good, spacing=[1, 0, 1]), 'spacing'),
            (dict(good, spacing=[1, 1]), 'spacing'),
            (dict(good, origin=[1, 2]), 'origin'),
            (dict(good, patient='yes'), 'patient'),
            (dict(good, colour='red'), 'colour'),
        ]:
            e = server_error(raw_upload, s, 'up-meta', meta, 64)
            assert e.code == ErrorCode.Malformed and key in e.message, (meta, e)
        for text in ('not json', '[4, 4, 4]', '{"dims": [4, 4, 4], "type": "uint8"} x'):
            assert server_error(raw_upload, s, 'up-meta', text, 64).code == ErrorCode.Malformed, text
        # `bytes` not dims x the type's size (4 x 4 x 4 x 2 = 128).
        e = server_error(raw_upload, s, 'up-meta', dict(good, type='uint16'), 64)
        assert e.code == ErrorCode.Malformed and 'bytes' in e.message and '128' in e.message, e
        assert listing(folder) == before

        # A chunk past `bytes` ends the upload: Malformed, its voxels deleted, the name free again.
        chunk_bytes = raw_upload(s, 'up-chunks', good, 64)
        assert 64 <= chunk_bytes <= s.capabilities.max_message_bytes - 4
        e = server_error(s._await, raw_chunk(s, b'\1' * 65), ())
        assert e.code == ErrorCode.Malformed, e
        assert settles(folder, before) == before
        # An empty chunk: the same (how a client abandons an upload and keeps its session).
        raw_upload(s, 'up-chunks', good, 64)
        raw_chunk(s, b'\1' * 10)
        e = server_error(s._await, raw_chunk(s, b''), ())
        assert e.code == ErrorCode.Malformed, e
        assert settles(folder, before) == before
        # A chunk with no upload in progress, and a second Upload while one is.
        assert server_error(s._await, raw_chunk(s, b'\1'), ()).code == ErrorCode.UnexpectedMessage
        raw_upload(s, 'up-chunks', good, 64)
        assert server_error(raw_upload, s, 'up-other', good, 64).code == ErrorCode.UnexpectedMessage
        # Other requests between chunks, then the rest: the dataset.
        raw_chunk(s, b'\1' * 30)
        assert 'sparse' in s.list_datasets()
        last = raw_chunk(s, b'\2' * 34)
        header, info = s._await(last, (MessageType.DatasetInfo,))
        assert info['name'] == 'up-chunks' and json.loads(info['meta_json'])['dims'] == [4, 4, 4]
        assert s.dataset is None
    assert settles(folder, sorted(before + ['up-chunks'])) == sorted(before + ['up-chunks'])


def test_a_session_of_version_5_cannot_upload(up):
    server, folder = up
    before = listing(folder)
    with voxbrick.connect(server.address, token=TOKEN, max_version=5) as c:
        with pytest.raises(voxbrick.ProtocolError, match='this session speaks protocol version 5; uploads need'):
            c.upload('up-five', blobs((4, 4, 4), np.uint8))
        # The message itself, in a session of version 5: a type that version does not have.
        body = b'\x07\0\0\0up-five' + b'\x02\0\0\0{}' + (64).to_bytes(8, 'little')
        c.session._transport.send(HEADER.pack(MAGIC, 5, int(MessageType.Upload), 99, len(body)) + body)
        e = server_error(c.session._await, 99, ())
        assert e.code == ErrorCode.UnknownType, e
        assert c.datasets()
    assert listing(folder) == before


def test_uploads_at_once(up):
    server, folder = up
    before = listing(folder)
    meta = {'dims': [8, 8, 8], 'type': 'uint8'}
    with Session(server.address, token=UPLOADER) as a, Session(server.ws, token=UPLOADER) as b, \
            Session(server.address, token=TOKEN) as c:
        raw_upload(a, 'up-at-once-1', meta, 512)
        scratch = [n for n in listing(folder) if n not in before]
        assert scratch and all(n.startswith('.upload-') for n in scratch), scratch
        # The name another session is uploading.
        e = server_error(raw_upload, b, 'up-at-once-1', meta, 512)
        assert e.code == ErrorCode.AlreadyExists, e
        raw_upload(b, 'up-at-once-2', meta, 512)
        # A third at once, past [upload] max_concurrent = 2.
        e = server_error(raw_upload, c, 'up-at-once-3', meta, 512)
        assert e.code == ErrorCode.Busy, e
        # One ends (abandoned: an empty chunk), and the third is taken.
        server_error(a._await, raw_chunk(a, b''), ())
        assert c.upload('up-at-once-3', meta, 512, [b'\3' * 512])['dims'] == [8, 8, 8]
        server_error(b._await, raw_chunk(b, b''), ())
    assert settles(folder, sorted(before + ['up-at-once-3'])) == sorted(before + ['up-at-once-3'])


@pytest.mark.parametrize('how', ['dropped', 'goodbye', 'websocket'])
def test_a_client_that_goes_away_part_way_leaves_nothing(up, how):
    server, folder = up
    before = listing(folder)
    name = f'up-gone-{how}'
    meta = {'dims': [64, 64, 64], 'type': 'uint8'}
    s = Session(server.ws if how == 'websocket' else server.address, token=UPLOADER)
    chunk_bytes = raw_upload(s, name, meta, 64 ** 3)
    for _ in range(3):
        raw_chunk(s, b'\5' * min(chunk_bytes, 20000))
    assert name not in s.list_datasets()  # its reply: the chunks before it have been read
    scratch = [n for n in listing(folder) if n not in before]
    assert scratch and all(n.startswith('.upload-') for n in scratch), scratch
    if how == 'goodbye':
        s.close()
    else:
        s._transport.sock.close()  # no Goodbye, no WebSocket close: the connection just ends
    assert settles(folder, before) == before
    # The name is free again.
    with voxbrick.connect(server.address, token=UPLOADER) as c:
        assert name not in c.datasets()
        assert c.upload(name, np.full((64, 64, 64), 5, np.uint8))['value_range'] == [5, 5]
    assert settles(folder, sorted(before + [name])) == sorted(before + [name])


def test_uploads_one_after_another(work):
    # An upload is finished when it is answered: its scratch is gone (nothing but the dataset is left in the folder)
    # and it no longer counts against [upload] max_concurrent, so the next upload, from this session or another, is
    # taken at once, not answered Busy.
    server, folder = start(work, 'upload-server-one', max_concurrent=1)
    try:
        names = listing(folder)
        with voxbrick.connect(server.address, token=UPLOADER) as c, voxbrick.connect(server.ws, token=TOKEN) as d:
            for i in range(8):
                for client, size in ((c, 8), (d, 40)):
                    name = f'up-{i}-{size}'
                    client.upload(name, np.full((size, size, size), i, np.uint8))
                    names = sorted(names + [name])
                    assert listing(folder) == names, f'upload {name} answered, its scratch still there'
    finally:
        server.stop()


def test_a_server_that_stops_part_way_keeps_nothing_and_the_sending_stops(work):
    server, folder = start(work, 'upload-server-stopping')
    before = listing(folder)
    sent = []

    def slabs():
        yield b'\0' * 1000
        sent.append(1000)
        server.stop()  # ShuttingDown (id 0), then the server closes
        for _ in range(1000):
            yield b'\0' * 1000
            sent.append(1000)

    try:
        with voxbrick.connect(server.address, token=UPLOADER) as c:
            with pytest.raises((ServerError, voxbrick.ConnectionClosed)) as e:
                c.session.upload('up-stopped', {'dims': [1000, 1000, 1], 'type': 'uint8'}, 10 ** 6, slabs())
            if isinstance(e.value, ServerError):
                assert e.value.code == ErrorCode.ShuttingDown and e.value.request_id == 0, e.value
        assert len(sent) < 1000  # it stopped sending
        assert listing(folder) == before
    finally:
        server.stop()


def test_view_of_an_array_uploads_it_first(up):
    server, folder = up
    a = blobs((20, 24, 28), np.float32, seed=3)
    before = listing(folder)
    v = voxbrick.view(a, server=f'{server.viewer}/?token={TOKEN}', name='up-view', camera='left', tf='hot',
                      size=(64, 64), spacing=(1, 1, 2))
    assert v.dataset == 'up-view' and 'dataset=up-view' in v.url
    assert settles(folder, sorted(before + ['up-view'])) == sorted(before + ['up-view'])
    with voxbrick.connect(server.address, token=UPLOADER) as c:
        info = c.info('up-view')
        assert info['dims'] == [28, 24, 20] and info['spacing'] == [1, 1, 2]
        assert largest_difference(v.snapshot(), c.render('up-view', scene=v.scene())) <= 1
    v.close()
    # Over TCP (address=, the token presented by Authenticate), with a name of its own.
    v = voxbrick.view(a, server=server.viewer, token=TOKEN, address=server.address, size=(32, 32))
    assert re.fullmatch(r'array-[0-9a-f]{12}', v.dataset), v.dataset
    assert v.snapshot().shape == (32, 32, 4)
    v.close()
    assert settles(folder, sorted(before + ['up-view', v.dataset])) == sorted(before + ['up-view', v.dataset])
    # Refusals: the server's (a name taken), and this client's, before anything is sent.
    e = server_error(voxbrick.view, a, server=server.viewer, token=TOKEN, name='up-view')
    assert e.code == ErrorCode.AlreadyExists
    with pytest.raises(ValueError, match='shape'):
        voxbrick.view(np.zeros((4, 4)), server=server.viewer, token=TOKEN)
    with pytest.raises(ValueError, match='name, spacing: for an array'):
        voxbrick.view('sparse', server=server.viewer, token=TOKEN, name='x', spacing=(1, 1, 1))
    with pytest.raises(ValueError, match="camera 'front'"):
        voxbrick.view(a, server=server.viewer, token=TOKEN, name='up-never', camera='front')
    assert settles(folder, sorted(before + ['up-view', v.dataset])) == sorted(before + ['up-view', v.dataset])


def scripted_session(monkeypatch, chunk_bytes=4, fail_chunk=None, forbid_upload=False):
    """A Session of version 6 whose server takes an upload in chunks of `chunk_bytes`, answers the `fail_chunk`-th
    chunk (from 1) with Error Internal, an empty one with Malformed, the last with DatasetInfo."""
    state = {'chunks': 0, 'bytes': 0, 'size': 0}

    def answer(header, fields):
        t, rid = header.type, header.request_id
        if t == MessageType.Hello:
            yield encode(MessageType.Capabilities, rid, 6, version=6, server='script', max_message_bytes=1 << 20,
                         max_image_side=4096, max_queued_per_session=4, encodings=[Encoding.png])
        elif t == MessageType.Authenticate:
            yield encode(MessageType.Error, rid, 6, code=ErrorCode.Forbidden, message='no such token')
        elif t == MessageType.Upload and forbid_upload:
            yield encode(MessageType.Error, rid, 6, code=ErrorCode.Forbidden, message='may not upload')
        elif t == MessageType.Upload:
            state.update(chunks=0, bytes=0, size=fields['bytes'])
            yield encode(MessageType.UploadReady, rid, 6, chunk_bytes=chunk_bytes)
        elif t == MessageType.UploadChunk:
            state['chunks'] += 1
            state['bytes'] += len(fields['data'])
            if not fields['data']:
                yield encode(MessageType.Error, rid, 6, code=ErrorCode.Malformed, message='UploadChunk.data: empty')
            elif state['chunks'] == fail_chunk:
                yield encode(MessageType.Error, rid, 6, code=ErrorCode.Internal, message='disk full')
            elif state['bytes'] == state['size']:
                yield encode(MessageType.DatasetInfo, rid, 6, name='up', meta_json='{"dims": [2, 2, 10]}')
        elif t == MessageType.ListDatasets:
            yield encode(MessageType.DatasetList, rid, 6, names=['up'])

    transport = Scripted(answer)
    monkeypatch.setattr(voxbrick.session, 'open_transport', lambda *args: transport)
    return Session('127.0.0.1:1'), transport


def chunks(transport: Scripted) -> list:
    return [fields['data'] for kind, _, fields in transport.sent if kind == MessageType.UploadChunk]


def test_the_session_side_of_an_upload_on_a_script(monkeypatch):
    meta = {'dims': [2, 2, 10], 'type': 'uint8'}
    voxels = bytes(range(40))
    # Buffers of any size, sent in chunks of the server's chunk_bytes; only the last chunk is answered.
    s, t = scripted_session(monkeypatch)
    assert s.upload('up', meta, 40, [voxels[:7], memoryview(voxels)[7:30], np.frombuffer(voxels[30:], np.uint8)]) == {
        'dims': [2, 2, 10]}
    assert b''.join(chunks(t)) == voxels and {len(c) for c in chunks(t)} <= {1, 2, 3, 4}
    assert json.loads(t.sent[1][2]['meta_json']) == meta and t.sent[1][2]['bytes'] == 40
    # An Error answering a chunk part way stops the sending: 2 chunks of 10 sent, and no empty one after them.
    s, t = scripted_session(monkeypatch, fail_chunk=2)
    e = server_error(s.upload, 'up', meta, 40, [voxels])
    assert e.code == ErrorCode.Internal and e.message == 'disk full' and e.request_id == t.sent[-1][1]
    assert len(chunks(t)) == 2
    assert s.list_datasets() == ['up']  # the session goes on
    # The array raising part way: the upload is abandoned (an empty chunk), the error raised, the session goes on.

    def failing():
        yield voxels[:8]
        raise OSError('chunk 3 does not decode')

    s, t = scripted_session(monkeypatch)
    with pytest.raises(OSError, match='chunk 3'):
        s.upload('up', meta, 40, failing())
    assert [len(c) for c in chunks(t)] == [4, 0] and not t.inbox  # the second chunk was held back: 8 of 40 bytes
    assert s.list_datasets() == ['up']
    # More or fewer bytes than announced: ValueError, and abandoned the same way.
    for data, words in [([voxels, b'x'], 'more than the 40 bytes'), ([voxels[:39]], '39 bytes, the upload announced 40')]:
        s, t = scripted_session(monkeypatch)
        with pytest.raises(ValueError, match=words):
            s.upload('up', meta, 40, data)
        assert len(chunks(t)[-1]) == 0 and not t.inbox
    # Forbidden answering an Upload leaves the session open (version 6); answering a token, it ends it.
    s, t = scripted_session(monkeypatch, forbid_upload=True)
    assert server_error(s.upload, 'up', meta, 40, [voxels]).code == ErrorCode.Forbidden
    assert s.list_datasets() == ['up'] and not t.closed
    monkeypatch.setattr(voxbrick.session, 'open_transport', lambda *args: t)
    assert server_error(Session, '127.0.0.1:1', token='wrong').code == ErrorCode.Forbidden
    assert t.closed

