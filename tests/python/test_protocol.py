"""The package's wire codec and image decoders on buffers, no server: PROTOCOL.md's example bytes, round trips,
every refusal naming its field, and PNG decoding against Pillow."""
from __future__ import annotations

import io
import struct
import zlib

import numpy as np
import pytest
from PIL import Image

import voxbrick
from voxbrick.errors import ErrorCode, ProtocolError
from voxbrick.images import decode_frame, decode_png, encode_png
from voxbrick.protocol import (HEADER, MAGIC, Encoding, MessageType, decode, decode_body, decode_header, encode,
                               encoding_of)
from voxbrick.transport import parse_address


def test_the_hello_of_the_protocol_document():
    # PROTOCOL.md, section 10: Hello 1..1, client "example", request id 1: 31 bytes.
    wire = encode(MessageType.Hello, 1, 1, min_version=1, max_version=1, client='example')
    assert wire == bytes.fromhex('5658424B 0100 0100 01000000 0F000000 0100 0100 07000000 6578616D706C65')
    header, fields = decode(wire)
    assert header == (1, MessageType.Hello, 1, 15)
    assert fields == {'min_version': 1, 'max_version': 1, 'client': 'example'}


def test_every_message_round_trips():
    messages = {
        MessageType.Capabilities: dict(version=4, server='voxbrick ü', max_message_bytes=1 << 20,
                                       max_image_side=4096, max_queued_per_session=2,
                                       encodings=[Encoding.png, Encoding.vp9]),
        MessageType.ListDatasets: {},
        MessageType.DatasetList: dict(names=['mri.vbs', 'sparse', '体']),
        MessageType.OpenDataset: dict(name='mri.vbs'),
        MessageType.DatasetInfo: dict(name='mri.vbs', meta_json='{"dims": [1, 2, 3]}'),
        MessageType.Render: dict(encoding=Encoding.jpeg, scene_json='{}'),
        MessageType.Frame: dict(width=3, height=2, encoding=Encoding.zstd_rgba8, stats_json='{"a": 1}',
                                payload=bytes(range(256))),
        MessageType.Error: dict(code=ErrorCode.Busy, message='full; retry after 250 ms'),
        MessageType.GetStats: {},
        MessageType.Stats: dict(json='{}'),
        MessageType.Goodbye: {},
        MessageType.FrameReceived: dict(frame_bytes=12345),
        MessageType.Authenticate: dict(token='radiology-Secret_1'),
        MessageType.Authenticated: dict(token_id='radiology'),
        MessageType.Upload: dict(name='up-1', meta_json='{"dims": [4, 5, 6], "type": "uint16"}', bytes=(1 << 40) + 3),
        MessageType.UploadReady: dict(chunk_bytes=1 << 20),
        MessageType.UploadChunk: dict(data=bytes(range(256)) * 3),
    }
    assert set(messages) | {MessageType.Hello} == set(MessageType)
    for kind, fields in messages.items():
        wire = encode(kind, 77, 6, **fields)
        assert encode(kind, 77, 6, **fields) == wire  # twice, the same bytes
        header, decoded = decode(wire)
        assert (header.type, header.request_id, header.version) == (kind, 77, 6)
        assert decoded == fields, kind


def test_the_upload_messages_bytes():
    # Upload: name, meta_json (strings), then bytes as a u64, little-endian; the largest u64 round trips.
    wire = encode(MessageType.Upload, 3, 6, name='ab', meta_json='{}', bytes=0x0102030405060708)
    assert wire == (HEADER.pack(MAGIC, 6, 16, 3, 20) + struct.pack('<I', 2) + b'ab' + struct.pack('<I', 2) + b'{}' +
                    bytes.fromhex('0807060504030201'))
    assert decode(encode(MessageType.Upload, 3, 6, name='', meta_json='', bytes=(1 << 64) - 1))[1]['bytes'] == (
        (1 << 64) - 1)
    assert encode(MessageType.UploadReady, 4, 6, chunk_bytes=65536) == HEADER.pack(MAGIC, 6, 17, 4, 4) + bytes(
        [0, 0, 1, 0])
    # A chunk takes any buffer: bytes, a memoryview (a slice of one), a NumPy array's bytes.
    voxels = np.arange(6, dtype='<u2')
    chunk = encode(MessageType.UploadChunk, 5, 6, data=memoryview(voxels).cast('B')[2:10])
    assert chunk == HEADER.pack(MAGIC, 6, 18, 5, 12) + struct.pack('<I', 8) + voxels.tobytes()[2:10]
    assert decode(chunk)[1] == {'data': voxels.tobytes()[2:10]}
    # Cut short: the u64 names its field.
    with pytest.raises(ProtocolError, match='Upload.bytes: truncated'):
        decode_body(MessageType.Upload, wire[HEADER.size:-1])
    with pytest.raises(ProtocolError, match='UploadChunk.data: truncated'):
        decode_body(MessageType.UploadChunk, struct.pack('<I', 9) + b'\0' * 8)
    with pytest.raises(ProtocolError, match='UploadReady: 1 trailing byte'):
        decode_body(MessageType.UploadReady, b'\0' * 5)


