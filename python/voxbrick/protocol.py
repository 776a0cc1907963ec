"""The wire protocol's messages as bytes (proto/PROTOCOL.md): headers, bodies, enums and limits. No sockets here, so
every function can be tested on buffers; the standard library only.

A message is a dict of its fields, keyed by the names PROTOCOL.md gives them; enum fields hold their enum members
(Encoding, ErrorCode), strings str, payloads bytes.
"""
from __future__ import annotations

import enum
import struct
from typing import Any, Dict, NamedTuple, Optional

from .errors import ERROR_CODE_SINCE, ErrorCode, ProtocolError

MAGIC = 0x4B425856  # "VXBK" read as a little-endian u32
#: The protocol versions this package speaks: 2 adds jpeg, 3 the Busy error, 4 the video encodings and FrameReceived,
#: 5 Authenticate, Authenticated and the Forbidden error (a TCP session's access token), 6 Upload, UploadReady,
#: UploadChunk (a volume sent as a new dataset), the u64 field type and the AlreadyExists error, 7 webp, 8 provisional
#: frames at the size they were drawn (the client scales them to the scene's: client.Client), 9 the scene key
#: accepts_vp9_444 (4:4:4 VP9 streams; this client decodes no video, so it never asks for them).
MIN_VERSION, MAX_VERSION = 1, 9
HEADER = struct.Struct('<IHHII')  # magic, version, type, request id, body bytes
HEADER_BYTES = HEADER.size

#: The protocol's default limits (PROTOCOL.md, section 3); a server may lower them and reports its body limit.
MAX_BODY_BYTES = 64 << 20
MAX_STRING_BYTES = 1 << 20
MAX_LIST_COUNT = 4096


class MessageType(enum.IntEnum):
    """Message types (PROTOCOL.md, section 4)."""

    Hello = 1
    Capabilities = 2
    ListDatasets = 3
    DatasetList = 4
    OpenDataset = 5
    DatasetInfo = 6
    Render = 7
    Frame = 8
    Error = 9
    GetStats = 10
    Stats = 11
    Goodbye = 12
    FrameReceived = 13
    Authenticate = 14
    Authenticated = 15
    Upload = 16
    UploadReady = 17
    UploadChunk = 18


class Encoding(enum.IntEnum):
    """Frame encodings (PROTOCOL.md, Frame)."""

    raw_rgba8 = 0
    png = 1
    zstd_rgba8 = 2
    jpeg = 3
    vp8 = 4
    vp9 = 5
    webp = 6


#: The protocol version each encoding appeared in (the others: version 1).
ENCODING_SINCE = {Encoding.jpeg: 2, Encoding.vp8: 4, Encoding.vp9: 4, Encoding.webp: 7}
#: The version each message appeared in (the others: version 1).
MESSAGE_SINCE = {MessageType.FrameReceived: 4, MessageType.Authenticate: 5, MessageType.Authenticated: 5,
                 MessageType.Upload: 6, MessageType.UploadReady: 6, MessageType.UploadChunk: 6}

#: The scene's short names of the encodings (its `provisional_encoding` key), beside the wire names.
ENCODING_NAMES = {'raw': Encoding.raw_rgba8, 'png': Encoding.png, 'zstd': Encoding.zstd_rgba8,
                  'jpeg': Encoding.jpeg, 'jpg': Encoding.jpeg, 'vp8': Encoding.vp8, 'vp9': Encoding.vp9,
                  **{e.name: e for e in Encoding}}


def encoding_of(value: Any) -> Encoding:
    """An Encoding from its member, value, wire name ('raw_rgba8') or short name ('raw', 'png', 'zstd', 'jpeg', 'webp');
    ValueError naming the choices otherwise."""
    if isinstance(value, Encoding):
        return value
    if isinstance(value, str) and value.lower() in ENCODING_NAMES:
        return ENCODING_NAMES[value.lower()]
    if isinstance(value, int) and not isinstance(value, bool) and value in Encoding._value2member_map_:
        return Encoding(value)
    raise ValueError(f'encoding {value!r}: expected one of raw, png, zstd, jpeg, webp (or raw_rgba8, zstd_rgba8)')


