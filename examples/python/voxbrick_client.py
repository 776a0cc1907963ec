#!/usr/bin/env python3
"""A voxbrick client in plain Python (standard library only); the protocol is proto/PROTOCOL.md.

    voxbrick_client.py HOST:PORT                                  lists the datasets
    voxbrick_client.py HOST:PORT --dataset NAME -o frame.png      renders one frame
        [--scene scene.json] [--orbit AZ,EL,DIST] [--size WxH] [--encoding png|raw_rgba8|zstd_rgba8|jpeg]
        [--jpeg-quality Q]   (jpeg needs a server of protocol version 2; the JPEG file is written as it came)
        [--tls [--ca FILE | --tls-insecure]]   (a server started with --tls-cert speaks TLS only)
        [--token-file FILE]  (or $VOXBRICK_TOKEN: the access token, presented in protocol version 5)

Offline, for tests without a server: --encode-hello FILE, --encode-render FILE --scene-json TEXT (write one
message, request id 1) and --decode FILE (print one message as JSON).
"""
import argparse
import binascii
import json
import os
import socket
import ssl
import struct
import sys

MAGIC = 0x4B425856  # "VXBK" read as a little-endian u32
# The protocol versions this client speaks; 2 adds the jpeg encoding, 3 the Busy error, 4 the video encodings (vp8,
# vp9: a session's moving frames as one stream, which this client never asks for: it takes stills) and FrameReceived,
# 5 the access token (Authenticate, Authenticated, the Forbidden error).
MIN_VERSION, MAX_VERSION = 1, 5
HEADER = struct.Struct('<IHHII')  # magic, version, type, request id, body bytes
CLIENT_NAME = 'voxbrick_client.py 1'
TYPES = ['Hello', 'Capabilities', 'ListDatasets', 'DatasetList', 'OpenDataset', 'DatasetInfo', 'Render', 'Frame',
         'Error', 'GetStats', 'Stats', 'Goodbye', 'FrameReceived', 'Authenticate', 'Authenticated']  # value = index + 1
ENCODINGS = dict(enumerate(['raw_rgba8', 'png', 'zstd_rgba8', 'jpeg', 'vp8', 'vp9']))  # value: name
ENCODING_SINCE = {'jpeg': 2, 'vp8': 4, 'vp9': 4}  # the protocol version an encoding appeared in (others: 1)
ERRORS = dict(enumerate(['BadMagic', 'UnsupportedVersion', 'UnknownType', 'TooLarge', 'Malformed', 'UnexpectedMessage',
                         'UnknownDataset', 'InvalidScene', 'LimitExceeded', 'Superseded', 'Internal', 'ShuttingDown',
                         'Timeout', 'Busy', 'Forbidden'], start=1))
ERROR_SINCE = {'Busy': 3, 'Forbidden': 5}  # the protocol version an error code appeared in (others: 1)
ENUMS = {'encoding': ENCODINGS, 'code': ERRORS}
ENUM_VALUES = {kind: {name: value for value, name in names.items()} for kind, names in ENUMS.items()}
INTS = {'u16': struct.Struct('<H'), 'u32': struct.Struct('<I'), 'encoding': struct.Struct('<B'),
        'code': struct.Struct('<H')}
# Each body's fields in wire order. str: u32 length + UTF-8; bytes: u32 length + bytes; "X list": u32 count + items.
FIELDS = {
    'Hello': [('min_version', 'u16'), ('max_version', 'u16'), ('client', 'str')],
    'Capabilities': [('version', 'u16'), ('server', 'str'), ('max_message_bytes', 'u32'), ('max_image_side', 'u32'),
                     ('max_queued_per_session', 'u32'), ('encodings', 'encoding list')],
    'DatasetList': [('names', 'str list')],
    'OpenDataset': [('name', 'str')],
    'DatasetInfo': [('name', 'str'), ('meta_json', 'str')],
    'Render': [('encoding', 'encoding'), ('scene_json', 'str')],
    'Frame': [('width', 'u32'), ('height', 'u32'), ('encoding', 'encoding'), ('stats_json', 'str'),
              ('payload', 'bytes')],
    'Error': [('code', 'code'), ('message', 'str')],
    'Stats': [('json', 'str')],
    'FrameReceived': [('frame_bytes', 'u32')],
    'Authenticate': [('token', 'str')],
    'Authenticated': [('token_id', 'str')],
}