def test_what_a_version_lacks_is_refused_both_ways():
    with pytest.raises(ValueError, match='jpeg needs protocol version 2'):
        encode(MessageType.Render, 1, 1, encoding=Encoding.jpeg, scene_json='{}')
    with pytest.raises(ValueError, match='FrameReceived needs protocol version 4'):
        encode(MessageType.FrameReceived, 1, 3, frame_bytes=1)
    with pytest.raises(ValueError, match='Authenticate needs protocol version 5'):
        encode(MessageType.Authenticate, 1, 4, token='t')
    with pytest.raises(ValueError, match='Error.code: Forbidden needs protocol version 5'):
        encode(MessageType.Error, 1, 4, code=ErrorCode.Forbidden, message='')
    for kind, fields in [(MessageType.Upload, dict(name='a', meta_json='{}', bytes=1)),
                         (MessageType.UploadReady, dict(chunk_bytes=1)), (MessageType.UploadChunk, dict(data=b'1'))]:
        with pytest.raises(ValueError, match=f'{kind.name} needs protocol version 6'):
            encode(kind, 1, 5, **fields)
    with pytest.raises(ValueError, match='Error.code: AlreadyExists needs protocol version 6'):
        encode(MessageType.Error, 1, 5, code=ErrorCode.AlreadyExists, message='')
    exists = encode(MessageType.Error, 5, 6, code=ErrorCode.AlreadyExists, message='up-1 exists')
    assert decode(exists)[1] == {'code': ErrorCode.AlreadyExists, 'message': 'up-1 exists'}
    with pytest.raises(ProtocolError, match='Error.code: unknown value 16 in protocol version 5'):
        decode(exists[:4] + struct.pack('<H', 5) + exists[6:])
    # The Authenticate message's bytes: header (version 5, type 14, id 2, body 8), then the token as u32 + UTF-8.
    assert encode(MessageType.Authenticate, 2, 5, token='abcd') == (HEADER.pack(MAGIC, 5, 14, 2, 8) +
                                                                    struct.pack('<I', 4) + b'abcd')
    frame = encode(MessageType.Frame, 5, 4, width=1, height=1, encoding=Encoding.vp8, stats_json='{}', payload=b'')
    with pytest.raises(ProtocolError, match='Frame.encoding: unknown value 4 in protocol version 3'):
        decode(frame[:4] + struct.pack('<H', 3) + frame[6:])
    webp = encode(MessageType.Frame, 5, 7, width=1, height=1, encoding=Encoding.webp, stats_json='{}', payload=b'')
    assert decode(webp)[1]['encoding'] is Encoding.webp
    with pytest.raises(ProtocolError, match='Frame.encoding: unknown value 6 in protocol version 6'):
        decode(webp[:4] + struct.pack('<H', 6) + webp[6:])
    with pytest.raises(ValueError, match='Render.encoding: webp needs protocol version 7'):
        encode(MessageType.Render, 1, 6, encoding=Encoding.webp, scene_json='{}')
    busy = encode(MessageType.Error, 5, 3, code=ErrorCode.Busy, message='')
    with pytest.raises(ProtocolError, match='Error.code: unknown value 14 in protocol version 2'):
        decode(busy[:4] + struct.pack('<H', 2) + busy[6:])


