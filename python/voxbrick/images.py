"""Frame payloads to NumPy images and back: raw RGBA, PNG (a decoder and an encoder of our own, on zlib), zstd (the
zstandard module, Debian's python3-zstandard), JPEG and lossless WebP (Pillow, Debian's python3-pil). Every image is an array of
shape (height, width, 4), dtype uint8, row 0 at the top.
"""
from __future__ import annotations

import struct
import zlib
from typing import Any, Union

import numpy as np

from .errors import DecodeError
from .protocol import Encoding, encoding_of

PNG_SIGNATURE = b'\x89PNG\r\n\x1a\n'
_CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}  # PNG colour type: channels (grey, RGB, grey+alpha, RGBA)


def decode_frame(payload: bytes, encoding: Union[Encoding, str], width: int, height: int) -> np.ndarray:
    """The image a Frame's payload holds, (height, width, 4) uint8; DecodeError when it does not decode to that size,
    or when its encoding needs a module that is not installed (zstd: python3-zstandard; jpeg, webp: python3-pil). Video
    frames (vp8, vp9) decode only within their stream and are refused."""
    encoding = encoding_of(encoding)
    if encoding == Encoding.raw_rgba8:
        image = _raw(payload, width, height)
    elif encoding == Encoding.png:
        image = _decode_png_fast(payload)
    elif encoding == Encoding.zstd_rgba8:
        image = _raw(_zstd_decompress(payload, width * height * 4), width, height)
    elif encoding == Encoding.jpeg:
        image = decode_jpeg(payload)
    elif encoding == Encoding.webp:
        image = decode_webp(payload)
    else:
        raise DecodeError(f'{encoding.name} frames decode only within their video stream; this client takes stills '
                          '(raw, png, zstd, jpeg, webp)')
    if image.shape[:2] != (height, width):
        raise DecodeError(f'{encoding.name} payload is {image.shape[1]}x{image.shape[0]}, the Frame says '
                          f'{width}x{height}')
    return image


def scale_up(image: np.ndarray, width: int, height: int) -> np.ndarray:
    """`image` (height, width, 4) uint8 grown bilinearly to `width` x `height`, pixel centres aligned and edges
    clamped, as the server scales a reduced drawing (image::scaleImage) and a browser draws an image onto a larger
    canvas: how a provisional frame sent at the size it was drawn (protocol version 8) is shown at its scene's size.
    Within a level or two of the server's own fixed-point scaling."""
    h, w = image.shape[:2]
    if (w, h) == (width, height):
        return image
    if width < w or height < h:
        raise ValueError(f'scale_up: {w}x{h} is larger than {width}x{height}')

    def taps(source: int, target: int):
        x = np.clip((np.arange(target) + 0.5) * source / target - 0.5, 0, source - 1)
        first = np.floor(x).astype(np.intp)
        return first, np.minimum(first + 1, source - 1), (x - first)[:, None]

    x0, x1, fx = taps(w, width)
    y0, y1, fy = taps(h, height)
    pixels = image.astype(np.float32)
    rows = pixels[y0] * (1 - fy[:, :, None]) + pixels[y1] * fy[:, :, None]
    grown = rows[:, x0] * (1 - fx) + rows[:, x1] * fx
    return np.clip(np.rint(grown), 0, 255).astype(np.uint8)


def _raw(data: bytes, width: int, height: int) -> np.ndarray:
    if len(data) != width * height * 4:
        raise DecodeError(f'raw_rgba8 payload of {len(data)} bytes, expected {width}x{height}x4 = '
                          f'{width * height * 4}')
    return np.frombuffer(data, dtype=np.uint8).reshape(height, width, 4).copy()


def _zstd_decompress(data: bytes, size: int) -> bytes:
    try:
        import zstandard
    except ImportError:
        raise DecodeError('zstd frames need the zstandard module (Debian: apt-get install python3-zstandard); '
                          'ask for png or raw instead') from None
    try:
        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    except zstandard.ZstdError as e:
        raise DecodeError(f'zstd_rgba8 payload does not decompress: {e}') from None


def zstd_available() -> bool:
    """Whether zstd frames can be decoded here (the zstandard module is installed)."""
    try:
        import zstandard  # noqa: F401
    except ImportError:
        return False
    return True