_U16 = struct.Struct('<H')
_U32 = struct.Struct('<I')
_U64 = struct.Struct('<Q')
_U8 = struct.Struct('<B')
_INTS = {'u16': _U16, 'u32': _U32, 'u64': _U64, 'encoding': _U8, 'code': _U16}
_ENUMS = {'encoding': Encoding, 'code': ErrorCode}
_SINCE = {'encoding': ENCODING_SINCE, 'code': ERROR_CODE_SINCE}

#: Each body's fields in wire order. str: u32 length + UTF-8; bytes: u32 length + bytes; "X list": u32 count + items.
FIELDS: Dict[MessageType, list] = {
    MessageType.Hello: [('min_version', 'u16'), ('max_version', 'u16'), ('client', 'str')],
    MessageType.Capabilities: [('version', 'u16'), ('server', 'str'), ('max_message_bytes', 'u32'),
                               ('max_image_side', 'u32'), ('max_queued_per_session', 'u32'),
                               ('encodings', 'encoding list')],
    MessageType.ListDatasets: [],
    MessageType.DatasetList: [('names', 'str list')],
    MessageType.OpenDataset: [('name', 'str')],
    MessageType.DatasetInfo: [('name', 'str'), ('meta_json', 'str')],
    MessageType.Render: [('encoding', 'encoding'), ('scene_json', 'str')],
    MessageType.Frame: [('width', 'u32'), ('height', 'u32'), ('encoding', 'encoding'), ('stats_json', 'str'),
                        ('payload', 'bytes')],
    MessageType.Error: [('code', 'code'), ('message', 'str')],
    MessageType.GetStats: [],
    MessageType.Stats: [('json', 'str')],
    MessageType.Goodbye: [],
    MessageType.FrameReceived: [('frame_bytes', 'u32')],
    MessageType.Authenticate: [('token', 'str')],
    MessageType.Authenticated: [('token_id', 'str')],
    MessageType.Upload: [('name', 'str'), ('meta_json', 'str'), ('bytes', 'u64')],
    MessageType.UploadReady: [('chunk_bytes', 'u32')],
    MessageType.UploadChunk: [('data', 'bytes')],
}


class Header(NamedTuple):
    """A message header. `type` is None for a type this package does not know (its body is to be skipped)."""

    version: int
    type: Optional[MessageType]
    request_id: int
    body_bytes: int


def _known(kind: str, member: enum.IntEnum, version: int) -> bool:
    return _SINCE.get(kind, {}).get(member, 1) <= version


def _encode_value(kind: str, value: Any) -> bytes:
    if kind.endswith(' list'):
        return _U32.pack(len(value)) + b''.join(_encode_value(kind[:-5], item) for item in value)
    if kind in ('str', 'bytes'):
        data = value.encode('utf-8') if kind == 'str' else bytes(value)
        return _U32.pack(len(data)) + data
    if kind in _ENUMS:
        value = _ENUMS[kind](value) if not isinstance(value, str) else _ENUMS[kind][value]
    return _INTS[kind].pack(int(value))


def encode(message_type: MessageType, request_id: int, version: int = MIN_VERSION, /, **fields: Any) -> bytes:
    """A whole message (header and body) written in protocol `version`; ValueError for a field the version lacks."""
    message_type = MessageType(message_type)
    if MESSAGE_SINCE.get(message_type, 1) > version:
        raise ValueError(f'{message_type.name} needs protocol version {MESSAGE_SINCE[message_type]}')
    spec = FIELDS[message_type]
    for name, kind in spec:
        if kind in _ENUMS:
            member = fields[name]
            member = _ENUMS[kind][member] if isinstance(member, str) else _ENUMS[kind](member)
            if not _known(kind, member, version):
                raise ValueError(f'{message_type.name}.{name}: {member.name} needs protocol version '
                                 f'{_SINCE[kind][member]}')
    unknown = set(fields) - {name for name, _ in spec}
    if unknown:
        raise ValueError(f'{message_type.name} has no field {", ".join(sorted(unknown))}')
    parts = []
    for name, kind in spec:
        if kind == 'bytes':  # a payload (an upload's voxels) joined into the message as it is, not copied first
            view = memoryview(fields[name])
            data = view.cast('B') if view.c_contiguous else memoryview(view.tobytes())
            parts += [_U32.pack(len(data)), data]
        else:
            parts.append(_encode_value(kind, fields[name]))
    header = HEADER.pack(MAGIC, version, int(message_type), request_id, sum(len(p) for p in parts))
    return b''.join([header, *parts])