def test_malformed_bodies_name_the_field():
    good = encode(MessageType.DatasetInfo, 1, 1, name='mri', meta_json='{}')
    body = good[HEADER.size:]
    cases = {
        body[:-1]: 'DatasetInfo.meta_json: truncated',
        body + b'\0': 'DatasetInfo: 1 trailing byte(s)',
        struct.pack('<I', 2) + b'\xff\xfe' + body[7:]: 'DatasetInfo.name: not valid UTF-8',
        struct.pack('<I', (1 << 20) + 1) + body[4:]: 'DatasetInfo.name: length 1048577 exceeds limit 1048576',
    }
    for bad, words in cases.items():
        with pytest.raises(ProtocolError) as e:
            decode_body(MessageType.DatasetInfo, bad)
        assert e.value.code == ErrorCode.Malformed and words in str(e.value), bad
    with pytest.raises(ProtocolError, match='DatasetList.names: count 4097 exceeds limit 4096'):
        decode_body(MessageType.DatasetList, struct.pack('<I', 4097))


def test_headers_that_do_not_check():
    header = HEADER.pack(MAGIC, 1, 1, 1, 0)
    with pytest.raises(ProtocolError, match='BadMagic'):
        decode_header(b'XXXX' + header[4:])
    with pytest.raises(ProtocolError, match='UnsupportedVersion: version 10'):
        decode_header(HEADER.pack(MAGIC, 10, 1, 1, 0))
    with pytest.raises(ProtocolError, match='TooLarge: body of 2000 bytes exceeds 1000'):
        decode_header(HEADER.pack(MAGIC, 1, 8, 1, 2000), max_body=1000)
    assert decode_header(HEADER.pack(MAGIC, 1, 99, 7, 3)).type is None  # unknown: skipped, not fatal
    assert decode_header(HEADER.pack(MAGIC, 3, 13, 7, 4)).type is None  # FrameReceived is version 4's
    assert decode_header(HEADER.pack(MAGIC, 4, 15, 7, 4)).type is None  # Authenticated is version 5's
    assert decode_header(HEADER.pack(MAGIC, 5, 17, 7, 4)).type is None  # UploadReady is version 6's
    assert decode_header(HEADER.pack(MAGIC, 6, 17, 7, 4)).type == MessageType.UploadReady


def test_encodings_by_name():
    assert encoding_of('raw') == encoding_of('raw_rgba8') == encoding_of(0) == Encoding.raw_rgba8
    assert encoding_of('ZSTD') == Encoding.zstd_rgba8
    with pytest.raises(ValueError, match="encoding 'gif': expected one of raw, png, zstd, jpeg"):
        encoding_of('gif')


def test_addresses():
    assert parse_address('127.0.0.1:7420') == ('tcp', '127.0.0.1', 7420, None, False)
    assert parse_address('[::1]:7420') == ('tcp', '::1', 7420, None, False)
    assert parse_address('ws://host:8080', token='a-b.c_~') == ('ws', 'host', 8080, 'a-b.c_~', False)
    assert parse_address('http://host:8080/?token=T0k&dataset=x') == ('ws', 'host', 8080, 'T0k', False)
    # Inside TLS: TCP ("tls://"), the WebSocket ("wss://", the viewer's "https://"); a token over TCP too (Authenticate).
    assert parse_address('tls://host:7420', token='t') == ('tcp', 'host', 7420, 't', True)
    assert parse_address('wss://host:8443/ws') == ('ws', 'host', 8443, None, True)
    assert parse_address('https://host:8443/?token=T0k') == ('ws', 'host', 8443, 'T0k', True)
    assert parse_address('host:7420', token='t') == ('tcp', 'host', 7420, 't', False)
    for bad, words in [('host', 'expected "HOST:PORT"'), ('host:0', 'port in 1..65535'),
                       ('ftp://host:8080', "scheme 'ftp'"), ('ws://host:8080/other', "path '/other'"),
                       ('ws://host:99999', 'port in 1..65535')]:
        with pytest.raises(ValueError, match=words):
            parse_address(bad)
    with pytest.raises(ValueError, match='token: letters, digits'):
        parse_address('ws://host:8080', token='a b')


