"""The viewer in a Jupyter output cell: the page `voxbrick serve --http PORT` serves, in an IFrame whose URL carries
the view (dataset, camera, transfer function, window, shading, quality, frame size), with the view readable and
settable from Python and its exact frame as an array (`snapshot`, rendered through the protocol). An array given in
place of a dataset is sent to the server first (Client.upload), as a new dataset.

Reading the view back works in the classic Notebook (Debian's jupyter-notebook 6): the viewer posts its view to the
cell, whose script hands it to the kernel (`IPython.notebook.kernel.execute`). Elsewhere (JupyterLab, an HTML export)
the frame still shows and turns, and the view is the one Python set last.
"""
from __future__ import annotations

import html
import json
import math
import urllib.parse
import uuid
import weakref
from typing import Any, Dict, Optional, Sequence, Union

import numpy as np

from .client import Client, connect
from .scene import NAMED_VIEWS as _NAMES

#: The named views and the orbit each stands for (about +z), as web/js/view.js has them.
NAMED_VIEWS = {'anterior': (0, 0), 'posterior': (180, 0), 'left': (90, 0), 'right': (270, 0), 'superior': (180, 90),
               'inferior': (0, -90)}
assert set(NAMED_VIEWS) == set(_NAMES)
#: The viewer's range of an orbit's distance, in bounding-sphere radii (web/js/view.js MIN_DIST, MAX_DIST).
MIN_DIST, MAX_DIST = 0.2, 50.0
PANEL_PX = 262  # the viewer's control panel and its border (web/viewer.css)

_views: 'weakref.WeakValueDictionary[str, View]' = weakref.WeakValueDictionary()


def view(dataset: Any, server: str, *, token: Optional[str] = None, camera: Any = None, tf: Any = 'grayscale',
         window: Optional[Sequence[float]] = None, shading: bool = False, quality: str = '',
         size: Sequence[int] = (512, 512), address: Optional[str] = None, browser_url: Optional[str] = None,
         ca: Optional[str] = None, insecure: bool = False, name: Optional[str] = None,
         spacing: Optional[Sequence[float]] = None, origin: Optional[Sequence[float]] = None,
         axes: Optional[str] = None, patient: Optional[bool] = None) -> 'View':
    """A live view of `dataset` for a notebook cell: the last expression of a cell, or display(view), shows it.

    `dataset`: a dataset's name, or a 3-D array (NumPy, a memory map, Zarr, anything Client.upload takes), which is
    first sent to the server as the new dataset `name` (default "array-" and 12 random hex digits; `view.dataset` says
    it) over the kernel's session with the server (below), then viewed. `spacing`, `origin`, `axes` ("zyx" by
    default: the last axis is x) and `patient` describe the array as Client.upload takes them. The server must take
    uploads from the session's token (docs/server.md#uploads); a refusal raises ServerError with its words
    (AlreadyExists for a name taken: uploaded datasets stay on the server).

    `server`: the server's HTTP port, as `voxbrick serve --http PORT` prints it ("http://HOST:PORT/?token=T", or
    "HOST:PORT" with `token=`). `camera`: a named view ("left") or an orbit (az, el[, dist]); `tf`: a preset name or
    a list of [x, r, g, b, a] points (each in [0, 1]); `window`: (lo, hi); `shading`, `quality` ("psnr:40",
    "ms:200"); `size`: the frame's (width, height), which the viewer then keeps. `address`: where the kernel renders
    snapshots and uploads (default: the WebSocket of `server`; a TCP "HOST:PORT" works too, the token presented there
    by Authenticate). `browser_url`: the viewer's address as the browser reaches it, when that is not `server` (a
    tunnel, a proxy). A server over TLS ("https://..."): the kernel's session verifies its certificate against `ca` (a
    PEM file of CAs) or the system's, or takes any with `insecure=True`; the browser trusts it, or not, by its own
    store.

    The URL in the cell carries the token: a notebook saved with its outputs holds it."""
    return View(dataset, server, token=token, camera=camera, tf=tf, window=window, shading=shading, quality=quality,
                size=size, address=address, browser_url=browser_url, ca=ca, insecure=insecure, name=name,
                spacing=spacing, origin=origin, axes=axes, patient=patient)


