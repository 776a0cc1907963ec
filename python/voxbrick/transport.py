"""The streams a session runs over: TCP, and a WebSocket on the server's HTTP port (PROTOCOL.md, section 11), each in
the clear or inside TLS (section 12). Each moves whole protocol messages; the standard library only.
"""
from __future__ import annotations

import base64
import hashlib
import os
import select
import socket
import ssl
import struct
import urllib.parse
from typing import Any, NamedTuple, Optional, Tuple

from .errors import ConnectionClosed, ConnectionRefused, TlsError
from .protocol import HEADER_BYTES, MAX_BODY_BYTES, decode_header

_WS_GUID = b'258EAFA5-E914-47DA-95CA-C5AB0DC85B11'
_MASK_PIECE = 64 << 10  # bytes of a client frame's payload masked at once
_TOKEN_CHARACTERS = set('abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-._~')
#: Each scheme an address may have: (transport, inside TLS).
_SCHEMES = {'tcp': ('tcp', False), 'tls': ('tcp', True), 'ws': ('ws', False), 'http': ('ws', False),
            'wss': ('ws', True), 'https': ('ws', True)}


class Address(NamedTuple):
    """Where a server is: scheme 'tcp' (its TCP port) or 'ws' (a WebSocket on its HTTP port), `tls` when inside TLS,
    and the access token the session presents (in the WebSocket's upgrade, or by Authenticate over TCP)."""

    scheme: str
    host: str
    port: int
    token: Optional[str]
    tls: bool = False


def parse_address(address: str, token: Optional[str] = None) -> Address:
    """An Address from "HOST:PORT" (TCP), "tcp://HOST:PORT", "tls://HOST:PORT" (TCP inside TLS),
    "ws[s]://HOST:PORT[/ws][?token=T]" or the viewer's "http[s]://HOST:PORT/[?token=T]" (a WebSocket on that port).
    ValueError naming what is wrong."""
    if not isinstance(address, str) or not address.strip():
        raise ValueError(f'address {address!r}: expected "HOST:PORT", "tls://HOST:PORT" or "ws[s]://HOST:PORT"')
    text = address.strip()
    scheme, tls = 'tcp', False
    if '://' in text:
        parsed = urllib.parse.urlsplit(text)
        if parsed.scheme.lower() not in _SCHEMES:
            raise ValueError(f'address {address!r}: scheme {parsed.scheme!r} is not one of {", ".join(_SCHEMES)}')
        scheme, tls = _SCHEMES[parsed.scheme.lower()]
        query = urllib.parse.parse_qs(parsed.query)
        if 'token' in query:
            if token is not None and token != query['token'][0]:
                raise ValueError(f'address {address!r}: its token and token= differ')
            token = query['token'][0]
        try:
            host, port = parsed.hostname, parsed.port
        except ValueError:
            host, port = parsed.hostname, None
        if parsed.path not in ('', '/', '/ws', '/index.html'):
            raise ValueError(f'address {address!r}: path {parsed.path!r}; the protocol is on /ws')
    else:
        host, _, port_text = text.rpartition(':')
        host = host.strip('[]')
        try:
            port = int(port_text)
        except ValueError:
            port = None
    if not host or port is None or not 0 < port < 65536:
        raise ValueError(f'address {address!r}: expected "HOST:PORT" with a port in 1..65535')
    if token is not None and (not token or not set(token) <= _TOKEN_CHARACTERS):
        raise ValueError('token: letters, digits and - . _ ~ only, at least one')
    return Address(scheme, host, port, token, tls)


def tls_context(ca: Optional[str] = None, insecure: bool = False) -> ssl.SSLContext:
    """The client side of PROTOCOL.md's TLS: 1.2 or later, the server's certificate verified against `ca` (a PEM file
    of CAs) or the system's CAs, and its name checked against the host connected to. `insecure` takes any certificate
    (a self-signed one in local use: the link is encrypted, but not the server's identity)."""
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    context.minimum_version = ssl.TLSVersion.TLSv1_2
    if insecure:
        context.check_hostname = False
        context.verify_mode = ssl.CERT_NONE
    elif ca is not None:
        try:
            context.load_verify_locations(cafile=os.fspath(ca))
        except (OSError, ssl.SSLError) as e:
            raise ValueError(f'ca {ca!r}: not a readable PEM file of CA certificates ({e})') from None
    else:
        context.load_default_certs()
    return context


def _connect(host: str, port: int, timeout: float, tls: Optional[ssl.SSLContext]) -> socket.socket:
    """A TCP connection to host:port, its TLS handshake done when `tls` is given; TlsError saying why one fails."""
    sock = socket.create_connection((host, port), timeout=timeout)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    if tls is None:
        return sock
    where = f'[{host}]:{port}' if ':' in host else f'{host}:{port}'
    try:
        return tls.wrap_socket(sock, server_hostname=host)
    except ssl.SSLCertVerificationError as e:
        sock.close()
        raise TlsError(f'the certificate of the server at {where} did not verify: {e.verify_message} (give ca= the '
                       'CA that signed it; insecure=True takes a self-signed one in local use)', str(e)) from None
    except ssl.SSLError as e:
        sock.close()
        hint = (' (does the server speak TLS there? `voxbrick serve --tls-cert`)'
                if 'WRONG_VERSION_NUMBER' in str(e) or 'record layer' in str(e) else '')
        raise TlsError(f'the TLS handshake with the server at {where} failed: {e.reason or e}{hint}', str(e)) from None
    except BaseException:
        sock.close()
        raise


