"""The client a notebook uses: datasets, their metadata and frames as NumPy arrays, and arrays sent as new datasets,
from one session with a server."""
from __future__ import annotations

import random
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, Iterable, Iterator, List, Optional, Sequence, Union

import numpy as np

from .arrays import as_volume
from .errors import ErrorCode, ServerError
from .images import decode_frame, scale_up
from .protocol import MAX_VERSION, MIN_VERSION, Encoding, encoding_of
from .scene import Camera, TransferFunction, build_scene
from .session import CLIENT_NAME, Capabilities, RawFrame, Session

_DEFAULT_SIZE = (512, 512)  # a scene's size when it names none (render/core/Scene.h)
_STILL_ENCODINGS = (Encoding.raw_rgba8, Encoding.png, Encoding.zstd_rgba8, Encoding.jpeg, Encoding.webp)
_BUSY_HINT_MS = 100  # the wait after a Busy reply that names none
_BUSY_JITTER = 1.2  # each wait is the hint times a random factor in [1, this]


@dataclass
class Frame:
    """One frame the server sent: its pixels and what it said about them.

    `image` is (height, width, 4) uint8 RGBA, row 0 at the top; `np.asarray(frame)` gives it too. `provisional` is
    True for a progressive or interactive Render's first frame (the exact one follows). `stats` is the frame's
    statistics (PROTOCOL.md, section 7), `scene` the scene it was asked with, `payload` the bytes as they came."""

    image: np.ndarray
    stats: Dict[str, Any]
    scene: Dict[str, Any]
    encoding: str
    request_id: int
    payload: bytes = field(repr=False)

    @property
    def provisional(self) -> bool:
        return bool(self.stats.get('provisional', False))

    @property
    def width(self) -> int:
        return self.image.shape[1]

    @property
    def height(self) -> int:
        return self.image.shape[0]

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        image = self.image if dtype is None else self.image.astype(dtype)
        return image.copy() if copy else image


def connect(address: str, token: Optional[str] = None, *, timeout: float = 120,
            max_version: int = MAX_VERSION, ca: Optional[str] = None, insecure: bool = False,
            busy_wait: float = 60) -> 'Client':
    """A session with the server at `address`.

    "HOST:PORT" is its TCP port (`voxbrick serve --port`), "tls://HOST:PORT" the same inside TLS (a server started
    with `--tls-cert`); "ws://HOST:PORT" (or the viewer's address, "http://HOST:PORT/?token=T") its HTTP port
    (`--http`), a WebSocket, and "wss://" / "https://" the same over TLS. `token`: the access token (`--http-token`, or
    one of the server's `[[tokens]]`), given when the WebSocket opens, or over TCP by Authenticate (protocol version
    5). Over TLS the server's certificate is verified against `ca` (a PEM file of CAs) or the system's CAs, and must
    name the host; `insecure=True` takes any certificate (a self-signed one in local use). `timeout`: seconds any reply
    may take. `max_version`: the highest protocol version offered (1 to 9; the session speaks the highest both sides
    do). `busy_wait`: the seconds one call may spend waiting out the server's Busy replies (to its Hello, a dataset's
    opening, its Renders: see Client); 0 raises the first. Raises ConnectionRefused (HTTP status and the server's
    words) for a refused upgrade, ServerError for a refused Hello or token (Forbidden, or Busy beyond `busy_wait`: the
    server is over capacity), TlsError for a certificate that does not verify, OSError when nothing listens."""
    return Client(address, token=token, timeout=timeout, max_version=max_version, ca=ca, insecure=insecure,
                  busy_wait=busy_wait)