class View:
    """The viewer of one dataset in a notebook cell (see view()). `state` is the view; `set(...)` changes it and shows
    the cell again; `snapshot()` is the exact frame of the view as a (height, width, 4) uint8 array."""

    def __init__(self, dataset: Any, server: str, *, token: Optional[str] = None, camera: Any = None,
                 tf: Any = 'grayscale', window: Optional[Sequence[float]] = None, shading: bool = False,
                 quality: str = '', size: Sequence[int] = (512, 512), address: Optional[str] = None,
                 browser_url: Optional[str] = None, ca: Optional[str] = None, insecure: bool = False,
                 name: Optional[str] = None, spacing: Optional[Sequence[float]] = None,
                 origin: Optional[Sequence[float]] = None, axes: Optional[str] = None,
                 patient: Optional[bool] = None):
        self._base, self._token = _http_base(server, token)
        self._tls = {'ca': ca, 'insecure': insecure} if ca is not None or insecure else {}
        self._browser_base = _http_base(browser_url, self._token)[0] if browser_url else self._base
        self._address = address
        self._client: Optional[Client] = None
        self._meta: Optional[Dict[str, Any]] = None
        self._state: Dict[str, Any] = {'dataset': '', 'view': None, 'az': 30.0, 'el': 20.0, 'dist': None,
                                       'pan': [0.0, 0.0], 'tf': 'grayscale', 'points': None, 'window': None,
                                       'shading': False, 'quality': '', 'size': [512, 512]}
        self.id = uuid.uuid4().hex
        self._displayed = False
        upload = {key: value for key, value in dict(spacing=spacing, origin=origin, axes=axes, patient=patient).items()
                  if value is not None}
        meta = None
        if dataset is not None and not isinstance(dataset, str):
            array = dataset
            # The view's arguments are checked before the array is sent: a refused one leaves nothing on the server.
            self._apply(dict(dataset='array', camera=camera, tf=tf, window=window, shading=shading, quality=quality,
                             size=size))
            dataset = f'array-{uuid.uuid4().hex[:12]}' if name is None else name
            meta = self._session().upload(dataset, array, **upload)
        elif name is not None or upload:
            raise ValueError(f'{", ".join(sorted(({"name"} if name is not None else set()) | set(upload)))}: for an '
                             'array sent to the server; dataset names one of its datasets')
        self._apply(dict(dataset=dataset, camera=camera, tf=tf, window=window, shading=shading, quality=quality,
                         size=size))
        self._meta = meta
        _views[self.id] = self

    # The view.

    @property
    def state(self) -> Dict[str, Any]:
        """The view as the viewer holds it: `dataset`; `view` (a named view, or None) or the orbit `az`, `el` (degrees)
        and `dist` (radii, None: fitted); `pan` (the look-at point moved, in radii along screen right and up); `tf` (a
        preset, or "custom" with `points`); `window` ([lo, hi] or None: the dataset's range); `shading`; `quality`;
        `size` [width, height]. In the classic Notebook it follows the mouse in the frame (a few times a second)."""
        return json.loads(json.dumps(self._state))

    @property
    def dataset(self) -> str:
        return self._state['dataset']

    def set(self, *, dataset: Optional[str] = None, camera: Any = None, tf: Any = None,
            window: Union[Sequence[float], str, None] = None, shading: Optional[bool] = None,
            quality: Optional[str] = None, pan: Optional[Sequence[float]] = None,
            size: Optional[Sequence[int]] = None) -> 'View':
        """Changes the view (arguments as view() takes them; window="full" goes back to the dataset's range) and
        shows the cell again with it. Returns the view."""
        self._apply(dict(dataset=dataset, camera=camera, tf=tf, window=window, shading=shading, quality=quality,
                         pan=pan, size=size))
        if self._displayed:
            from IPython.display import HTML, update_display
            update_display(HTML(self._html()), display_id=self.id)
        return self

    @property
    def url(self) -> str:
        """The viewer's address for this view, as the browser opens it (the token included)."""
        params = self._query()
        if self._token:
            params.append(('token', self._token))
        return f'{self._browser_base}/?{urllib.parse.urlencode(params, safe=",;")}'

    def scene(self, meta: Optional[Dict[str, Any]] = None) -> Dict[str, Any]:
        """The scene of the view's exact frame, as the viewer asks it (web/js/view.js, buildScene). A panned view needs
        the dataset's metadata (fetched when not given)."""
        s = self._state
        panned = s['pan'][0] != 0 or s['pan'][1] != 0
        if s['view'] and not panned and s['dist'] is None:
            camera: Dict[str, Any] = {'view': s['view']}
        elif not panned:
            camera = {'orbit': [s['az'], s['el']] + ([] if s['dist'] is None else [s['dist']])}
        else:
            camera = _panned_camera(s, meta if meta is not None else self._dataset_meta(), s['size'])
        scene = {'camera': camera, 'size': list(s['size']),
                 'transfer_function': {'points': s['points']} if s['tf'] == 'custom' else s['tf'],
                 'shading': s['shading']}
        if s['window']:
            scene['window'] = list(s['window'])
        if s['quality']:
            scene['quality'] = s['quality']
        return scene

    def snapshot(self, encoding: str = 'png') -> np.ndarray:
        """The exact frame of the view, (height, width, 4) uint8: rendered by the server through the protocol, the
        frame the viewer shows once the camera rests. ServerError carries the server's words."""
        client = self._session()
        try:
            client.info(self.dataset)
            return client.render(self.dataset, scene=self.scene(client.info()), encoding=encoding)
        except (OSError, ConnectionError):
            self.close()  # the server went away or restarted: connect afresh next time
            raise

    def close(self) -> None:
        """Closes the kernel's session with the server (snapshot opens another when needed)."""
        if self._client is not None:
            self._client.close()
            self._client = None

    # Display.

    def _ipython_display_(self) -> None:
        from IPython.display import HTML, display
        display(HTML(self._html()), display_id=self.id)
        self._displayed = True

    def _repr_html_(self) -> str:
        return self._html()

    def __repr__(self) -> str:
        return f'<voxbrick.View {self.dataset!r} at {self._base}>'

    def _html(self) -> str:
        width, height = self._state['size']
        origin = _origin(self._browser_base)
        # The script asks the viewer for its view (web/js/main.js: "voxbrick-hello") and hands each one it posts to the
        # kernel, where _report keeps it. One listener per page serves every view, by id.
        script = """
(function () {
  var id = %(id)s, origin = %(origin)s;
  var root = document.getElementById("voxbrick-view-" + id);
  var frame = root && root.querySelector("iframe");
  if (!frame) return;
  var views = window.voxbrickViews = window.voxbrickViews || {};
  views[id] = { frame: frame, origin: origin };
  var hello = function () {
    if (frame.contentWindow) frame.contentWindow.postMessage({ type: "voxbrick-hello" }, origin);
  };
  frame.addEventListener("load", hello);
  hello();
  if (window.voxbrickListening) return;
  window.voxbrickListening = true;
  window.addEventListener("message", function (e) {
    if (!e.data || e.data.type !== "voxbrick-view") return;
    for (var key in views) {
      var v = views[key];
      if (v.frame.contentWindow !== e.source || v.origin !== e.origin) continue;
      var kernel = window.IPython && window.IPython.notebook && window.IPython.notebook.kernel;
      if (!kernel) return;
      var report = JSON.stringify({ view: e.data.view, size: e.data.size });
      kernel.execute("import voxbrick.notebook as _voxbrick_nb; _voxbrick_nb._report(" + JSON.stringify(key) +
                     ", " + JSON.stringify(report) + ")", {}, { silent: true, store_history: false });
      return;
    }
  });
})();
""" % {'id': json.dumps(self.id), 'origin': json.dumps(origin)}
        url = html.escape(self.url, quote=True)
        title = html.escape(f'voxbrick viewer: {self.dataset}', quote=True)
        return (f'<div class="voxbrick-view" id="voxbrick-view-{self.id}">'
                f'<iframe src="{url}" title="{title}" width="{width + PANEL_PX}" height="{max(height, 420)}" '
                f'style="border: 1px solid #444; max-width: 100%;" allow="fullscreen"></iframe>'
                f'<div style="font-size: 12px;"><a href="{url}" target="_blank" rel="noopener">{title}</a></div>'
                f'<script>{script}</script></div>')

    # Helpers.

    def _query(self) -> list:
        """The view as the viewer's URL parameters (web/js/view.js, writeView and readView)."""
        s = self._state
        params = [('dataset', s['dataset'])]
        if s['view'] and s['dist'] is None:
            params.append(('view', s['view']))
        else:
            params.append(('orbit', _list([s['az'], s['el']] + ([] if s['dist'] is None else [s['dist']]))))
        if s['pan'][0] or s['pan'][1]:
            params.append(('pan', _list(s['pan'])))
        params.append(('tf', s['tf']))
        if s['tf'] == 'custom':
            params.append(('points', ';'.join(_list(p) for p in s['points'])))
        if s['window']:
            params.append(('window', _list(s['window'])))
        if s['shading']:
            params.append(('shading', '1'))
        if s['quality']:
            params.append(('quality', s['quality']))
        params.append(('size', f'{s["size"][0]}x{s["size"][1]}'))
        return params

    def _apply(self, changes: Dict[str, Any]) -> None:
        """Checks and applies changes to the view; ValueError naming the argument. Nothing changes on an error."""
        s = json.loads(json.dumps(self._state))
        if changes.get('dataset') is not None:
            if not isinstance(changes['dataset'], str) or not changes['dataset']:
                raise ValueError(f'dataset {changes["dataset"]!r}: expected its name')
            if s['dataset'] and changes['dataset'] != s['dataset']:
                s.update(view=None, az=30.0, el=20.0, dist=None, pan=[0.0, 0.0], window=None)  # as the viewer does
            s['dataset'] = changes['dataset']
            self._meta = None
        camera = changes.get('camera')
        if camera is not None:
            if isinstance(camera, str):
                if camera not in NAMED_VIEWS:
                    raise ValueError(f'camera {camera!r}: a named view is one of {", ".join(NAMED_VIEWS)}')
                s.update(view=camera, az=float(NAMED_VIEWS[camera][0]), el=float(NAMED_VIEWS[camera][1]), dist=None)
            elif isinstance(camera, dict) or isinstance(camera, (str, bytes)) or len(camera) not in (2, 3):
                raise ValueError(f'camera {camera!r}: the viewer\'s camera is a named view or an orbit '
                                 '(az, el[, dist]); render other cameras with Client.render')
            else:
                orbit = [_finite(v, 'camera') for v in camera]
                if not -90 <= orbit[1] <= 90:
                    raise ValueError(f'camera {tuple(camera)!r}: elevation in [-90, 90]')
                if len(orbit) == 3 and not MIN_DIST <= orbit[2] <= MAX_DIST:
                    raise ValueError(f'camera {tuple(camera)!r}: distance in [{MIN_DIST}, {MAX_DIST}] radii')
                s.update(view=None, az=orbit[0], el=orbit[1], dist=orbit[2] if len(orbit) == 3 else None)
        tf = changes.get('tf')
        if tf is not None:
            if isinstance(tf, str):
                if not tf or tf == 'custom':
                    raise ValueError(f'tf {tf!r}: a preset name, or a list of [x, r, g, b, a] points')
                s.update(tf=tf, points=None)
            else:
                if isinstance(tf, dict):
                    if set(tf) - {'points', 'name', 'description'}:
                        raise ValueError(f'tf keys {sorted(set(tf) - {"points", "name", "description"})}: the '
                                         'viewer\'s curve has points only')
                    tf = tf.get('points')
                points = tf.tolist() if hasattr(tf, 'tolist') else tf
                if not isinstance(points, (list, tuple)) or not points or any(
                        not isinstance(p, (list, tuple)) or len(p) != 5 for p in points):
                    raise ValueError(f'tf {tf!r}: a list of [x, r, g, b, a] points')
                points = [[_finite(v, 'tf point') for v in p] for p in points]
                if any(not 0 <= v <= 1 for p in points for v in p):
                    raise ValueError('tf points: every number in [0, 1]')
                s.update(tf='custom', points=points)
        window = changes.get('window')
        if isinstance(window, str) and window == 'full':
            s['window'] = None
        elif window is not None:
            if isinstance(window, (str, bytes)) or len(window) != 2:
                raise ValueError(f'window {window!r}: (lo, hi), or "full"')
            lo, hi = (_finite(v, 'window') for v in window)
            if not hi > lo:
                raise ValueError(f'window {tuple(window)!r}: hi must be above lo')
            s['window'] = [lo, hi]
        if changes.get('shading') is not None:
            s['shading'] = bool(changes['shading'])
        if changes.get('quality') is not None:
            q = changes['quality']
            if not isinstance(q, str) or (q and not (q.startswith('psnr:') or q.startswith('ms:'))):
                raise ValueError(f'quality {q!r}: "psnr:DB", "ms:N" or ""')
            s['quality'] = q
        if changes.get('pan') is not None:
            pan = changes['pan']
            if isinstance(pan, (str, bytes)) or len(pan) != 2:
                raise ValueError(f'pan {pan!r}: (right, up) in radii')
            s['pan'] = [_finite(v, 'pan') for v in pan]
        if changes.get('size') is not None:
            size = changes['size']
            if isinstance(size, (str, bytes)) or len(size) != 2 or not all(
                    isinstance(v, (int, np.integer)) and not isinstance(v, bool) and 1 <= v <= 2048 for v in size):
                raise ValueError(f'size {size!r}: (width, height), each 1 to 2048 (the viewer\'s largest side)')
            s['size'] = [int(v) for v in size]
        self._state = s

    def _report(self, report: Dict[str, Any]) -> None:
        """A view the viewer posted (web/js/main.js, tellEmbedder): kept when it reads as one."""
        v, size = report.get('view'), report.get('size')
        if not isinstance(v, dict):
            return
        camera = (v.get('view') if v.get('view') in NAMED_VIEWS and v.get('dist') is None
                  else (v.get('az'), v.get('el')) + (() if v.get('dist') is None else (v.get('dist'),)))
        tf = v.get('points') if v.get('tf') == 'custom' else v.get('tf')
        try:
            self._apply(dict(dataset=v.get('dataset') or None, camera=camera, tf=tf, window=v.get('window') or 'full',
                             shading=v.get('shading'), quality=v.get('quality') or '', pan=v.get('pan'), size=size))
        except (ValueError, TypeError):
            return

    def _session(self) -> Client:
        if self._client is None:
            if self._address is not None:
                self._client = connect(self._address, token=self._token, **self._tls)
            else:
                self._client = connect('ws' + self._base[len('http'):], token=self._token, **self._tls)
        return self._client

    def _dataset_meta(self) -> Dict[str, Any]:
        if self._meta is None:
            self._meta = self._session().info(self.dataset)
        return self._meta