class ProtocolError(Exception):
    """An Error reply, or bytes that do not decode: `code` is the error code's name."""

    def __init__(self, code, message):
        super().__init__(f'{code}: {message}')
        self.code, self.message = code, message


def known(kind, name, version):
    """Whether an enum value's name exists in protocol `version`."""
    return (ENCODING_SINCE if kind == 'encoding' else ERROR_SINCE).get(name, 1) <= version


def encode_value(kind, value):
    if kind.endswith(' list'):
        return INTS['u32'].pack(len(value)) + b''.join(encode_value(kind[:-5], item) for item in value)
    if kind in ('str', 'bytes'):
        data = value.encode('utf-8') if kind == 'str' else value
        return INTS['u32'].pack(len(data)) + data
    return INTS[kind].pack(ENUM_VALUES[kind][value] if kind in ENUMS else value)


def encode(type_name, request_id, header_version=MIN_VERSION, **fields):
    """A whole message in protocol `header_version`."""
    for name, kind in FIELDS.get(type_name, []):
        if kind == 'encoding' and not known(kind, fields[name], header_version):
            raise ValueError(f'{type_name}.{name}: {fields[name]} needs protocol version {ENCODING_SINCE[fields[name]]}')
    body = b''.join(encode_value(kind, fields[name]) for name, kind in FIELDS.get(type_name, []))
    return HEADER.pack(MAGIC, header_version, TYPES.index(type_name) + 1, request_id, len(body)) + body


def decode_header(data, max_body):
    """(type name or None if unknown, request id, body length, version) of a 16-byte header."""
    magic, version, type_value, request_id, size = HEADER.unpack(data)
    if magic != MAGIC:
        raise ProtocolError('BadMagic', f'magic 0x{magic:08X}')
    if not MIN_VERSION <= version <= MAX_VERSION:
        raise ProtocolError('UnsupportedVersion', f'version {version}')
    if size > max_body:
        raise ProtocolError('TooLarge', f'body of {size} bytes exceeds {max_body}')
    return (TYPES[type_value - 1] if 1 <= type_value <= len(TYPES) else None), request_id, size, version


def decode_body(type_name, body, version=MAX_VERSION):
    """The fields of a body as a dict; enums as names, strings as str, payloads as bytes."""
    offset = 0

    def take(size, field):
        nonlocal offset
        if size > len(body) - offset:
            raise ProtocolError('Malformed', f'{type_name}.{field}: truncated')
        offset += size
        return body[offset - size:offset]

    def value(kind, field):
        if kind.endswith(' list'):
            return [value(kind[:-5], field) for _ in range(value('u32', field))]
        if kind == 'bytes':
            return take(value('u32', field), field)
        if kind == 'str':
            try:
                return take(value('u32', field), field).decode('utf-8')
            except UnicodeDecodeError as e:
                raise ProtocolError('Malformed', f'{type_name}.{field}: not valid UTF-8 ({e.reason})') from None
        number = INTS[kind].unpack(take(INTS[kind].size, field))[0]
        if kind in ENUMS and (number not in ENUMS[kind] or not known(kind, ENUMS[kind][number], version)):
            raise ProtocolError('Malformed', f'{type_name}.{field}: unknown value {number} in version {version}')
        return ENUMS[kind][number] if kind in ENUMS else number

    message = {name: value(kind, name) for name, kind in FIELDS.get(type_name, [])}
    if offset != len(body):
        raise ProtocolError('Malformed', f'{type_name}: {len(body) - offset} trailing byte(s)')
    return message