def decode_header(data: bytes, max_body: int = MAX_BODY_BYTES) -> Header:
    """The header of a message's first 16 bytes; ProtocolError (BadMagic, UnsupportedVersion, TooLarge) when it does
    not check."""
    if len(data) != HEADER_BYTES:
        raise ProtocolError(ErrorCode.Malformed, f'header: {len(data)} bytes, expected {HEADER_BYTES}')
    magic, version, type_value, request_id, size = HEADER.unpack(data)
    if magic != MAGIC:
        raise ProtocolError(ErrorCode.BadMagic, f'magic 0x{magic:08X}')
    if not MIN_VERSION <= version <= MAX_VERSION:
        raise ProtocolError(ErrorCode.UnsupportedVersion, f'version {version}')
    if size > max_body:
        raise ProtocolError(ErrorCode.TooLarge, f'body of {size} bytes exceeds {max_body}')
    message_type = MessageType(type_value) if type_value in MessageType._value2member_map_ else None
    if message_type is not None and MESSAGE_SINCE.get(message_type, 1) > version:
        message_type = None
    return Header(version, message_type, request_id, size)


def decode_body(message_type: MessageType, body: bytes, version: int = MAX_VERSION) -> Dict[str, Any]:
    """The fields of a body as a dict. ProtocolError (Malformed, naming the field) when a field runs past the end,
    bytes are left over, an enum value is unknown in `version`, a string is not UTF-8, or a length or count is over
    its limit."""
    message_type = MessageType(message_type)
    offset = 0
    where = message_type.name

    def take(size: int, field: str) -> bytes:
        nonlocal offset
        if size > len(body) - offset:
            raise ProtocolError(ErrorCode.Malformed, f'{where}.{field}: truncated')
        offset += size
        return body[offset - size:offset]

    def value(kind: str, field: str) -> Any:
        if kind.endswith(' list'):
            count = value('u32', field)
            if count > MAX_LIST_COUNT:
                raise ProtocolError(ErrorCode.Malformed, f'{where}.{field}: count {count} exceeds limit '
                                                         f'{MAX_LIST_COUNT}')
            return [value(kind[:-5], field) for _ in range(count)]
        if kind == 'bytes':
            return take(value('u32', field), field)
        if kind == 'str':
            size = value('u32', field)
            if size > MAX_STRING_BYTES:
                raise ProtocolError(ErrorCode.Malformed, f'{where}.{field}: length {size} exceeds limit '
                                                         f'{MAX_STRING_BYTES}')
            try:
                return take(size, field).decode('utf-8')
            except UnicodeDecodeError as e:
                raise ProtocolError(ErrorCode.Malformed, f'{where}.{field}: not valid UTF-8 ({e.reason})') from None
        number = _INTS[kind].unpack(take(_INTS[kind].size, field))[0]
        if kind in _ENUMS:
            enum_type = _ENUMS[kind]
            if number not in enum_type._value2member_map_ or not _known(kind, enum_type(number), version):
                raise ProtocolError(ErrorCode.Malformed,
                                    f'{where}.{field}: unknown value {number} in protocol version {version}')
            return enum_type(number)
        return number

    message = {name: value(kind, name) for name, kind in FIELDS[message_type]}
    if offset != len(body):
        raise ProtocolError(ErrorCode.Malformed, f'{where}: {len(body) - offset} trailing byte(s)')
    return message


def decode(data: bytes, max_body: int = MAX_BODY_BYTES) -> tuple:
    """(Header, fields) of one whole message; ProtocolError when it is not exactly one message of a known type."""
    header = decode_header(data[:HEADER_BYTES], max_body)
    if header.type is None:
        raise ProtocolError(ErrorCode.UnknownType, f'message type {HEADER.unpack(data[:HEADER_BYTES])[2]} '
                                                   f'in protocol version {header.version}')
    if len(data) - HEADER_BYTES != header.body_bytes:
        raise ProtocolError(ErrorCode.Malformed, f'{header.type.name}: body of {len(data) - HEADER_BYTES} bytes, '
                                                 f'the header announces {header.body_bytes}')
    return header, decode_body(header.type, data[HEADER_BYTES:], header.version)