def _report(view_id: str, text: str) -> None:
    """Called in the kernel by the cell's script with a view the viewer posted (JSON text)."""
    target = _views.get(view_id)
    if target is None:
        return
    try:
        report = json.loads(text)
    except ValueError:
        return
    if isinstance(report, dict):
        target._report(report)


def _finite(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) or not math.isfinite(
            value):
        raise ValueError(f'{what}: {value!r} is not a finite number')
    return float(value)


def _list(values: Sequence[float]) -> str:
    return ','.join(repr(float(v)).removesuffix('.0') for v in values)


def _http_base(server: Optional[str], token: Optional[str]) -> tuple:
    """("http://HOST:PORT", token) of the viewer's address; ValueError naming what is wrong."""
    if not isinstance(server, str) or not server.strip():
        raise ValueError(f'server {server!r}: the HTTP port of `voxbrick serve --http`, e.g. "http://127.0.0.1:8080"')
    text = server.strip()
    if '://' not in text:
        text = 'http://' + text
    parts = urllib.parse.urlsplit(text)
    if parts.scheme not in ('http', 'https'):
        raise ValueError(f'server {server!r}: an http:// address (the viewer\'s), not {parts.scheme}://')
    query = urllib.parse.parse_qs(parts.query).get('token')
    if query:
        if token is not None and token != query[0]:
            raise ValueError(f'server {server!r}: its token and token= differ')
        token = query[0]
    try:
        port = parts.port
    except ValueError:
        port = None
    if not parts.hostname or port is None:
        raise ValueError(f'server {server!r}: expected "http://HOST:PORT"')
    host = f'[{parts.hostname}]' if ':' in parts.hostname else parts.hostname
    return f'{parts.scheme}://{host}:{port}', token


