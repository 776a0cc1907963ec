"""voxbrick.connect and the Client against the real server: every call, frames equal to `voxbrick render`'s, the
server's own words in errors, versions, the WebSocket and its token, Busy replies waited out."""
from __future__ import annotations

import json
import threading
import time

import numpy as np
import pytest

import voxbrick
from voxbrick import ErrorCode, ServerError
from voxbrick.images import decode_frame
from voxbrick.protocol import Encoding, MessageType, encode
from conftest import TOKEN, Scripted, Server, fresh, largest_difference, render_cli

MRI_SCENE = dict(camera='left', tf='mri', size=(96, 80), shading=True)


@pytest.fixture
def client(server):
    with voxbrick.connect(server.address) as c:
        yield c


def psnr(a, b):
    error = np.mean((a[..., :3].astype(float) - b[..., :3].astype(float)) ** 2)
    return 10 * np.log10(255 ** 2 / error) if error else float('inf')


def test_datasets_info_and_stats(client):
    assert client.version == 9
    caps = client.capabilities
    assert caps.max_message_bytes == 1 << 20 and caps.max_image_side == 4096
    assert [e.name for e in caps.encodings] == ['raw_rgba8', 'png', 'zstd_rgba8', 'jpeg', 'vp8', 'vp9', 'webp']
    assert client.datasets() == ['cold', *[f'fresh-{i}' for i in range(4)], 'mri.vbs', 'sparse']
    assert client.dataset is None
    meta = client.info('mri.vbs')
    assert client.dataset == 'mri.vbs'
    assert meta['kind'] == 'brick-store'
    assert meta['dims'] == [301, 370, 316] and meta['spacing'] == [0.5, 0.5, 0.5] and meta['type'] == 'u8'
    assert meta['orientation']['patient'] is True
    assert client.info() == meta  # the open dataset's
    client.render(size=(16, 16))
    stats = client.stats()
    assert stats['renders']['frames'] >= 1, stats


def test_a_frame_is_the_frame_voxbrick_render_draws(client, datasets, tmp_path):
    name = fresh()
    frame = client.render_frame(name, **MRI_SCENE)
    assert frame.encoding == 'png'
    assert frame.image.shape == (80, 96, 4) and frame.image.dtype == np.uint8
    assert not frame.provisional and frame.stats['bricks_drawn'] > 0
    assert frame.scene == {'camera': {'view': 'left'}, 'transfer_function': 'mri', 'size': [96, 80], 'shading': True}
    expected = voxbrick.read_png(str(render_cli(datasets / name, frame.scene, tmp_path / 'cli.png')))
    assert np.array_equal(frame.image, expected)  # byte for byte, every channel
    assert frame.image[..., :3].max() > 100  # the head is there, not a black frame
    assert np.array_equal(np.asarray(frame), frame.image)
    # The same scene again, in the other lossless encodings: the same bytes.
    for encoding, wire in [('raw', 'raw_rgba8'), ('zstd', 'zstd_rgba8'), ('png', 'png')]:
        again = client.render_frame(name, encoding=encoding, **MRI_SCENE)
        assert again.encoding == wire
        assert np.array_equal(again.image, expected), encoding


def test_cameras_transfer_functions_windows_and_scene_keys(client, datasets, tmp_path):
    # Every form of each argument, as the scene the server gets.
    points = [[0, 0, 0, 0, 0], [0.3, 1, 0.5, 0, 0.1], [1, 1, 1, 1, 0.8]]
    eye = {'eye': [0, 300, 0], 'center': [0, 0, 0], 'up': [0, 0, 1], 'fov': 40}
    forms = [
        (dict(camera='superior'), {'camera': {'view': 'superior'}}),
        (dict(camera=(90, 0)), {'camera': {'orbit': [90, 0]}}),
        (dict(camera=np.array([90, 0, 3.5])), {'camera': {'orbit': [90, 0, 3.5]}}),
        (dict(camera=eye), {'camera': eye}),
        (dict(tf='hot'), {'transfer_function': 'hot'}),
        (dict(tf=np.array(points)), {'transfer_function': {'points': points}}),
        (dict(tf={'points': points, 'reference_length': 2}), {'transfer_function': {'points': points,
                                                                                     'reference_length': 2}}),
        (dict(window=(np.uint8(20), 200)), {'window': [20, 200]}),
        (dict(scene='{"lod": 0, "camera": {"view": "left"}}', camera=(1, 2)), {'lod': 0, 'camera': {'orbit': [1, 2]}}),
        (dict(step=np.float32(1.5), shading=None, background='none'), {'step': 1.5, 'background': 'none'}),
    ]
    for kwargs, scene in forms:
        frame = client.render_frame('sparse', size=(16, 16), **kwargs)
        assert frame.scene == dict(scene, size=[16, 16]), kwargs
    # One scene of many keys, byte for byte the command line's frame.
    name = fresh()
    frame = client.render_frame(name, camera=(120, 15, 3.5), tf=np.array(points), window=(20, 200), step=1.5,
                                background='none', size=(64, 48))
    expected = voxbrick.read_png(str(render_cli(datasets / name, frame.scene, tmp_path / 'f.png')))
    assert np.array_equal(frame.image, expected)
    assert frame.image[..., 3].min() == 0 and frame.image[..., 3].max() > 100  # transparent around the head