def decode_jpeg(data: bytes) -> np.ndarray:
    """A JPEG's pixels with alpha 255, (height, width, 4) uint8; needs Pillow."""
    return _decode_with_pillow(data, 'jpeg', 'JPEG')


def decode_webp(data: bytes) -> np.ndarray:
    """A lossless WebP's pixels, (height, width, 4) uint8 (alpha 255 where the file has none); needs Pillow."""
    return _decode_with_pillow(data, 'webp', 'WEBP')


def _decode_with_pillow(data: bytes, name: str, pillow_format: str) -> np.ndarray:
    """A `name` payload (Pillow's `pillow_format`) as (height, width, 4) uint8 RGBA; DecodeError without Pillow, for
    a file of another format, or one that does not decode."""
    try:
        from PIL import Image
    except ImportError:
        raise DecodeError(f'{name} frames need Pillow (Debian: apt-get install python3-pil); ask for png instead') \
            from None
    import io
    try:
        with Image.open(io.BytesIO(data), formats=[pillow_format]) as image:
            return np.asarray(image.convert('RGBA')).copy()
    except OSError as e:
        raise DecodeError(f'{name} payload does not decode: {e}') from None


def _decode_png_fast(data: bytes) -> np.ndarray:
    """decode_png's pixels: the file checked by decode_png's reading of its chunks, then unfiltered by Pillow when it
    is installed (about ten times faster at 512x512), else by our own code."""
    return decode_png(data, pillow=True)


def decode_png(data: bytes, pillow: bool = False) -> np.ndarray:
    """The pixels of an 8-bit, non-interlaced PNG (grey, grey+alpha, RGB or RGBA: what the server and
    `voxbrick render` write is RGBA) as (height, width, 4) uint8, without colour conversion. DecodeError naming the
    problem for anything else, a bad CRC or a cut-short file. `pillow`: unfilter with Pillow if it is installed (the
    same pixels, faster)."""
    if not data.startswith(PNG_SIGNATURE):
        raise DecodeError('not a PNG (no PNG signature)')
    offset, header, idat = len(PNG_SIGNATURE), None, []
    while True:
        if offset + 8 > len(data):
            raise DecodeError('PNG cut short (no IEND chunk)')
        length, kind = struct.unpack('>I4s', data[offset:offset + 8])
        body = data[offset + 8:offset + 8 + length]
        if len(body) != length or offset + 12 + length > len(data):
            raise DecodeError(f'PNG cut short in chunk {kind!r}')
        (crc,) = struct.unpack('>I', data[offset + 8 + length:offset + 12 + length])
        if zlib.crc32(kind + body) != crc:
            raise DecodeError(f'PNG chunk {kind!r}: CRC mismatch')
        offset += 12 + length
        if kind == b'IHDR':
            if length != 13:
                raise DecodeError('PNG IHDR is not 13 bytes')
            header = struct.unpack('>IIBBBBB', body)
        elif kind == b'IDAT':
            idat.append(body)
        elif kind == b'IEND':
            break
    if header is None:
        raise DecodeError('PNG without IHDR')
    width, height, depth, colour, _, _, interlace = header
    if depth != 8 or colour not in _CHANNELS or interlace != 0:
        raise DecodeError(f'PNG of bit depth {depth}, colour type {colour}, interlace {interlace}: only 8-bit '
                          'non-interlaced grey, RGB and RGBA are read')
    if width == 0 or height == 0:
        raise DecodeError(f'PNG of size {width}x{height}')
    channels = _CHANNELS[colour]
    stride = width * channels
    try:
        raw = zlib.decompressobj().decompress(b''.join(idat), height * (stride + 1) + 1)
    except zlib.error as e:
        raise DecodeError(f'PNG image data does not inflate: {e}') from None
    if len(raw) != height * (stride + 1):
        raise DecodeError(f'PNG image data is {len(raw)} bytes, expected {height * (stride + 1)}')
    rows = np.frombuffer(raw, dtype=np.uint8).reshape(height, stride + 1)
    filters = rows[:, 0]
    if filters.max() > 4:
        raise DecodeError(f'PNG row {int(np.argmax(filters > 4))}: unknown filter type {int(filters.max())}')
    if pillow and channels == 4:
        try:
            from PIL import Image
        except ImportError:
            pass
        else:
            import io
            with Image.open(io.BytesIO(data)) as image:
                return np.asarray(image).copy()
    pixels = _unfilter(filters, rows[:, 1:].reshape(height, width, channels))
    if channels == 4:
        return pixels
    rgba = np.empty((height, width, 4), dtype=np.uint8)
    if channels in (1, 2):
        rgba[..., :3] = pixels[..., :1]
    else:
        rgba[..., :3] = pixels
    rgba[..., 3] = pixels[..., 1] if channels == 2 else 255
    return rgba


