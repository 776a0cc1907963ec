"""The exceptions the package raises: what the server refused, what did not decode, what could not connect."""
from __future__ import annotations

import enum
import re
from typing import Optional


class ErrorCode(enum.IntEnum):
    """The protocol's error codes (proto/PROTOCOL.md, section 8)."""

    BadMagic = 1
    UnsupportedVersion = 2
    UnknownType = 3
    TooLarge = 4
    Malformed = 5
    UnexpectedMessage = 6
    UnknownDataset = 7
    InvalidScene = 8
    LimitExceeded = 9
    Superseded = 10
    Internal = 11
    ShuttingDown = 12
    Timeout = 13
    Busy = 14
    Forbidden = 15
    AlreadyExists = 16


#: The protocol version each error code appeared in (the others: version 1).
ERROR_CODE_SINCE = {ErrorCode.Busy: 3, ErrorCode.Forbidden: 5, ErrorCode.AlreadyExists: 6}


class VoxbrickError(Exception):
    """Every error this package raises on purpose."""


class ProtocolError(VoxbrickError):
    """A protocol error: an Error reply of the server (ServerError), or bytes this client could not decode.

    `code` is the ErrorCode, `message` the words of whoever found the problem; str() gives "Code: message".
    """

    def __init__(self, code: ErrorCode, message: str):
        super().__init__(f'{code.name}: {message}')
        self.code = code
        self.message = message


class ServerError(ProtocolError):
    """The server answered a request with an Error message; `message` is the server's own text, `request_id` the id
    of the request it answers (0: about the connection, not one request)."""

    def __init__(self, code: ErrorCode, message: str, request_id: int = 0):
        super().__init__(code, message)
        self.request_id = request_id

    @property
    def retry_after_ms(self) -> Optional[int]:
        """For Busy (and LimitExceeded carrying Busy's text to an older session): the milliseconds the server asks
        the client to wait before asking again, from the message's "; retry after N ms"; None when it names none."""
        m = re.search(r'retry after (\d+) ms', self.message)
        return int(m.group(1)) if m else None


class ConnectionRefused(VoxbrickError):
    """The server refused the connection before any session began: an HTTP status for a WebSocket upgrade (a wrong
    or missing token: 403) with the server's words in `reason`."""

    def __init__(self, status: int, reason: str):
        super().__init__(f'HTTP {status}: {reason}' if reason else f'HTTP {status}')
        self.status = status
        self.reason = reason


class TlsError(VoxbrickError, ConnectionError):
    """The TLS handshake with the server failed: its certificate did not verify (not signed by a CA this client trusts,
    or not naming the host connected to), or the server does not speak TLS on that port. `reason` is OpenSSL's."""

    def __init__(self, message: str, reason: str = ''):
        super().__init__(message)
        self.reason = reason


class ConnectionClosed(VoxbrickError, ConnectionError):
    """The connection ended while a reply was awaited."""


class DecodeError(VoxbrickError, ValueError):
    """A frame's payload does not decode as its encoding says (or needs a module that is not installed)."""