class TcpTransport:
    """One protocol connection over TCP."""

    def __init__(self, host: str, port: int, timeout: float, tls: Optional[ssl.SSLContext] = None):
        self.sock = _connect(host, port, timeout, tls)

    def send(self, message: bytes) -> None:
        """Writes one whole message."""
        self.sock.sendall(message)

    def receive(self, max_body: int = MAX_BODY_BYTES) -> Tuple[object, bytes]:
        """(Header, body) of the next message; ConnectionClosed when the server closed, ProtocolError for a header
        that does not check."""
        header = decode_header(_read(self.sock, HEADER_BYTES), max_body)
        return header, _read(self.sock, header.body_bytes)

    def readable(self) -> bool:
        """True when the server has sent something not read yet (or closed): receive() finds it without waiting
        for the server, which writes each message whole."""
        return _readable(self.sock)

    def close(self) -> None:
        self.sock.close()


class WebSocketTransport:
    """One protocol connection over a WebSocket (RFC 6455) on the server's HTTP port: each binary WebSocket message
    carries one protocol message. No Origin header is sent (a script, not a page)."""

    def __init__(self, host: str, port: int, token: Optional[str], timeout: float,
                 tls: Optional[ssl.SSLContext] = None):
        self.sock = _connect(host, port, timeout, tls)
        self._buffer = b''
        try:
            self._handshake(host, port, token)
        except BaseException:
            self.sock.close()
            raise

    def _handshake(self, host: str, port: int, token: Optional[str]) -> None:
        key = base64.b64encode(os.urandom(16)).decode('ascii')
        path = '/ws' + (f'?token={urllib.parse.quote(token, safe="")}' if token is not None else '')
        host_header = f'[{host}]:{port}' if ':' in host else f'{host}:{port}'
        request = (f'GET {path} HTTP/1.1\r\nHost: {host_header}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n'
                   f'Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n')
        self.sock.sendall(request.encode('ascii'))
        head = b''
        while b'\r\n\r\n' not in head:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise ConnectionClosed(f'the server at {host_header} closed the connection during the WebSocket '
                                       'upgrade')
            head += chunk
            if len(head) > 65536:
                raise ConnectionRefused(0, 'the answer to the WebSocket upgrade has no end of headers')
        head, _, rest = head.partition(b'\r\n\r\n')
        lines = head.decode('latin-1').split('\r\n')
        parts = lines[0].split(' ', 2)
        status = int(parts[1]) if len(parts) > 1 and parts[1].isdigit() else 0
        headers = {}
        for line in lines[1:]:
            name, _, value = line.partition(':')
            headers[name.strip().lower()] = value.strip()
        if status != 101:
            # The server says why in the body (a refused token, origin or a full server): read what it sent.
            length = int(headers.get('content-length', '0') or 0)
            while len(rest) < min(length, 4096):
                chunk = self.sock.recv(4096)
                if not chunk:
                    break
                rest += chunk
            reason = rest[:length or 4096].decode('utf-8', 'replace').strip()
            raise ConnectionRefused(status, reason or (parts[2] if len(parts) > 2 else ''))
        expected = base64.b64encode(hashlib.sha1(key.encode('ascii') + _WS_GUID).digest()).decode('ascii')
        if headers.get('sec-websocket-accept') != expected:
            raise ConnectionRefused(status, 'the server\'s Sec-WebSocket-Accept does not match the key sent')
        self._buffer = rest

    def send(self, message: bytes) -> None:
        """Writes one whole message as one masked binary WebSocket frame."""
        self._send_frame(0x2, message)

    def _send_frame(self, opcode: int, payload: bytes) -> None:
        size = len(payload)
        if size < 126:
            head = struct.pack('!BB', 0x80 | opcode, 0x80 | size)
        elif size < 1 << 16:
            head = struct.pack('!BBH', 0x80 | opcode, 0x80 | 126, size)
        else:
            head = struct.pack('!BBQ', 0x80 | opcode, 0x80 | 127, size)
        mask = os.urandom(4)
        if size <= _MASK_PIECE:
            self.sock.sendall(head + mask + _masked(payload, mask))
            return
        # A large payload (an upload's chunk) masked and sent a piece at a time: a few copies of a piece held, not of
        # the whole payload. Pieces are whole multiples of the mask's 4 bytes.
        self.sock.sendall(head + mask)
        view = memoryview(payload)
        for start in range(0, size, _MASK_PIECE):
            self.sock.sendall(_masked(view[start:start + _MASK_PIECE], mask))

    def receive(self, max_body: int = MAX_BODY_BYTES) -> Tuple[object, bytes]:
        """(Header, body) of the next WebSocket message, which must be exactly one protocol message."""
        data = self._next_message(HEADER_BYTES + max_body)
        header = decode_header(data[:HEADER_BYTES], max_body)
        if len(data) != HEADER_BYTES + header.body_bytes:
            raise ConnectionClosed(f'a WebSocket message of {len(data)} bytes carries a protocol message of '
                                   f'{HEADER_BYTES + header.body_bytes}')
        return header, data[HEADER_BYTES:]

    def readable(self) -> bool:
        """True when the server has sent something not read yet (or closed), as TcpTransport.readable."""
        return bool(self._buffer) or _readable(self.sock)

    def _next_message(self, limit: int) -> bytes:
        message = bytearray()
        while True:
            first, second = self._take(2)
            fin, opcode = first & 0x80, first & 0x0F
            size = second & 0x7F
            if size == 126:
                size = struct.unpack('!H', self._take(2))[0]
            elif size == 127:
                size = struct.unpack('!Q', self._take(8))[0]
            mask = self._take(4) if second & 0x80 else None
            if opcode < 0x8 and len(message) + size > limit:
                raise ConnectionClosed(f'a WebSocket message above {limit} bytes')
            payload = self._take(size)
            if mask:
                payload = _masked(payload, mask)
            if opcode == 0x8:  # close: the server ends the session (its last reply came before it)
                code = struct.unpack('!H', payload[:2])[0] if len(payload) >= 2 else 1005
                try:
                    self._send_frame(0x8, payload[:2])
                except OSError:
                    pass
                raise ConnectionClosed(f'the server closed the WebSocket (code {code}'
                                       f'{": " + payload[2:].decode("utf-8", "replace") if len(payload) > 2 else ""})')
            if opcode == 0x9:
                self._send_frame(0xA, payload)
                continue
            if opcode == 0xA:
                continue
            message += payload
            if fin:
                return bytes(message)

    def _take(self, size: int) -> bytes:
        if len(self._buffer) < size:
            parts, have = [self._buffer], len(self._buffer)
            while have < size:
                chunk = self.sock.recv(max(size - have, 1 << 16))
                if not chunk:
                    raise ConnectionClosed('the server closed the connection')
                parts.append(chunk)
                have += len(chunk)
            self._buffer = b''.join(parts)
        data, self._buffer = self._buffer[:size], self._buffer[size:]
        return data

    def close(self) -> None:
        try:
            self._send_frame(0x8, struct.pack('!H', 1000))
        except OSError:
            pass
        self.sock.close()