def _unfilter(filters: np.ndarray, filtered: np.ndarray) -> np.ndarray:
    """PNG's reconstruction (filter types None, Sub, Up, Average, Paeth), vectorised. Rows of None, Sub and Up only
    are reconstructed a row at a time; Average and Paeth depend on the pixel to the left, so an image with them is
    reconstructed by anti-diagonals: pixel (r, x) needs (r, x-1), (r-1, x) and (r-1, x-1), all on the two diagonals
    before its own, so each diagonal is one vector step (height + width steps in all)."""
    height, width, channels = filtered.shape
    if filters.max() <= 2:
        out = np.empty_like(filtered)
        previous = np.zeros((width, channels), dtype=np.uint8)
        for r in range(height):
            row, kind = filtered[r], filters[r]
            if kind == 1:
                row = np.cumsum(row, axis=0, dtype=np.uint8)
            elif kind == 2:
                row = row + previous
            out[r] = row
            previous = out[r]
        return out
    # Padded by a zero row on top and a zero column on the left: the PNG's "outside the image is 0".
    recon = np.zeros((height + 1, width + 1, channels), dtype=np.int16)
    kinds = filters.astype(np.int8)
    values = filtered.astype(np.int16)
    for d in range(height + width - 1):
        r = np.arange(max(0, d - width + 1), min(height, d + 1))
        x = d - r
        a = recon[r + 1, x]  # left
        b = recon[r, x + 1]  # above
        c = recon[r, x]  # above left
        kind = kinds[r][:, None]
        p = a + b - c
        pa, pb, pc = np.abs(p - a), np.abs(p - b), np.abs(p - c)
        paeth = np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))
        predictor = np.select([kind == 1, kind == 2, kind == 3, kind == 4], [a, b, (a + b) >> 1, paeth], 0)
        recon[r + 1, x + 1] = (values[r, x] + predictor) & 0xFF
    return recon[1:, 1:].astype(np.uint8)


def encode_png(image: Any, level: int = 6) -> bytes:
    """A PNG file of an image: (height, width, 4) or (height, width, 3) uint8 (RGBA or RGB), or (height, width)
    grey. Rows are written unfiltered (filter type None)."""
    pixels = np.ascontiguousarray(image)
    if pixels.dtype != np.uint8:
        raise ValueError(f'encode_png: dtype {pixels.dtype}; expected uint8 (convert first, e.g. with np.clip and '
                         '.astype(np.uint8))')
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    if pixels.ndim != 3 or pixels.shape[2] not in (1, 3, 4) or 0 in pixels.shape:
        raise ValueError(f'encode_png: shape {image.shape}; expected (height, width), (height, width, 3) or '
                         '(height, width, 4)')
    height, width, channels = pixels.shape
    colour = {1: 0, 3: 2, 4: 6}[channels]
    rows = np.zeros((height, width * channels + 1), dtype=np.uint8)
    rows[:, 1:] = pixels.reshape(height, -1)

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack('>I', len(body)) + kind + body + struct.pack('>I', zlib.crc32(kind + body))

    return (PNG_SIGNATURE + chunk(b'IHDR', struct.pack('>IIBBBBB', width, height, 8, colour, 0, 0, 0)) +
            chunk(b'IDAT', zlib.compress(rows.tobytes(), level)) + chunk(b'IEND', b''))


def save_png(image: Any, path: str) -> None:
    """Writes an image (as encode_png takes it) to a PNG file at `path`."""
    data = encode_png(image)
    with open(path, 'wb') as f:
        f.write(data)


def read_png(path: str) -> np.ndarray:
    """The pixels of a PNG file, as decode_png gives them."""
    with open(path, 'rb') as f:
        return decode_png(f.read())