def _origin(base: str) -> str:
    """A page's origin as a browser writes it: the default port left out."""
    parts = urllib.parse.urlsplit(base)
    default = {'http': 80, 'https': 443}[parts.scheme]
    host = f'[{parts.hostname}]' if ':' in parts.hostname else parts.hostname
    return f'{parts.scheme}://{host}' + ('' if parts.port == default else f':{parts.port}')


def _panned_camera(s: Dict[str, Any], meta: Dict[str, Any], size: Sequence[int]) -> Dict[str, Any]:
    """eye, center and up of a panned view, as web/js/view.js sceneCamera computes them."""
    rad = math.pi / 180
    az, el = s['az'] * rad, s['el'] * rad
    horizontal = [-math.sin(az), math.cos(az), 0.0]
    direction = [horizontal[0] * math.cos(el), horizontal[1] * math.cos(el), math.sin(el)]
    up = [-horizontal[0] * math.sin(el), -horizontal[1] * math.sin(el), math.cos(el)]
    back = [-d for d in direction]
    right = [back[1] * up[2] - back[2] * up[1], back[2] * up[0] - back[0] * up[2], back[0] * up[1] - back[1] * up[0]]
    center, radius = _world_sphere(meta)
    look = [center[i] + right[i] * s['pan'][0] * radius + up[i] * s['pan'][1] * radius for i in range(3)]
    distance = s['dist'] if s['dist'] is not None else _fit_distance(size[0] / size[1])
    eye = [look[i] + direction[i] * distance * radius for i in range(3)]
    return {'eye': [round(v, 6) for v in eye], 'center': [round(v, 6) for v in look], 'up': [round(v, 6) for v in up]}