def test_the_png_decoder_reads_every_filter_as_pillow_does():
    rng = np.random.default_rng(3)
    smooth = (np.add.outer(np.arange(37), np.arange(53))[:, :, None] * [1, 3, 5, 7] % 256).astype(np.uint8)
    noisy = rng.integers(0, 256, (29, 41, 4), dtype=np.uint8)
    for image in (smooth, noisy, smooth[:, :, :3], smooth[:, :, 0]):
        buffer = io.BytesIO()
        Image.fromarray(image).save(buffer, format='PNG', optimize=True)  # libpng's adaptive filters
        data = buffer.getvalue()
        expected = np.asarray(Image.open(io.BytesIO(data)).convert('RGBA'))
        assert np.array_equal(decode_png(data), expected)
        assert np.array_equal(decode_png(data, pillow=True), expected)
        assert np.array_equal(decode_png(encode_png(image)), expected)
    # Each filter type alone, rows written by hand.
    height, width = 6, 5
    pixels = rng.integers(0, 256, (height, width, 4), dtype=np.uint8)
    for kind in range(5):
        rows = [bytes([kind]) + _filtered(pixels, r, kind) for r in range(height)]
        png = _png(width, height, b''.join(rows))
        assert np.array_equal(decode_png(png), pixels), kind


def _filtered(pixels, r, kind):
    row = pixels[r].astype(int).reshape(-1)
    above = pixels[r - 1].astype(int).reshape(-1) if r else np.zeros_like(row)
    out = []
    for i, x in enumerate(row):
        a = row[i - 4] if i >= 4 else 0
        b = above[i]
        c = above[i - 4] if i >= 4 else 0
        p = a + b - c
        paeth = min((abs(p - a), 0, a), (abs(p - b), 1, b), (abs(p - c), 2, c))[2]
        out.append((x - [0, a, b, (a + b) // 2, paeth][kind]) % 256)
    return bytes(out)


def _png(width, height, raw, colour=6):
    def chunk(kind, body):
        return struct.pack('>I', len(body)) + kind + body + struct.pack('>I', zlib.crc32(kind + body))
    return (b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', width, height, 8, colour, 0, 0, 0)) +
            chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b''))


def test_damaged_payloads_are_refused_naming_the_problem():
    png = encode_png(np.zeros((4, 5, 4), np.uint8))
    cases = [
        (b'GIF89a', 'not a PNG'),
        (png[:40], 'cut short'),
        (png[:-20], 'cut short in chunk'),
        (png[:20] + bytes([png[20] ^ 1]) + png[21:], 'CRC mismatch'),
        (_png(2, 2, b'\0' * 17), 'image data is 17 bytes, expected 18'),
        (_png(1, 1, b'\x07' + b'\0' * 4), 'unknown filter type 7'),
        (_png(1, 1, b'\0' * 5, colour=3), 'colour type 3'),
    ]
    for data, words in cases:
        for pillow in (False, True):
            with pytest.raises(voxbrick.DecodeError, match=words):
                decode_png(data, pillow=pillow)
    with pytest.raises(voxbrick.DecodeError, match='raw_rgba8 payload of 7 bytes, expected 2x1x4 = 8'):
        decode_frame(b'\0' * 7, 'raw', 2, 1)
    with pytest.raises(voxbrick.DecodeError, match='png payload is 5x4, the Frame says 4x5'):
        decode_frame(png, 'png', 4, 5)
    with pytest.raises(voxbrick.DecodeError, match='zstd_rgba8 payload does not decompress'):
        decode_frame(b'not zstd', 'zstd', 2, 2)
    with pytest.raises(voxbrick.DecodeError, match='vp8 frames decode only within their video stream'):
        decode_frame(b'', 'vp8', 2, 2)


@pytest.mark.parametrize('size', [0, 1, 3, 4, 4095, 4096, 4099, (1 << 16) + 2, (1 << 20) + 3])
def test_websocket_masking_with_numpy_is_the_xor_of_rfc_6455(size, monkeypatch):
    # Every byte XOR the mask byte of its position modulo 4 (RFC 6455, 5.3), whichever way it is computed: NumPy's
    # 32-bit words for large payloads, one big integer without NumPy.
    from voxbrick import transport
    payload, mask = bytes((i * 131 + 7) % 256 for i in range(size)), b'\x9a\x04\xe1\x5c'
    expected = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
    assert transport._masked(payload, mask) == expected
    assert transport._masked(memoryview(payload), mask) == expected
    monkeypatch.setattr(transport, '_NUMPY', [None])
    assert transport._masked(payload, mask) == expected