def test_a_webp_frame_is_the_png_frame_in_fewer_bytes(client):
    png = client.render_frame('mri.vbs', **MRI_SCENE)
    webp = client.render_frame('mri.vbs', encoding='webp', **MRI_SCENE)
    assert webp.encoding == 'webp' and webp.payload[8:12] == b'WEBP'
    assert np.array_equal(webp.image, png.image)
    assert len(webp.payload) < len(png.payload)


def test_jpeg_is_close_to_the_lossless_frame(client):
    exact = client.render('mri.vbs', **MRI_SCENE)
    jpeg = client.render_frame('mri.vbs', encoding='jpeg', jpeg_quality=90, **MRI_SCENE)
    assert jpeg.encoding == 'jpeg' and jpeg.payload[:2] == b'\xff\xd8'
    assert (jpeg.image[..., 3] == 255).all()
    assert 30 < psnr(jpeg.image, exact) < float('inf')


def test_progressive_frames_arrive_coarse_then_exact(client):
    scene = dict(camera=(30, 20), size=(64, 64), tf='hot')
    frames = list(client.frames('cold', progressive=True, **scene))  # no brick of it in the server's memory yet
    assert [f.provisional for f in frames] == [True, False]
    assert frames[0].stats['bricks_standin'] > 0 and frames[1].stats['bricks_standin'] == 0
    assert not np.array_equal(frames[0].image, frames[1].image)
    assert largest_difference(frames[1].image, client.render(**scene)) <= 1  # PROTOCOL.md: within 1/255


def test_an_interactive_frame_then_the_exact_one(client):
    scene = dict(camera=(120, 10), size=(64, 64), tf='mri')
    frames = list(client.frames('mri.vbs', interactive=True, time_budget_ms=20, **scene))
    assert [f.provisional for f in frames] == [True, False]
    assert frames[0].stats['interactive']['budget_ms'] == 20
    assert largest_difference(frames[1].image, client.render(**scene)) <= 1  # PROTOCOL.md: within 1/255


def test_a_provisional_frame_drawn_smaller_is_shown_at_the_scenes_size(datasets, tmp_path):
    # Version 8: the server sends the drawing, the client scales it up; a version-7 session gets it scaled up by the
    # server. A fresh server for each: its first interactive frame is the cheapest drawing (64 pixels a side), the
    # same in both. The same picture.
    scene = dict(camera=(120, 10), size=(160, 160), tf='mri', time_budget_ms=20, provisional_encoding='png')
    shown = {}
    for version in (8, 7):
        (tmp_path / str(version)).mkdir()
        server = Server(datasets, tmp_path / str(version))
        try:
            with voxbrick.connect(server.address, max_version=version) as c:
                first = next(iter(c.frames('mri.vbs', interactive=True, **scene)))
        finally:
            server.stop()
        assert first.provisional and first.stats['interactive']['width'] == 64
        assert first.image.shape == (160, 160, 4)
        shown[version] = first
    # decode_frame refuses a payload of another size than it is told.
    assert decode_frame(shown[8].payload, 'png', 64, 64).shape == (64, 64, 4), 'version 8 sends the drawing'
    assert decode_frame(shown[7].payload, 'png', 160, 160).shape == (160, 160, 4), 'version 7: scaled up'
    assert largest_difference(shown[8].image, shown[7].image) <= 2


