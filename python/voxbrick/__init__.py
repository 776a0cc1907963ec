"""voxbrick from Python: frames of a voxbrick server as NumPy arrays, stores prepped from arrays, arrays sent to a
server as new datasets (Client.upload), and the viewer in a Jupyter notebook.

    import voxbrick
    with voxbrick.connect("127.0.0.1:7420") as client:
        image = client.render("mri.vbs", camera="left", tf="mri", size=(256, 256))   # (256, 256, 4) uint8

The protocol (voxbrick.protocol, voxbrick.session) needs the standard library only; frames as arrays need NumPy.
"""
from __future__ import annotations

from typing import Any

from .errors import (ConnectionClosed, ConnectionRefused, DecodeError, ErrorCode, ProtocolError, ServerError,
                     TlsError, VoxbrickError)
from .protocol import Encoding

__version__ = '1.0'

# NumPy is imported with the first of these, so that the protocol alone runs without it.
_LAZY = {
    'connect': 'client', 'Client': 'client', 'Frame': 'client',
    'decode_png': 'images', 'encode_png': 'images', 'save_png': 'images', 'read_png': 'images',
    'prep': 'arrays', 'find_voxbrick': 'arrays',
    'view': 'notebook', 'View': 'notebook',
}

__all__ = ['ConnectionClosed', 'ConnectionRefused', 'DecodeError', 'ErrorCode', 'ProtocolError', 'ServerError',
           'TlsError', 'VoxbrickError', 'Encoding', *_LAZY]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib
        value = getattr(importlib.import_module(f'.{_LAZY[name]}', __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


def __dir__() -> list:
    return sorted(set(globals()) | set(_LAZY))
