"""One session with a voxbrick server (PROTOCOL.md, section 5), in protocol terms: Hello, datasets, Render requests
and their Frame replies, statistics, uploads, Goodbye. The standard library only; `voxbrick.Client` builds scenes and
images on top of it.
"""
from __future__ import annotations

import json
import socket
from typing import Any, Callable, Dict, Iterable, Iterator, List, NamedTuple, Optional, Union

from .errors import ConnectionClosed, ErrorCode, ProtocolError, ServerError
from .protocol import (ENCODING_SINCE, HEADER_BYTES, MAX_BODY_BYTES, MAX_VERSION, MIN_VERSION, Encoding, MessageType,
                       decode_body, encode, encoding_of)
from .transport import Address, open_transport, parse_address

CLIENT_NAME = 'voxbrick-python 1'
#: Errors with request id 0 after which the server closes the connection (PROTOCOL.md, section 8).
_CLOSING = (ErrorCode.BadMagic, ErrorCode.UnsupportedVersion, ErrorCode.TooLarge, ErrorCode.LimitExceeded,
            ErrorCode.ShuttingDown, ErrorCode.Timeout, ErrorCode.Busy)


class Capabilities(NamedTuple):
    """The server's Capabilities: the session's protocol version, its limits and the encodings it produces."""

    version: int
    server: str
    max_message_bytes: int
    max_image_side: int
    max_queued_per_session: int
    encodings: List[Encoding]


class RawFrame(NamedTuple):
    """A Frame reply as it came: the payload still encoded. `stats` is the parsed stats_json; `message_bytes` the
    whole message's size (header included), as FrameReceived reports it."""

    request_id: int
    width: int
    height: int
    encoding: Encoding
    stats: Dict[str, Any]
    payload: bytes
    message_bytes: int

    @property
    def provisional(self) -> bool:
        """True for a provisional frame (a progressive or interactive Render's first answer; the exact one follows)."""
        return bool(self.stats.get('provisional', False))


