"""Scenes (PROTOCOL.md, section 6) from Python arguments: a camera as a named view, an orbit or a dict; a transfer
function as a preset name, a dict or a list of points; window, size and any other scene key as is. The server checks
every value against its schema and names what it refuses; here only the shape of each argument is checked.
"""
from __future__ import annotations

import copy
import json
import numbers
from typing import Any, Dict, Optional, Sequence, Union

Camera = Union[str, Sequence[float], Dict[str, Any], None]
TransferFunction = Union[str, Dict[str, Any], Sequence[Sequence[float]], None]

#: The named views of `camera.view`.
NAMED_VIEWS = ('anterior', 'posterior', 'left', 'right', 'superior', 'inferior')


def _number(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f'{what}: {value!r} is not a number')
    return float(value)


def _numbers(value: Any, counts: Sequence[int], what: str) -> list:
    if isinstance(value, (str, bytes, dict)) or not hasattr(value, '__len__') or len(value) not in counts:
        raise ValueError(f'{what}: {value!r}; expected {" or ".join(str(c) for c in counts)} numbers')
    return [_number(v, what) for v in value]


def camera_json(camera: Camera) -> Optional[Dict[str, Any]]:
    """The scene's `camera` object: "left" (a named view) → {"view": "left"}; (az, el) or (az, el, dist) → an orbit;
    a dict → itself (eye, center, up, fov, orthographic, up_axis, fit ...); None → None (the server's default)."""
    if camera is None:
        return None
    if isinstance(camera, str):
        if camera not in NAMED_VIEWS:
            raise ValueError(f'camera {camera!r}: a named view is one of {", ".join(NAMED_VIEWS)}')
        return {'view': camera}
    if isinstance(camera, dict):
        return copy.deepcopy(camera)
    return {'orbit': _numbers(camera, (2, 3), 'camera (an orbit: azimuth, elevation[, distance])')}


def transfer_function_json(tf: TransferFunction) -> Union[str, Dict[str, Any], None]:
    """The scene's `transfer_function`: a preset name as is; a dict as is; a list (or array) of [x, r, g, b, a]
    points → {"points": ...}."""
    if tf is None or isinstance(tf, str):
        return tf
    if isinstance(tf, dict):
        return copy.deepcopy(tf)
    if hasattr(tf, 'tolist'):
        tf = tf.tolist()
    if not isinstance(tf, (list, tuple)) or not tf:
        raise ValueError(f'tf {tf!r}: expected a preset name, a dict or a list of [x, r, g, b, a] points')
    return {'points': [_numbers(p, (5,), f'tf point {i}') for i, p in enumerate(tf)]}


def _plain(value: Any) -> Any:
    """NumPy scalars and arrays (and tuples) as JSON's types."""
    if hasattr(value, 'tolist') and not isinstance(value, (str, bytes)):
        return value.tolist()
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def build_scene(scene: Union[Dict[str, Any], str, None] = None, *, camera: Camera = None,
                tf: TransferFunction = None, window: Optional[Sequence[float]] = None,
                size: Optional[Sequence[int]] = None, **keys: Any) -> Dict[str, Any]:
    """A scene dict: `scene` (a dict or JSON text; not changed) with the arguments laid over it. `camera` replaces
    the scene's camera whole; `keys` are further scene keys by their names (step=0.5, quality="psnr:40",
    shading=True, background="none", ...); a key given None is left out."""
    if isinstance(scene, str):
        try:
            scene = json.loads(scene)
        except ValueError as e:
            raise ValueError(f'scene: not JSON ({e})') from None
    if scene is not None and not isinstance(scene, dict):
        raise ValueError(f'scene: {type(scene).__name__}; expected a dict or a JSON object')
    result = copy.deepcopy(scene) if scene else {}
    if camera is not None:
        result['camera'] = camera_json(camera)
    if tf is not None:
        result['transfer_function'] = transfer_function_json(tf)
    if window is not None:
        result['window'] = _numbers(window, (2,), 'window (lo, hi)')
    if size is not None:
        if isinstance(size, (str, bytes)) or not hasattr(size, '__len__') or len(size) != 2 or not all(
                isinstance(v, numbers.Integral) and not isinstance(v, bool) and v > 0 for v in size):
            raise ValueError(f'size {size!r}: expected (width, height), two positive integers')
        result['size'] = [int(v) for v in size]
    for key, value in keys.items():
        if value is not None:
            result[key] = _plain(value)
    return result