def _fit_distance(aspect: float) -> float:
    tan_half = math.tan(15 * math.pi / 180)  # the scene's default field of view, 30 degrees
    return 1.05 / math.sin(math.atan(tan_half * min(1.0, aspect)))


def _world_sphere(meta: Dict[str, Any]) -> tuple:
    """A dataset's world centre and bounding-sphere radius (web/js/view.js, worldSphere)."""
    if meta.get('kind') == 'tet-mesh' and isinstance(meta.get('bounds'), list):
        lo, hi = meta['bounds']
        return [(a + b) / 2 for a, b in zip(lo, hi)], math.dist(lo, hi) / 2
    dims = meta.get('dims') or [1, 1, 1]
    spacing = meta.get('spacing') or [1, 1, 1]
    radius = math.hypot(*(n * d for n, d in zip(dims, spacing))) / 2
    o = meta.get('orientation') or {}
    axes = o.get('axes') or [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    origin = o.get('origin') or [0, 0, 0]
    if not o.get('patient') and axes == [[1, 0, 0], [0, 1, 0], [0, 0, 1]] and list(origin) == [0, 0, 0]:
        return [0.0, 0.0, 0.0], radius
    center = list(origin)
    for k in range(3):
        center = [center[i] + axes[k][i] * (dims[k] - 1) / 2 * spacing[k] for i in range(3)]
    return center, radius