def test_orbits(client):
    still = list(client.orbit('sparse', steps=4, elevation=10, size=(32, 32), tf='hot'))
    assert [f.scene['camera'] for f in still] == [{'orbit': [a, 10]} for a in (0.0, 90.0, 180.0, 270.0)]
    assert not any(f.provisional for f in still)
    assert largest_difference(still[1].image, client.render(camera=(90, 10), size=(32, 32), tf='hot')) <= 1
    assert len({f.image.tobytes() for f in still}) == 4
    drag = list(client.orbit(azimuths=[0, 5, 10], elevation=10, distance=3, interactive=True, size=(32, 32), tf='hot'))
    assert [f.provisional for f in drag] == [True, True, True, False]
    assert [f.scene['camera']['orbit'] for f in drag] == [[0, 10, 3], [5, 10, 3], [10, 10, 3], [10, 10, 3]]
    assert all(f.scene['interactive'] is True for f in drag)


def test_errors_carry_the_servers_code_and_words(client):
    with pytest.raises(ServerError) as e:
        client.info('nope')
    assert e.value.code == ErrorCode.UnknownDataset
    assert e.value.message.startswith("no dataset 'nope' (one of: cold, fresh-0, ")
    assert str(e.value) == f'UnknownDataset: {e.value.message}'
    assert e.value.request_id > 0
    assert client.dataset is None  # the session is as it was
    with pytest.raises(ValueError, match=r'no dataset is open: pass the dataset\'s name \(this server offers: cold'):
        client.render()
    with pytest.raises(ServerError, match=r"InvalidScene: scene: 'window' must be \[lo, hi\] in increasing order"):
        client.render('sparse', window=(5, 1))
    with pytest.raises(ServerError, match="InvalidScene: .*unknown key 'camera.zoom'"):
        client.render(camera={'zoom': 2})
    with pytest.raises(ServerError, match="InvalidScene: .*unknown key 'colour'"):
        client.render(colour='red')
    with pytest.raises(ServerError) as e:
        client.render(size=(1024, 1024), encoding='raw')  # 4 MiB: past the server's 1 MiB message limit
    assert e.value.code == ErrorCode.LimitExceeded and '1048576' in e.value.message
    assert client.render(size=(8, 8)).shape == (8, 8, 4)  # the session goes on
    # What this client declines, before anything is sent.
    with pytest.raises(ValueError, match='encoding vp8: a video frame'):
        client.render(encoding='vp8')
    with pytest.raises(ValueError, match="provisional_encoding 'vp9': this client does not decode video"):
        client.render(interactive=True, provisional_encoding='vp9')
    with pytest.raises(ValueError, match=r'size \(0, 4\): expected \(width, height\), two positive integers'):
        client.render(size=(0, 4))
    with pytest.raises(ValueError, match="camera 'front': a named view is one of anterior"):
        client.render(camera='front')
    with pytest.raises(ValueError, match=r'window \(lo, hi\): 1; expected 2 numbers'):
        client.render(window=1)


def test_versions_are_negotiated(server):
    with voxbrick.connect(server.address, max_version=1) as old:
        assert old.version == 1
        assert [e.name for e in old.capabilities.encodings] == ['raw_rgba8', 'png', 'zstd_rgba8']
        with pytest.raises(ValueError, match='jpeg needs protocol version 2; this session speaks version 1'):
            old.render('sparse', encoding='jpeg')
        assert old.render('sparse', size=(16, 16)).shape == (16, 16, 4)
    with voxbrick.connect(server.address, max_version=2) as two:
        assert two.version == 2
        assert two.render_frame('sparse', size=(16, 16), encoding='jpeg').encoding == 'jpeg'
    with pytest.raises(ValueError, match=r'versions 1..10: this client speaks 1..9'):
        voxbrick.connect(server.address, max_version=10)


def test_the_websocket_and_its_token(server):
    with voxbrick.connect(server.address) as tcp:
        expected = tcp.render('mri.vbs', **MRI_SCENE)
    for address, token in [(server.ws, TOKEN), (f'{server.viewer}/?token={TOKEN}', None)]:
        with voxbrick.connect(address, token=token) as ws:
            assert 'mri.vbs' in ws.datasets()
            assert largest_difference(ws.render('mri.vbs', **MRI_SCENE), expected) <= 1
            # A frame larger than a WebSocket frame's 16-bit length, in one message.
            assert ws.render(size=(200, 150), encoding='zstd').shape == (150, 200, 4)
    with pytest.raises(voxbrick.ConnectionRefused) as e:
        voxbrick.connect(server.ws, token='wrong-token')
    assert e.value.status == 403 and 'wrong access token' in e.value.reason
    with pytest.raises(voxbrick.ConnectionRefused) as e:
        voxbrick.connect(server.ws)
    assert e.value.status == 403 and 'an access token is required' in e.value.reason
    # Over TCP the token is presented by Authenticate (version 5): the server's one token (`--http-token`) is taken
    # there too, by its name in the configuration, and a wrong one is Forbidden.
    with voxbrick.connect(server.address, token=TOKEN) as tcp:
        assert tcp.session.token_id == 'http.token'
        assert 'mri.vbs' in tcp.datasets()
    with pytest.raises(voxbrick.ServerError) as e:
        voxbrick.connect(server.address, token='wrong-token')
    assert e.value.code == voxbrick.ErrorCode.Forbidden