class Client:
    """One session with a voxbrick server. Requests wait for their reply; an Error reply raises ProtocolError."""

    def __init__(self, host, port, timeout=120, tls=None):
        """`tls`: None for the clear, else an ssl.SSLContext (tls_context) whose checks the server must pass."""
        self.sock = socket.create_connection((host, port), timeout=timeout)
        if tls is not None:
            self.sock = tls.wrap_socket(self.sock, server_hostname=host)
        self.next_id = 1
        self.max_body = 64 << 20  # the largest body accepted: the default limit, or the server's if higher
        self.version = MIN_VERSION  # the session's protocol version: Hello is written in the lowest one offered

    def hello(self, max_version=MAX_VERSION):
        """Offers versions MIN_VERSION..max_version; the session speaks the one the server picks (self.version)."""
        caps = self._call('Hello', 'Capabilities', min_version=MIN_VERSION, max_version=max_version,
                          client=CLIENT_NAME)
        if not MIN_VERSION <= caps['version'] <= max_version:
            raise ProtocolError('UnsupportedVersion', f'the server chose version {caps["version"]}')
        self.version = caps['version']
        self.max_body = max(self.max_body, caps['max_message_bytes'])
        return caps

    def authenticate(self, token):
        """Presents the access token (protocol version 5 on); returns the token's id. A wrong one: Forbidden."""
        if self.version < 5:
            raise ProtocolError('UnsupportedVersion', f'an access token needs protocol version 5; the server speaks '
                                f'{self.version}')
        return self._call('Authenticate', 'Authenticated', token=token)['token_id']

    def list_datasets(self):
        return self._call('ListDatasets', 'DatasetList')['names']

    def open_dataset(self, name):
        return json.loads(self._call('OpenDataset', 'DatasetInfo', name=name)['meta_json'])

    def render(self, scene, encoding='png', on_provisional=None):
        """The exact frame as (width, height, encoding, stats, payload). For a scene with "progressive": true the
        server may first send provisional frames (stats "provisional": true, bricks still on their way drawn from a
        coarser level); each is passed to on_provisional, if given, as the same tuple."""
        request_id = self._send('Render', encoding=encoding, scene_json=json.dumps(scene))
        while True:
            frame = self._await(request_id, 'Frame')
            result = (frame['width'], frame['height'], frame['encoding'], json.loads(frame['stats_json']),
                      frame['payload'])
            if not result[3].get('provisional', False):
                return result
            if on_provisional:
                on_provisional(*result)

    def stats(self):
        return json.loads(self._call('GetStats', 'Stats')['json'])

    def close(self):
        try:
            self.sock.sendall(encode('Goodbye', self._new_id()))
        except OSError:
            pass  # the server already closed
        self.sock.close()

    def _new_id(self):
        self.next_id += 1
        return self.next_id - 1

    def _call(self, type_name, reply_type, **fields):
        return self._await(self._send(type_name, **fields), reply_type)

    def _send(self, type_name, **fields):
        request_id = self._new_id()
        self.sock.sendall(encode(type_name, request_id, self.version, **fields))
        return request_id

    def _await(self, request_id, reply_type):
        while True:
            name, reply_id, size, version = decode_header(self._read(HEADER.size), self.max_body)
            body = self._read(size)
            if name is None or reply_id not in (request_id, 0):
                continue  # a type this client does not know, or an answer to nothing it waits for
            reply = decode_body(name, body, version)
            if name == 'Error':
                raise ProtocolError(reply['code'], reply['message'])
            if name == 'Goodbye':
                raise ConnectionError('the server ended the session')
            if name == reply_type:
                return reply

    def _read(self, size):
        data = bytearray()
        while len(data) < size:
            chunk = self.sock.recv(min(size - len(data), 1 << 20))
            if not chunk:
                raise ConnectionError('the server closed the connection')
            data += chunk
        return bytes(data)


def decode_file(path):
    """One message from a file as a JSON-ready dict; a payload shows as its length and CRC-32."""
    with open(path, 'rb') as f:
        data = f.read()
    name, request_id, size, version = decode_header(data[:HEADER.size], 1 << 32)
    if name is None or len(data) != HEADER.size + size:
        raise ProtocolError('Malformed', f'{path}: unknown type or a body that is not {size} bytes')
    message = {'type': name, 'request_id': request_id, 'version': version,
               **decode_body(name, data[HEADER.size:], version)}
    if 'payload' in message:
        payload = message.pop('payload')
        message.update(payload_bytes=len(payload), payload_crc32=binascii.crc32(payload))
    return message


def tls_context(ca=None, insecure=False):
    """A TLS client context: TLS 1.2 or later, the server's certificate checked against `ca` (a PEM file; None: the
    system's CAs) and its name, unless `insecure` (any certificate: a self-signed one, in local use only)."""
    context = ssl.create_default_context(cafile=ca)
    context.minimum_version = ssl.TLSVersion.TLSv1_2
    if insecure:
        context.check_hostname = False
        context.verify_mode = ssl.CERT_NONE
    return context


def access_token(token_file):
    """The first line of `token_file`, else $VOXBRICK_TOKEN, else None."""
    if token_file:
        with open(token_file) as f:
            return f.readline().strip() or None
    return os.environ.get('VOXBRICK_TOKEN') or None