def _masked(payload: bytes, mask: bytes) -> bytes:
    # With NumPy (there whenever the package makes arrays; the command-line client runs without it), XOR as 32-bit
    # words: about 0.3 ms a MiB. Else as one big integer: about 2 ms a MiB, no NumPy needed.
    if not payload:
        return b''
    numpy = _numpy()
    if numpy is not None and len(payload) >= 4096:
        words = len(payload) // 4
        out = bytearray(len(payload))
        numpy.bitwise_xor(numpy.frombuffer(payload, '<u4', words), numpy.frombuffer(mask, '<u4')[0],
                          out=numpy.frombuffer(out, '<u4', words))
        tail = len(payload) - 4 * words  # the mask's phase restarts at every multiple of 4
        if tail:
            out[4 * words:] = bytes(b ^ m for b, m in zip(bytes(payload[4 * words:]), mask))
        return bytes(out)
    repeated = (mask * (len(payload) // 4 + 1))[:len(payload)]
    return (int.from_bytes(payload, 'little') ^ int.from_bytes(repeated, 'little')).to_bytes(len(payload), 'little')


_NUMPY: list = []


def _numpy() -> Any:
    """NumPy if it can be imported (once), else None."""
    if not _NUMPY:
        try:
            import numpy
            _NUMPY.append(numpy)
        except ImportError:
            _NUMPY.append(None)
    return _NUMPY[0]


def _readable(sock: socket.socket) -> bool:
    # Inside TLS, bytes already decrypted wait in the SSL object, where select() does not see them.
    if isinstance(sock, ssl.SSLSocket) and sock.pending():
        return True
    return bool(select.select([sock], [], [], 0)[0])


def _read(sock: socket.socket, size: int) -> bytes:
    data = bytearray()
    while len(data) < size:
        chunk = sock.recv(min(size - len(data), 1 << 20))
        if not chunk:
            raise ConnectionClosed('the server closed the connection')
        data += chunk
    return bytes(data)


def open_transport(address: Address, timeout: float, ca: Optional[str] = None, insecure: bool = False):
    """A connected transport for `address` (parse_address's); over TLS when the address says so, verifying the
    server as tls_context(ca, insecure) does."""
    tls = tls_context(ca, insecure) if address.tls else None
    if address.scheme == 'ws':
        return WebSocketTransport(address.host, address.port, address.token, timeout, tls)
    return TcpTransport(address.host, address.port, timeout, tls)