def test_a_server_that_goes_away(datasets, work):
    from conftest import Server
    own = work / 'own'
    own.mkdir()
    s = Server(datasets, own)
    c = voxbrick.connect(s.address)
    assert c.datasets()
    s.stop()
    with pytest.raises(ServerError) as e:  # a clean stop says so first
        c.datasets()
    assert e.value.code == ErrorCode.ShuttingDown and e.value.request_id == 0
    with pytest.raises(voxbrick.ConnectionClosed, match='the session ended: the server closed the session: '
                                                        'ShuttingDown'):
        c.datasets()
    c.close()  # closing a closed session is harmless
    with pytest.raises(ConnectionRefusedError):
        voxbrick.connect(s.address)


# Busy replies to Renders, waited out (busy_wait).

SMALL = dict(size=(32, 32), tf='hot')


def configured_server(datasets, tmp_path, toml: str) -> Server:
    """A server of its own whose server.toml is `toml`."""
    config = tmp_path / 'server.toml'
    config.write_text(toml)
    return Server(datasets, tmp_path, extra=('--config', str(config)))


class Dragger(threading.Thread):
    """A session dragging the camera for `seconds` through `client`: an interactive Render of sparse about 20 times
    a second, each waited for until its provisional frame. `dragging` is set at its first frame; `last_sent` is when
    it sent its last Render (time.monotonic)."""

    def __init__(self, client: voxbrick.Client, seconds: float):
        super().__init__(daemon=True)
        self.client, self.seconds = client, seconds
        self.dragging = threading.Event()
        self.last_sent = 0.0
        self.frames = 0
        self.error = None

    def run(self) -> None:
        try:
            end = time.monotonic() + self.seconds
            while time.monotonic() < end:
                self.last_sent = time.monotonic()
                first = next(iter(self.client.frames('sparse', camera=(5 * self.frames, 10), interactive=True,
                                                     **SMALL)))
                assert first.provisional
                self.frames += 1
                self.dragging.set()
                time.sleep(0.05)
        except BaseException as e:  # handed to the test's thread
            self.error = e
            self.dragging.set()

    def finish(self) -> None:
        self.join(30)
        assert not self.is_alive()
        if self.error is not None:
            raise self.error
        assert self.frames >= 5, f'the drag had {self.frames} frames'


@pytest.fixture
def one_drag_server(datasets, tmp_path):
    """A server that keeps one dragging session (max_interactive_sessions): a second session's first moving camera is
    Busy while the first drags (a new session is taken all the same: its still frames are drawn)."""
    s = configured_server(datasets, tmp_path, '[scheduler]\nmax_interactive_sessions = 1\n')
    yield s
    s.stop()


def test_a_drag_refused_busy_waits_its_turn(one_drag_server):
    with voxbrick.connect(one_drag_server.address, busy_wait=0) as first:
        dragger = Dragger(first, 1.5)
        dragger.start()
        assert dragger.dragging.wait(20)
        second = voxbrick.connect(one_drag_server.address, busy_wait=10)  # taken while the other drags
        second.info('sparse')
        arrived = []
        began = time.monotonic()
        for frame in second.orbit(steps=3, elevation=10, interactive=True, **SMALL):
            arrived.append((time.monotonic(), frame))
        dragger.finish()
        second.close()
    frames = [frame for _, frame in arrived]
    assert [f.provisional for f in frames] == [True, True, True, False]
    assert [f.scene['camera']['orbit'] for f in frames] == [[0, 10], [120, 10], [240, 10], [240, 10]]
    assert second.busy_waits >= 1, 'the first azimuth was refused while the other session dragged'
    # Its drag was taken only once the other's had ended: a session drags for a second after its last move.
    assert arrived[0][0] - dragger.last_sent > 0.9, (arrived[0][0] - dragger.last_sent, second.busy_waits)
    assert arrived[-1][0] - began < 10


