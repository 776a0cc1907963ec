#!/usr/bin/env python3
"""A voxbrick client on the command line, through the Python package `voxbrick` (python/ in the source tree,
share/voxbrick/python installed); this script needs the standard library only (frames are written as they came).

    voxbrick_client.py HOST:PORT                                  lists the datasets
    voxbrick_client.py HOST:PORT --dataset NAME -o frame.png      renders one frame
        [--scene scene.json] [--orbit AZ,EL,DIST] [--size WxH] [--encoding png|raw_rgba8|zstd_rgba8|jpeg]
        [--jpeg-quality Q]   (jpeg needs a server of protocol version 2; the JPEG file is written as it came)
    voxbrick_client.py ws://HOST:HTTP_PORT --token TOKEN ...     the same over the server's WebSocket
    voxbrick_client.py tls://HOST:PORT --token TOKEN --ca ca.pem ...   over TLS (wss://HOST:HTTP_PORT too)

Offline, for tests without a server: --encode-hello FILE, --encode-render FILE --scene-json TEXT (write one
message, request id 1) and --decode FILE (print one message as JSON).
"""
import argparse
import binascii
import enum
import json
import os
import sys

try:
    import voxbrick  # noqa: F401  (installed, or on PYTHONPATH)
except ImportError:
    # The package beside this script: python/ two folders up, in the source tree and in share/voxbrick alike.
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, 'python'))

from voxbrick.errors import VoxbrickError  # noqa: E402
from voxbrick.protocol import (ENCODING_SINCE, MAX_VERSION, MIN_VERSION, Encoding, MessageType, decode,  # noqa: E402
                               encode, encoding_of)
from voxbrick.session import Session  # noqa: E402

CLIENT_NAME = 'voxbrick_client.py 1'


def decode_file(path):
    """One message from a file as a JSON-ready dict; enums by name, bytes (a payload, an upload's data) as their
    length and CRC-32."""
    with open(path, 'rb') as f:
        data = f.read()
    header, fields = decode(data, 1 << 32)
    message = {'type': header.type.name, 'request_id': header.request_id, 'version': header.version}
    for name, value in fields.items():
        if isinstance(value, enum.Enum):
            value = value.name
        elif isinstance(value, list):
            value = [v.name if isinstance(v, enum.Enum) else v for v in value]
        elif isinstance(value, (bytes, bytearray, memoryview)):
            message.update({f'{name}_bytes': len(value), f'{name}_crc32': binascii.crc32(value)})
            continue
        message[name] = value
    return message


def render_frame(args):
    session = Session(args.address, args.token, client_name=CLIENT_NAME, ca=args.ca, insecure=args.insecure)
    try:
        if not args.dataset:
            print('\n'.join(session.list_datasets()))
            return
        session.open_dataset(args.dataset)
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

        def provisional(frame):
            root, ext = os.path.splitext(args.output)
            with open(root + '.provisional' + ext, 'wb') as f:
                f.write(frame.payload)
            print(f'{root}.provisional{ext}: provisional {frame.width}x{frame.height}, '
                  f'{frame.stats.get("bricks_standin")} bricks stood in')

        frame = session.render(scene, args.encoding, provisional)
        with open(args.output, 'wb') as f:
            f.write(frame.payload)
        print(f'{args.output}: {frame.width}x{frame.height} {frame.encoding.name}, {len(frame.payload)} bytes; '
              f'stats {json.dumps(frame.stats)}')
    finally:
        session.close()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('address', nargs='?', help='HOST:PORT of the server, or ws://HOST:HTTP_PORT')
    parser.add_argument('--token', help='the access token: given when the WebSocket opens (ws://, wss://), or over '
                                        'TCP by Authenticate (protocol version 5)')
    parser.add_argument('--ca', help='PEM file of the CAs that may sign the server\'s certificate (tls://, wss://; '
                                     'default: the system\'s CAs)')
    parser.add_argument('--insecure', action='store_true',
                        help='over TLS, take any certificate (a self-signed one in local use)')
    parser.add_argument('--dataset', help='dataset to render (without it: list the datasets)')
    parser.add_argument('--scene', help='scene JSON file (the schema of `voxbrick render --scene`)')
    parser.add_argument('--orbit', help='AZ,EL[,DIST] camera orbit (degrees about the up axis, +z by default; '
                                        'bounding radii, default fitted)')
    parser.add_argument('--size', help='WxH image size')
    parser.add_argument('--encoding', choices=[e.name for e in Encoding if e <= Encoding.jpeg], default='png')
    parser.add_argument('--jpeg-quality', type=int, choices=range(1, 101), metavar='1..100',
                        help='quality of a jpeg frame (default: the server\'s)')
    parser.add_argument('--progressive', action='store_true',
                        help='coarse to fine: also write the provisional frame (beside the output) if one comes')
    parser.add_argument('-o', '--output', default='frame.png', help='where the payload is written')
    parser.add_argument('--encode-hello', metavar='FILE', help='write a Hello message to FILE')
    parser.add_argument('--encode-render', metavar='FILE', help='write a Render message with --scene-json to FILE')
    parser.add_argument('--scene-json', metavar='TEXT', help='scene JSON text for --encode-render')
    parser.add_argument('--decode', metavar='FILE', help='print the message in FILE as JSON')
    args = parser.parse_args()
    try:
        if args.encode_hello:
            with open(args.encode_hello, 'wb') as f:
                f.write(encode(MessageType.Hello, 1, MIN_VERSION, min_version=MIN_VERSION, max_version=MAX_VERSION,
                               client=CLIENT_NAME))
        elif args.encode_render:
            if args.scene_json is None:
                parser.error('--encode-render needs --scene-json')
            encoding = encoding_of(args.encoding)
            with open(args.encode_render, 'wb') as f:
                # Written in the first version that has the encoding (jpeg: 2).
                f.write(encode(MessageType.Render, 1, ENCODING_SINCE.get(encoding, MIN_VERSION), encoding=encoding,
                               scene_json=args.scene_json))
        elif args.decode:
            print(json.dumps(decode_file(args.decode), indent=2, ensure_ascii=False))
        elif args.address:
            render_frame(args)
        else:
            parser.error('HOST:PORT is required')
    except (VoxbrickError, OSError, ValueError) as e:
        sys.exit(f'error: {e}')


if __name__ == '__main__':
    main()