class Client:
    """A session with a voxbrick server (see connect). Use it in a `with` block, or call close().

    Each call waits for its reply. An Error reply raises ServerError, whose `code` is the ErrorCode and `message` the
    server's words. The session has one open dataset at a time; the calls that take a dataset open it when it is not
    the open one. Not for use from several threads at once.

    A Render the server answers Busy (over capacity: a first moving camera while as many sessions drag as it keeps, a
    frame-rate quota, batch work) is sent again once the server's hint has passed ("; retry after N ms", 100 ms when
    it names none), times a random factor from 1 to 1.2 so that clients refused together do not come back together.
    The waits of one call (render, render_frame, frames, or one azimuth of orbit) add up to at most `busy_wait`
    seconds: the Busy reply whose wait would pass that is raised as it came, a ServerError whose `retry_after_ms` is
    the hint; busy_wait=0 raises the first. A session of protocol version 1 or 2 gets LimitExceeded with Busy's words,
    waited out the same way. A refused first drag keeps its place in the server's line while it is asked again within
    the hint and a second. A Busy answering Hello (a server configured with busy_at_hello takes no new session while
    it drags as many as it keeps; it closes the connection) is waited out by connecting again after its hint, and a
    Busy answering a dataset's opening (a PACS series being fetched) by asking again, each within `busy_wait` seconds
    too. `busy_waits` counts the Busy replies waited out."""

    def __init__(self, address: str, token: Optional[str] = None, *, timeout: float = 120,
                 min_version: int = MIN_VERSION, max_version: int = MAX_VERSION, client_name: str = CLIENT_NAME,
                 ca: Optional[str] = None, insecure: bool = False, busy_wait: float = 60):
        if isinstance(busy_wait, bool) or not isinstance(busy_wait, (int, float)) or not busy_wait >= 0:
            raise ValueError(f'busy_wait {busy_wait!r}: expected seconds, a number >= 0 (0: Busy raises at once)')
        self.busy_wait = float(busy_wait)
        self.busy_waits = 0  # Busy replies waited out: to Hello, OpenDataset and Renders
        # A Busy answering Hello (busy_at_hello: the server closed the connection) is waited out by a new connection.
        self.session = self._waiting_out_busy(
            lambda: Session(address, token, timeout=timeout, client_name=client_name, min_version=min_version,
                            max_version=max_version, ca=ca, insecure=insecure),
            about_the_session=True)

    @property
    def version(self) -> int:
        """The protocol version of the session."""
        return self.session.version

    @property
    def capabilities(self) -> Capabilities:
        """What the server said at Hello: version, its name, limits and the encodings it produces."""
        assert self.session.capabilities is not None
        return self.session.capabilities

    @property
    def dataset(self) -> Optional[str]:
        """The dataset open in the session, or None."""
        return self.session.dataset

    def datasets(self) -> List[str]:
        """The names of the datasets the server offers."""
        return self.session.list_datasets()

    def info(self, dataset: Optional[str] = None) -> Dict[str, Any]:
        """The metadata of `dataset` (opening it), or of the open one: for a grid its `dims`, `spacing`,
        `value_range`, `orientation` ...; for a mesh its `tets`, `bounds` ... (PROTOCOL.md, DatasetInfo)."""
        if dataset is None and self.session.meta is not None:
            return dict(self.session.meta)
        return dict(self._open(dataset))

    def stats(self) -> Dict[str, Any]:
        """The server's statistics."""
        return self.session.stats()

    def render(self, dataset: Optional[str] = None, *, camera: Camera = None, tf: TransferFunction = None,
               window: Optional[Sequence[float]] = None, size: Optional[Sequence[int]] = None,
               encoding: Union[str, Encoding] = 'png', scene: Union[Dict[str, Any], str, None] = None,
               **keys: Any) -> np.ndarray:
        """The exact frame of one scene as an array, (height, width, 4) uint8 RGBA.

        `camera`: a named view ("left"), an orbit (az, el[, dist]) or a camera dict (eye, center, up, fov, ...).
        `tf`: a preset name ("mri"), a list of [x, r, g, b, a] points, or a transfer-function dict. `window`:
        (lo, hi) raw values. `size`: (width, height). `encoding`: how the frame travels: "png" (lossless, the
        default), "raw" (lossless, large: within the server's message limit), "zstd" (lossless; needs the
        zstandard module), "jpeg" (lossy, opaque; needs Pillow) or "webp" (lossless, about 0.6 of png's bytes for
        longer encoding, protocol version 7; needs Pillow). `scene`: a whole scene dict or JSON text to start from.
        Other keywords are scene keys (PROTOCOL.md, section 6): step=0.5, quality="psnr:40", shading=True,
        background=[1, 1, 1] or "none", lod=0, ..."""
        return self.render_frame(dataset, camera=camera, tf=tf, window=window, size=size, encoding=encoding,
                                 scene=scene, **keys).image

    def render_frame(self, dataset: Optional[str] = None, *, camera: Camera = None, tf: TransferFunction = None,
                     window: Optional[Sequence[float]] = None, size: Optional[Sequence[int]] = None,
                     encoding: Union[str, Encoding] = 'png', scene: Union[Dict[str, Any], str, None] = None,
                     **keys: Any) -> Frame:
        """As render(), the exact Frame with its statistics."""
        frame = None
        for frame in self.frames(dataset, camera=camera, tf=tf, window=window, size=size, encoding=encoding,
                                 scene=scene, **keys):
            pass
        assert frame is not None and not frame.provisional
        return frame

    def frames(self, dataset: Optional[str] = None, *, camera: Camera = None, tf: TransferFunction = None,
               window: Optional[Sequence[float]] = None, size: Optional[Sequence[int]] = None,
               encoding: Union[str, Encoding] = 'png', scene: Union[Dict[str, Any], str, None] = None,
               progressive: Optional[bool] = None, interactive: Optional[bool] = None,
               **keys: Any) -> Iterator[Frame]:
        """The frames of one Render as they arrive, as render() takes it: with `progressive=True` (bricks not yet in
        the server's memory drawn from a coarser level) or `interactive=True` (drawn within `time_budget_ms`, a
        camera in motion), a provisional frame first, then the exact one, which ends the iteration; otherwise the
        exact frame alone. `provisional_encoding` may be "png", "raw", "zstd" or "jpeg". Take every frame before the
        session's next call: a newer Render makes the server drop an exact frame not yet started. A Busy reply is
        waited out before the first frame (see Client: busy_wait)."""
        request = self._request(dataset, camera, tf, window, size, encoding, scene,
                                dict(keys, progressive=progressive, interactive=interactive))
        for raw in self._replies(request):
            yield self._frame(raw, request[0])

    def orbit(self, dataset: Optional[str] = None, *, steps: int = 36, azimuths: Optional[Iterable[float]] = None,
              elevation: float = 20, distance: Optional[float] = None, interactive: bool = False,
              tf: TransferFunction = None, window: Optional[Sequence[float]] = None,
              size: Optional[Sequence[int]] = None, encoding: Union[str, Encoding] = 'png',
              scene: Union[Dict[str, Any], str, None] = None, **keys: Any) -> Iterator[Frame]:
        """Frames of a camera turning about the volume: an orbit at `elevation` degrees (and `distance` radii, or
        fitted) through `azimuths`, by default `steps` evenly from 0 to 360.

        Still (the default): one exact frame per azimuth. `interactive=True`: the turn as a drag, each frame drawn
        within the scene's `time_budget_ms` (the server's default 100 ms, or time_budget_ms=...), one provisional
        frame per azimuth, then the exact frame of the last one once the camera rests. An azimuth answered Busy (a
        server dragging as many sessions as it keeps) is asked again once the hint has passed, within `busy_wait`
        seconds for each azimuth (see Client), so the orbit has all its frames or raises ServerError."""
        if azimuths is None:
            if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
                raise ValueError(f'steps {steps!r}: expected a positive integer')
            azimuths = [360.0 * i / steps for i in range(steps)]
        azimuths = [float(a) for a in azimuths]
        if not azimuths:
            raise ValueError('azimuths: empty')
        orbit = [elevation] if distance is None else [elevation, distance]
        for i, azimuth in enumerate(azimuths):
            request = self._request(dataset, [azimuth, *orbit], tf, window, size, encoding, scene,
                                    dict(keys, interactive=True if interactive else None))
            replies = self._replies(request)
            if not interactive:
                for raw in replies:  # a still Render's exact frame (after a provisional one with progressive=True)
                    frame = self._frame(raw, request[0])
                    if not frame.provisional:
                        yield frame
                continue
            first = self._frame(next(replies), request[0])
            yield first
            if first.provisional and i == len(azimuths) - 1:
                for raw in replies:  # the camera rests: the exact frame of the last azimuth
                    yield self._frame(raw, request[0])

    def upload(self, name: str, array: Any, *, spacing: Sequence[float] = (1, 1, 1),
               origin: Optional[Sequence[float]] = None, axes: str = 'zyx', patient: bool = False,
               slab_bytes: int = 64 << 20, progress: Optional[Callable[[int, int], None]] = None,
               timeout: Optional[float] = None) -> Dict[str, Any]:
        """Sends a 3-D array to the server as a new dataset `name`, which the server preps as `voxbrick prep` does;
        returns its metadata, as info() gives it. The dataset is listed and opened like any other from then on; the
        session's open dataset does not change.

        `array`, `spacing`, `origin`, `axes` and `patient` as voxbrick.prep takes them (a NumPy array or memory map,
        a Zarr array, anything with `shape`, `dtype` and NumPy slicing; "zyx": the last axis is x), and the values
        stored as prep stores them (uint8, uint16, int16 as they are; int8 as int16; the others as float32; bool as
        uint8): the new dataset is the store voxbrick.prep makes of the same array. The array is read and sent a slab
        of at most `slab_bytes` at a time, so memory stays within about two slabs whatever its size.

        The server takes uploads only when configured to (`[upload] max_bytes`, docs/server.md#uploads) and from a
        session whose token may upload. Refusals raise ServerError with the server's words: Forbidden (no uploads, a
        token that may not upload or not open `name`, no token), AlreadyExists (`name` is taken or being uploaded),
        LimitExceeded (above the server's quota, or its disk), Malformed (a name that is not one: ASCII letters, digits,
        ".", "-", "_", not starting with "."), Busy (as many uploads in progress as the server takes), Internal
        (prep's words). Nothing of a refused upload is kept. ValueError, before anything is sent, for an array or
        argument that cannot be sent (not 3-D, a dtype prep does not take, a spacing that is not three positive
        numbers); ProtocolError UnsupportedVersion when the session speaks a version below 6. The server's last
        answer comes once it has prepped the store: within `timeout` seconds of the last chunk (default: the session's
        timeout). `progress(sent, total)`, if given, is called with the bytes sent after each chunk and once more with
        `total` when the server has answered (a progress bar's update)."""
        volume = as_volume(array, spacing=spacing, origin=origin, axes=axes, patient=patient, slab_bytes=slab_bytes,
                           purpose='upload')
        if not isinstance(name, str) or not name:
            raise ValueError(f'name {name!r}: the new dataset\'s name, a str')
        return self.session.upload(name, volume.meta(), volume.nbytes, volume.slabs(slab_bytes), progress=progress,
                                   timeout=timeout)

    def close(self) -> None:
        """Says Goodbye and closes the connection."""
        self.session.close()

    def __enter__(self) -> 'Client':
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        a = self.session.address
        scheme = {('tcp', False): 'tcp', ('tcp', True): 'tls', ('ws', False): 'ws', ('ws', True): 'wss'}[a.scheme, a.tls]
        return f'<voxbrick.Client {scheme}://{a.host}:{a.port} version {self.version} dataset {self.dataset!r}>'

    # Helpers.

    def _open(self, dataset: Optional[str]) -> Dict[str, Any]:
        if dataset is None:
            if self.session.dataset is None:
                raise ValueError('no dataset is open: pass the dataset\'s name (this server offers: '
                                 f'{", ".join(self.datasets()) or "none"})')
            assert self.session.meta is not None
            return self.session.meta
        if not isinstance(dataset, str):
            raise ValueError(f'dataset {dataset!r}: expected its name, a str')
        if dataset != self.session.dataset:
            # A dataset the server is still making (a PACS series being fetched) is Busy, saying where it stands.
            self._waiting_out_busy(lambda: self.session.open_dataset(dataset))
        assert self.session.meta is not None
        return self.session.meta

    def _request(self, dataset: Optional[str], camera: Camera, tf: TransferFunction,
                 window: Optional[Sequence[float]], size: Optional[Sequence[int]], encoding: Union[str, Encoding],
                 scene: Union[Dict[str, Any], str, None], keys: Dict[str, Any]) -> tuple:
        """(scene, encoding) of a Render, the dataset opened; ValueError for what this client cannot take."""
        encoding = encoding_of(encoding)
        if encoding not in _STILL_ENCODINGS:
            raise ValueError(f'encoding {encoding.name}: a video frame is one of a stream for a moving camera, '
                             'refused as a Render\'s encoding; this client takes png, raw, zstd, jpeg or webp')
        built = build_scene(scene, camera=camera, tf=tf, window=window, size=size, **keys)
        provisional = built.get('provisional_encoding')
        if provisional is not None and encoding_of(provisional) not in _STILL_ENCODINGS:
            raise ValueError(f'provisional_encoding {provisional!r}: this client does not decode video streams; '
                             'use png, raw, zstd, jpeg or webp')
        self._open(dataset)
        return built, encoding

    def _waiting_out_busy(self, call: Callable[[], Any], about_the_session: bool = False) -> Any:
        """`call`'s result, called again after each Busy reply's wait (_busy_wait_of) while the waits stay within
        busy_wait; the Busy whose wait would pass it is raised as it came, and so is any other error.
        `about_the_session`: `call` makes the session, and the Busy it may meet answers its Hello."""
        waited = 0.0
        while True:
            try:
                return call()
            except ServerError as e:
                wait = self._busy_wait_of(e, about_the_session)
                if wait is None or waited + wait > self.busy_wait:
                    raise
                time.sleep(wait)
                waited += wait
                self.busy_waits += 1

    def _replies(self, request: tuple) -> Iterator[RawFrame]:
        """The Frames answering a Render of `request` (scene, encoding), as Session.frames gives them; a Busy reply
        sends the same Render again after its hint, while the waits of this Render stay within busy_wait."""
        def first() -> tuple:
            replies = self.session.frames(self.session.send_render(*request))
            return next(replies), replies  # Busy is a Render's only reply: decided before anything is drawn
        frame, replies = self._waiting_out_busy(first)
        yield frame
        yield from replies

    def _busy_wait_of(self, error: ServerError, about_the_session: bool = False) -> Optional[float]:
        """The seconds to wait before asking again after `error` (its hint, 100 ms when it names none, times a random
        factor in [1, 1.2]), or None when it is no Busy reply to a request. A Busy with request id 0 answers Hello
        (`about_the_session`) and has ended that connection. Versions 1 and 2 get Busy's words, and its hint, as
        LimitExceeded; other LimitExceeded replies name no hint."""
        if (error.request_id == 0) != about_the_session:
            return None
        hint = error.retry_after_ms
        if error.code == ErrorCode.Busy:
            hint = _BUSY_HINT_MS if hint is None else hint
        elif about_the_session or not (error.code == ErrorCode.LimitExceeded and self.session.version < 3
                                       and hint is not None):
            return None
        return hint / 1000 * random.uniform(1, _BUSY_JITTER)

    @staticmethod
    def _frame(raw: RawFrame, scene: Dict[str, Any]) -> Frame:
        image = decode_frame(raw.payload, raw.encoding, raw.width, raw.height)
        # From protocol version 8 a provisional frame comes at the size it was drawn: shown at the scene's, as the
        # server scaled it for older clients.
        width, height = scene.get('size', _DEFAULT_SIZE)
        if raw.stats.get('provisional', False) and (raw.width, raw.height) != (width, height):
            image = scale_up(image, width, height)
        return Frame(image, raw.stats, scene, raw.encoding.name, raw.request_id, raw.payload)