def test_a_session_refused_at_hello_connects_again_after_the_hint(datasets, tmp_path):
    # busy_at_hello with room for one drag: while one session drags, a new one is refused at Hello (the server
    # closes it); connect waits the hint out, connects again and is taken once the drag is over. busy_wait=0 raises.
    server = configured_server(datasets, tmp_path, '[scheduler]\nmax_interactive_sessions = 1\nbusy_at_hello = true\n')
    try:
        with voxbrick.connect(server.address, busy_wait=0) as first:
            dragger = Dragger(first, 3)
            dragger.start()
            assert dragger.dragging.wait(20)
            with pytest.raises(ServerError) as e:
                voxbrick.connect(server.address, busy_wait=0)
            assert e.value.code == ErrorCode.Busy and e.value.request_id == 0, e.value
            assert e.value.retry_after_ms is not None and e.value.retry_after_ms > 0, e.value.message
            began = time.monotonic()
            with voxbrick.connect(server.address, busy_wait=20) as late:
                waited = time.monotonic() - began
                assert late.busy_waits >= 1
                assert waited >= 1.5, waited  # the hint is 2 s (at least 1.5 of it, whatever the moment)
                assert late.render('sparse', **SMALL).shape == (32, 32, 4)
            dragger.finish()
    finally:
        server.stop()


def test_busy_wait_0_raises_a_refused_drag(one_drag_server):
    with voxbrick.connect(one_drag_server.address, busy_wait=0) as first, \
            voxbrick.connect(one_drag_server.address, busy_wait=0) as second:
        second.info('sparse')
        dragger = Dragger(first, 1.5)
        dragger.start()
        assert dragger.dragging.wait(20)
        began = time.monotonic()
        with pytest.raises(ServerError) as e:
            list(second.orbit(steps=3, elevation=10, interactive=True, **SMALL))
        assert time.monotonic() - began < 1, 'raised at once'
        assert e.value.code == ErrorCode.Busy and e.value.request_id > 0
        assert 'over capacity' in e.value.message and e.value.retry_after_ms > 0, e.value.message
        assert second.busy_waits == 0
        assert second.render(camera=(0, 10), **SMALL).shape == (32, 32, 4)  # the session goes on: its still frames
        dragger.finish()


def test_renders_past_a_frame_rate_quota_wait_their_turn(datasets, tmp_path):
    # Two Renders a second from an address (loopback included: loopback_exempt is false by default), in a bucket of
    # two: six Renders take at least two seconds from the first.
    server = configured_server(datasets, tmp_path, '[quotas]\nframes_per_s_per_address = 2\n')
    try:
        with voxbrick.connect(server.address, busy_wait=10) as c:
            c.info('sparse')
            began = time.monotonic()
            images = [c.render(camera=(30 * i, 10), **SMALL) for i in range(6)]
            took = time.monotonic() - began
            assert len({image.tobytes() for image in images}) == 6
            assert 1.9 < took < 10, took
            assert c.busy_waits >= 1
        # busy_wait=0: the quota's Busy, as it came, and the session goes on once its hint has passed.
        with voxbrick.connect(server.address, busy_wait=0) as c:
            c.info('sparse')
            with pytest.raises(ServerError) as e:
                for i in range(6):
                    c.render(camera=(30 * i, 10), **SMALL)
            assert e.value.code == ErrorCode.Busy and e.value.request_id > 0
            assert 'frames_per_s_per_address' in e.value.message and 0 < e.value.retry_after_ms <= 500, e.value.message
            assert c.busy_waits == 0
            time.sleep(e.value.retry_after_ms / 1000)
            assert c.render(**SMALL).shape == (32, 32, 4)
        # A version-2 session gets Busy's words as LimitExceeded: waited out the same way, or raised with busy_wait=0.
        with voxbrick.connect(server.address, max_version=2, busy_wait=10) as old:
            old.info('sparse')
            assert len([old.render(camera=(30 * i, 10), **SMALL) for i in range(4)]) == 4
            assert old.busy_waits >= 1
        with voxbrick.connect(server.address, max_version=2, busy_wait=0) as old:
            old.info('sparse')
            with pytest.raises(ServerError) as e:
                for i in range(6):
                    old.render(camera=(30 * i, 10), **SMALL)
            assert e.value.code == ErrorCode.LimitExceeded and e.value.retry_after_ms > 0, e.value.message
    finally:
        server.stop()