class Session:
    """A connected session: opens the connection and says Hello at once (the server closes connections that wait).

    Requests wait for their reply; an Error reply raises ServerError with the server's code and words. Not for use from
    several threads at once. `address`: "HOST:PORT" or "tls://HOST:PORT" (TCP), or "ws[s]://HOST:HTTP_PORT" / the
    viewer's "http[s]://..." URL (a WebSocket). `token`: the access token, given in the WebSocket's upgrade, or over TCP
    by Authenticate after Hello (version 5; `token_id` is then the server's name for it). Over TLS the server's
    certificate is verified against `ca` (a PEM file) or the system's CAs; `insecure` takes any certificate."""

    def __init__(self, address: Union[str, Address], token: Optional[str] = None, timeout: float = 120,
                 client_name: str = CLIENT_NAME, min_version: int = MIN_VERSION, max_version: int = MAX_VERSION,
                 ca: Optional[str] = None, insecure: bool = False):
        if not MIN_VERSION <= min_version <= max_version <= MAX_VERSION:
            raise ValueError(f'versions {min_version}..{max_version}: this client speaks {MIN_VERSION}..{MAX_VERSION}')
        self.address = address if isinstance(address, Address) else parse_address(address, token)
        if (ca is not None or insecure) and not self.address.tls:
            raise ValueError(f'ca= and insecure= are for TLS: connect to "tls://{self.address.host}:'
                             f'{self.address.port}" (TCP) or "wss://..." / "https://..." (the HTTP port)')
        if self.address.token is not None and self.address.scheme == 'tcp' and max_version < 5:
            raise ValueError('a token over TCP needs protocol version 5 (Authenticate): max_version=5, or connect to '
                             'the HTTP port ("ws://HOST:HTTP_PORT"), where the token opens the WebSocket')
        self._timeout = timeout
        self._transport = open_transport(self.address, timeout, ca, insecure)
        self._next_id = 1
        self._max_body = MAX_BODY_BYTES  # the largest body accepted: the default limit, or the server's if higher
        self.version = min_version  # Hello is written in the lowest version offered
        self.dataset: Optional[str] = None  # the dataset open in this session
        self.meta: Optional[Dict[str, Any]] = None  # its DatasetInfo meta_json
        self.capabilities: Optional[Capabilities] = None
        self._broken = ''  # why the session ended, once it has
        self.token_id: Optional[str] = None  # the server's name for the token presented by Authenticate
        try:
            self._hello(client_name, min_version, max_version)
            if self.address.token is not None and self.address.scheme == 'tcp':
                self._authenticate(self.address.token)
        except BaseException:
            self._transport.close()
            raise

    def _hello(self, client_name: str, min_version: int, max_version: int) -> None:
        caps = self._call(MessageType.Hello, MessageType.Capabilities, min_version=min_version,
                          max_version=max_version, client=client_name)
        if not min_version <= caps['version'] <= max_version:
            raise ProtocolError(ErrorCode.UnsupportedVersion,
                                f'the server chose version {caps["version"]}, not one of {min_version}..{max_version}')
        self.version = caps['version']
        self._max_body = max(self._max_body, caps['max_message_bytes'])
        self.capabilities = Capabilities(**caps)

    def _authenticate(self, token: str) -> None:
        if self.version < 5:
            raise ProtocolError(ErrorCode.UnsupportedVersion,
                                f'the server speaks protocol version {self.version}, which takes no token over TCP: '
                                'connect to its HTTP port ("ws://HOST:HTTP_PORT"), where the token opens the WebSocket')
        self.token_id = self._call(MessageType.Authenticate, MessageType.Authenticated, token=token)['token_id']

    # Requests.

    def list_datasets(self) -> List[str]:
        """The names of the datasets the server offers."""
        return self._call(MessageType.ListDatasets, MessageType.DatasetList)['names']

    def open_dataset(self, name: str) -> Dict[str, Any]:
        """Makes `name` the session's dataset; its metadata (meta_json). ServerError UnknownDataset if there is none."""
        info = self._call(MessageType.OpenDataset, MessageType.DatasetInfo, name=name)
        self.dataset, self.meta = info['name'], json.loads(info['meta_json'])
        return self.meta

    def stats(self) -> Dict[str, Any]:
        """The server's statistics (GetStats); its keys are informative and may change."""
        return json.loads(self._call(MessageType.GetStats, MessageType.Stats)['json'])

    def send_render(self, scene: Union[Dict[str, Any], str], encoding: Union[Encoding, str] = Encoding.png) -> int:
        """Sends a Render of `scene` (a dict or JSON text) for the open dataset; its request id. Replies are read with
        frames(). ValueError for an encoding the session's version lacks."""
        encoding = encoding_of(encoding)
        if ENCODING_SINCE.get(encoding, 1) > self.version:
            raise ValueError(f'{encoding.name} needs protocol version {ENCODING_SINCE[encoding]}; this session '
                             f'speaks version {self.version}')
        text = scene if isinstance(scene, str) else json.dumps(scene)
        return self._send(MessageType.Render, encoding=encoding, scene_json=text)

    def frames(self, request_id: int) -> Iterator[RawFrame]:
        """The Frames answering Render `request_id` as they arrive: provisional ones, then the exact one, which ends
        the iteration. An Error reply raises ServerError."""
        while True:
            frame = self._frame(request_id)
            yield frame
            if not frame.provisional:
                return

    def render(self, scene: Union[Dict[str, Any], str], encoding: Union[Encoding, str] = Encoding.png,
               on_provisional: Optional[Callable[[RawFrame], None]] = None) -> RawFrame:
        """The exact Frame of one Render; provisional Frames before it (progressive or interactive scenes) go to
        `on_provisional`, if given."""
        for frame in self.frames(self.send_render(scene, encoding)):
            if not frame.provisional:
                return frame
            if on_provisional:
                on_provisional(frame)
        raise AssertionError('unreachable: frames() ends with an exact frame')

    def upload(self, name: str, meta: Union[Dict[str, Any], str], size: int, data: Iterable[Any], *,
               progress: Optional[Callable[[int, int], None]] = None,
               timeout: Optional[float] = None) -> Dict[str, Any]:
        """Sends a volume that becomes the server's dataset `name` (Upload, protocol version 6; PROTOCOL.md, Session
        13) and returns its metadata (the DatasetInfo's meta_json); the session's open dataset does not change.

        `meta`: the voxels' description (a dict or JSON text: `dims`, `type`, `endian`, `spacing`, `origin`,
        `patient`), sent as it is; `size`: their bytes. `data`: the voxels in order (x fastest, then y, then z) as
        buffers of any size (bytes, memoryviews, C-contiguous arrays), each sent as UploadChunks of at most the
        server's `chunk_bytes`, one buffer held at a time. The server's last answer comes once it has prepped the
        store, within `timeout` seconds of the last chunk (default: the session's timeout). `progress(sent, size)` is
        called after each chunk handed to the connection, and once more when the server has answered (then `sent` is
        `size`); what it raises abandons the upload as an exception of `data` does.

        An Error answering the Upload or any chunk raises ServerError with the server's words (a chunk's Error stops
        the sending); nothing of the upload is then kept. `data` holding more or fewer than `size` bytes, or raising,
        abandons the upload (an empty chunk, which the server answers Malformed and deletes what it got) and raises:
        ValueError for the wrong size, else what `data` raised."""
        if self.version < 6:
            raise ProtocolError(ErrorCode.UnsupportedVersion,
                                f'this session speaks protocol version {self.version}; uploads need version 6')
        text = meta if isinstance(meta, str) else json.dumps(meta)
        ready = self._call(MessageType.Upload, MessageType.UploadReady, name=name, meta_json=text, bytes=size)
        assert self.capabilities is not None
        # A chunk's body is its u32 length and its bytes, within the server's body limit.
        limit = min(ready['chunk_bytes'], self.capabilities.max_message_bytes - 4)
        if limit < 1:
            self._cancel_upload(self._next_id)
            raise ProtocolError(ErrorCode.Malformed, f'UploadReady.chunk_bytes: {ready["chunk_bytes"]}, with a body '
                                                     f'limit of {self.capabilities.max_message_bytes}')
        # Each chunk is sent once the next is in hand, and the last once `data` has ended with `size` bytes: the one
        # that completes the upload (the server then preps it) goes only when the voxels are known to be right.
        first, taken, last = self._next_id, 0, None
        try:
            for buffer in data:
                view = memoryview(buffer).cast('B')
                for start in range(0, len(view), limit):
                    piece = view[start:start + limit]
                    taken += len(piece)
                    if taken > size:
                        raise ValueError(f'data: more than the {size} bytes the upload announced')
                    if last is not None:
                        self._send(MessageType.UploadChunk, data=last)
                        # An Error answering a chunk has ended the upload: stop sending.
                        self._await(range(first, self._next_id), (), wait=False)
                        if progress is not None:
                            progress(taken - len(piece), size)
                    last = piece
                if last is not None:
                    last = bytes(last)  # a copy of at most a chunk, not the whole buffer held while the next is read
                del buffer, view
            if taken != size or last is None:
                raise ValueError(f'data: {taken} bytes, the upload announced {size}')
        except ServerError:
            raise
        except BaseException:
            self._cancel_upload(first)
            raise
        self._send(MessageType.UploadChunk, data=last)
        # The answer comes once the server has prepped the store: a large volume may take it longer than a frame.
        if timeout is not None:
            self._transport.sock.settimeout(timeout)
        try:
            info = self._await(range(first, self._next_id), (MessageType.DatasetInfo,), timeout=timeout)[1]
        finally:
            if timeout is not None and not self._broken:
                self._transport.sock.settimeout(self._timeout)
        if progress is not None:
            progress(size, size)
        return json.loads(info['meta_json'])

    def _cancel_upload(self, first: int) -> None:
        """Abandons the upload whose chunks have ids from `first` on: an empty chunk, answered Malformed (the server
        deletes what it got). Without a session left to ask, its end abandons the upload."""
        if self._broken:
            return
        try:
            self._send(MessageType.UploadChunk, data=b'')
            self._await(range(first, self._next_id), ())
        except ServerError:
            pass  # the answer expected (or an earlier chunk's Error)
        except (OSError, ProtocolError):
            self._end('an upload could not be abandoned')

    def frame_received(self, frame: RawFrame) -> None:
        """Reports a Frame as arrived (FrameReceived, version 4): the server then paces its frames by the reports.
        A client sends one for every Frame, in order, or none at all."""
        if self.version >= 4 and not self._broken:
            self._transport.send(encode(MessageType.FrameReceived, frame.request_id, self.version,
                                        frame_bytes=frame.message_bytes))

    def close(self) -> None:
        """Says Goodbye and closes the connection (also when the server has gone already)."""
        if not self._broken:
            try:
                self._transport.send(encode(MessageType.Goodbye, self._new_id(), self.version))
            except OSError:
                pass
            self._broken = 'closed by this client'
        self._transport.close()

    def __enter__(self) -> 'Session':
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # Messages.

    def _new_id(self) -> int:
        self._next_id += 1
        return self._next_id - 1

    def _send(self, message_type: MessageType, **fields: Any) -> int:
        if self._broken:
            raise ConnectionClosed(f'the session ended: {self._broken}')
        request_id = self._new_id()
        try:
            self._transport.send(encode(message_type, request_id, self.version, **fields))
        except OSError as e:
            raise self._end(f'the connection failed: {e}') from e
        return request_id

    def _end(self, why: str) -> ConnectionClosed:
        # A stream cut part way through a message cannot be read on: every later call says why it ended.
        self._broken = why
        self._transport.close()
        return ConnectionClosed(why)

    def _call(self, message_type: MessageType, reply_type: MessageType, **fields: Any) -> Dict[str, Any]:
        return self._await(self._send(message_type, **fields), (reply_type,))[1]

    def _frame(self, request_id: int) -> RawFrame:
        header, frame = self._await(request_id, (MessageType.Frame,))
        return RawFrame(request_id, frame['width'], frame['height'], frame['encoding'],
                        json.loads(frame['stats_json']), frame['payload'], HEADER_BYTES + header.body_bytes)

    def _await(self, request_ids: Union[int, range], reply_types: tuple, wait: bool = True,
               timeout: Optional[float] = None) -> Optional[tuple]:
        """(header, fields) of the reply of type `reply_types` answering the last of `request_ids` (one id, or a range
        of ids: an upload's chunks). An Error answering any of them, or about the connection (id 0), raises
        ServerError; replies to other requests are skipped. `wait=False`: only what has arrived already is read, and
        None is returned when that holds no such reply."""
        ids = range(request_ids, request_ids + 1) if isinstance(request_ids, int) else request_ids
        while wait or self._transport.readable():
            try:
                header, body = self._transport.receive(self._max_body)
            except ConnectionClosed as e:
                raise self._end(str(e)) from None
            except socket.timeout:
                raise self._end(f'no reply within {timeout or self._timeout:g} s') from None
            except OSError as e:
                raise self._end(f'the connection failed: {e}') from e
            except ProtocolError as e:
                if e.code in (ErrorCode.BadMagic, ErrorCode.UnsupportedVersion, ErrorCode.TooLarge):
                    self._end(f'a reply that does not decode: {e}')  # the header is wrong: nothing after it reads
                raise
            if header.type is None or (header.request_id not in ids and header.request_id != 0):
                continue  # a type this client does not know, or an answer to an earlier request (superseded)
            reply = decode_body(header.type, body, header.version)
            if header.type == MessageType.Error:
                error = ServerError(reply['code'], reply['message'], header.request_id)
                # Forbidden closes the session (a token the server does not have), but not when it answers an Upload.
                if ((header.request_id == 0 and error.code in _CLOSING) or
                        (error.code == ErrorCode.Forbidden and MessageType.UploadReady not in reply_types)):
                    self._end(f'the server closed the session: {error}')
                raise error
            if header.type == MessageType.Goodbye:
                raise self._end('the server ended the session (Goodbye)')
            if header.type in reply_types and header.request_id == ids[-1]:
                return header, reply
        return None