def render_frame(args):
    host, _, port = args.address.rpartition(':')
    client = Client(host, int(port), tls=tls_context(args.ca, args.tls_insecure) if args.tls else None)
    try:
        client.hello()
        token = access_token(args.token_file)
        if token:
            client.authenticate(token)
        if not args.dataset:
            print('\n'.join(client.list_datasets()))
            return
        client.open_dataset(args.dataset)
        scene = {}
        if args.scene:
            with open(args.scene) as f:
                scene = json.load(f)
        if args.orbit:
            camera = scene.setdefault('camera', {})
            for key in ('eye', 'center', 'up', 'view'):
                camera.pop(key, None)
            camera['orbit'] = [float(v) for v in args.orbit.split(',')]
        if args.size:
            scene['size'] = [int(v) for v in args.size.lower().split('x')]
        if args.progressive:
            scene['progressive'] = True
        if args.jpeg_quality is not None:
            scene['jpeg_quality'] = args.jpeg_quality
        if args.encoding == 'jpeg' and client.version < 2:
            raise ProtocolError('UnsupportedVersion', 'the server speaks protocol version 1, which has no jpeg')

        def provisional(width, height, encoding, stats, payload):
            root, ext = os.path.splitext(args.output)
            with open(root + '.provisional' + ext, 'wb') as f:
                f.write(payload)
            print(f'{root}.provisional{ext}: provisional {width}x{height}, {stats.get("bricks_standin")} bricks '
                  'stood in')

        width, height, encoding, stats, payload = client.render(scene, args.encoding, provisional)
        with open(args.output, 'wb') as f:
            f.write(payload)
        print(f'{args.output}: {width}x{height} {encoding}, {len(payload)} bytes; stats {json.dumps(stats)}')
    finally:
        client.close()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('address', nargs='?', help='HOST:PORT of the server')
    parser.add_argument('--dataset', help='dataset to render (without it: list the datasets)')
    parser.add_argument('--scene', help='scene JSON file (the schema of `voxbrick render --scene`)')
    parser.add_argument('--orbit', help='AZ,EL[,DIST] camera orbit (degrees about the up axis, +z by default; bounding radii, default fitted)')
    parser.add_argument('--size', help='WxH image size')
    parser.add_argument('--encoding', choices=list(ENCODINGS.values()), default='png')
    parser.add_argument('--jpeg-quality', type=int, choices=range(1, 101), metavar='1..100',
                        help='quality of a jpeg frame (default: the server\'s)')
    parser.add_argument('--progressive', action='store_true',
                        help='coarse to fine: also write the provisional frame (beside the output) if one comes')
    parser.add_argument('-o', '--output', default='frame.png', help='where the payload is written')
    parser.add_argument('--tls', action='store_true', help='speak TLS, the server\'s certificate verified')
    parser.add_argument('--ca', help='PEM certificates of the CAs that may sign the server\'s (default: the system\'s)')
    parser.add_argument('--tls-insecure', action='store_true',
                        help='take any certificate (a self-signed one, in local use only)')
    parser.add_argument('--token-file', help='file whose first line is the access token (default: $VOXBRICK_TOKEN)')
    parser.add_argument('--encode-hello', metavar='FILE', help='write a Hello message to FILE')
    parser.add_argument('--encode-render', metavar='FILE', help='write a Render message with --scene-json to FILE')
    parser.add_argument('--scene-json', metavar='TEXT', help='scene JSON text for --encode-render')
    parser.add_argument('--decode', metavar='FILE', help='print the message in FILE as JSON')
    args = parser.parse_args()
    if (args.ca or args.tls_insecure) and not args.tls:
        parser.error('--ca and --tls-insecure need --tls')
    try:
        if args.encode_hello:
            with open(args.encode_hello, 'wb') as f:
                f.write(encode('Hello', 1, min_version=MIN_VERSION, max_version=MAX_VERSION, client=CLIENT_NAME))
        elif args.encode_render:
            if args.scene_json is None:
                parser.error('--encode-render needs --scene-json')
            with open(args.encode_render, 'wb') as f:
                # Written in the first version that has the encoding (jpeg: 2).
                f.write(encode('Render', 1, ENCODING_SINCE.get(args.encoding, MIN_VERSION), encoding=args.encoding,
                               scene_json=args.scene_json))
        elif args.decode:
            print(json.dumps(decode_file(args.decode), indent=2, ensure_ascii=False))
        elif args.address:
            render_frame(args)
        else:
            parser.error('HOST:PORT is required')
    except (ProtocolError, OSError) as e:
        sys.exit(f'error: {e}')


if __name__ == '__main__':
    main()