def busy_script(monkeypatch, refusals, version=9, code=ErrorCode.Busy):
    """A Client of `version` on a script that answers Renders with Error `code`, each message the next of `refusals`
    (then a raw 2x2 Frame), and the sleeps it takes, recorded in place of sleeping."""
    refusals = list(refusals)

    def answer(header, fields):
        t, rid = header.type, header.request_id
        if t == MessageType.Hello:
            yield encode(MessageType.Capabilities, rid, version, version=version, server='script',
                         max_message_bytes=1 << 20, max_image_side=4096, max_queued_per_session=4,
                         encodings=[Encoding.raw_rgba8])
        elif t == MessageType.OpenDataset:
            yield encode(MessageType.DatasetInfo, rid, version, name=fields['name'], meta_json='{}')
        elif t == MessageType.Render and refusals:
            yield encode(MessageType.Error, rid, version, code=code, message=refusals.pop(0))
        elif t == MessageType.Render:
            yield encode(MessageType.Frame, rid, version, width=2, height=2, encoding=Encoding.raw_rgba8,
                         stats_json='{}', payload=bytes(16))

    transport = Scripted(answer)
    monkeypatch.setattr(voxbrick.session, 'open_transport', lambda *args: transport)
    slept = []
    monkeypatch.setattr(voxbrick.client.time, 'sleep', slept.append)
    return transport, slept


def test_busy_waits_on_a_script(monkeypatch):
    def renders(t):
        return [json.loads(fields['scene_json']) for kind, _, fields in t.sent if kind == MessageType.Render]

    # The hint times a factor in [1, 1.2]; 100 ms when the message names none; the same Render each time.
    t, slept = busy_script(monkeypatch, ['over capacity; retry after 300 ms', 'over capacity', 'quota; retry after '
                                         '1 ms'])
    c = voxbrick.Client('127.0.0.1:1', busy_wait=5)
    assert c.render('x', camera=(10, 20), size=(2, 2), encoding='raw').shape == (2, 2, 4)
    assert len(slept) == 3 and c.busy_waits == 3
    assert 0.3 <= slept[0] <= 0.36 and 0.1 <= slept[1] <= 0.12 and 0.001 <= slept[2] <= 0.0012, slept
    assert len({round(w / hint, 9) for w, hint in zip(slept, (0.3, 0.1, 0.001))}) == 3, 'a random factor each'
    assert renders(t) == [{'camera': {'orbit': [10, 20]}, 'size': [2, 2]}] * 4
    # Waits stop short of busy_wait: the refusal whose wait would pass it is raised as it came. Each call has its own.
    t, slept = busy_script(monkeypatch, ['busy; retry after 400 ms'] * 3)
    c = voxbrick.Client('127.0.0.1:1', busy_wait=1)
    with pytest.raises(ServerError) as e:
        c.render('x', size=(2, 2), encoding='raw')
    assert e.value.message == 'busy; retry after 400 ms' and e.value.retry_after_ms == 400
    assert len(slept) == 2 and sum(slept) <= 1 and c.busy_waits == 2
    assert c.render(size=(2, 2), encoding='raw').shape == (2, 2, 4)  # the next call waits its own second
    assert len(slept) == 2
    # busy_wait=0 raises the first.
    t, slept = busy_script(monkeypatch, ['busy; retry after 1 ms'])
    c = voxbrick.Client('127.0.0.1:1', busy_wait=0)
    with pytest.raises(ServerError):
        c.render('x', size=(2, 2), encoding='raw')
    assert slept == [] and c.busy_waits == 0
    # Version 2: LimitExceeded with a hint is Busy's; without one (a frame above the limit, say) it is raised.
    t, slept = busy_script(monkeypatch, ['busy; retry after 50 ms', 'frame above the limit'], version=2,
                           code=ErrorCode.LimitExceeded)
    c = voxbrick.Client('127.0.0.1:1', max_version=2)
    with pytest.raises(ServerError, match='LimitExceeded: frame above the limit'):
        c.render('x', size=(2, 2), encoding='raw')
    assert len(slept) == 1 and 0.05 <= slept[0] <= 0.06
    # ... and from version 3 on LimitExceeded is never Busy; nor is any other error.
    for code in (ErrorCode.LimitExceeded, ErrorCode.Internal, ErrorCode.Superseded):
        t, slept = busy_script(monkeypatch, ['no; retry after 50 ms'], code=code)
        with pytest.raises(ServerError) as e:
            voxbrick.Client('127.0.0.1:1').render('x', size=(2, 2), encoding='raw')
        assert e.value.code == code and slept == []
    with pytest.raises(ValueError, match='busy_wait -1'):
        voxbrick.Client('127.0.0.1:1', busy_wait=-1)
