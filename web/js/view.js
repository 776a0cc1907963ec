// The viewer's view: camera, transfer function, window, shading and quality; how it is written to and read from
// the page's URL, and the one place that turns it into a scene (PROTOCOL.md section 6) for a still or a moving
// camera.

/// The named views of the scene's camera.view, with the orbit each stands for (about +z).
export const NAMED_VIEWS = {
  anterior: [0, 0],
  posterior: [180, 0],
  left: [90, 0],
  right: [270, 0],
  superior: [180, 90],
  inferior: [0, -90],
};

/// The transfer-function presets every server has built in (the page lists the server's own, from /presets.json,
/// once it has them: a server's configuration may add or retune presets).
export const PRESETS = ["grayscale", "ct-bone", "hot", "mri", "sparse"];

/// The dataset the address's `dataset=` most likely means among `names`, and whether it is safe to open it in its
/// place: the same name but for case, or the one name that is it plus an extension ("mri" for "mri.vbs"), is
/// opened; a name a few edits away is only suggested. null when nothing is close.
export function closestDataset(wanted, names) {
  const w = wanted.toLowerCase();
  const same = names.filter((n) => n.toLowerCase() === w || n.toLowerCase().startsWith(`${w}.`));
  if (same.length === 1) return { name: same[0], open: true };
  // As the server's own suggestions (common/Names): at most max(2, a third of the name) edits, and no tie.
  let best = null;
  let bestDistance = Math.max(2, Math.floor(w.length / 3)) + 1;
  let tie = false;
  for (const n of names) {
    const l = n.toLowerCase();
    const d = Math.min(editDistance(w, l), editDistance(w, l.replace(/\.[^.]*$/, "")));
    if (d < bestDistance) [best, bestDistance, tie] = [n, d, false];
    else if (d === bestDistance) tie = true;
  }
  if (tie) best = null;
  return best ? { name: best, open: false } : null;
}

/// Levenshtein distance.
function editDistance(a, b) {
  let row = Array.from({ length: b.length + 1 }, (_, j) => j);
  for (let i = 1; i <= a.length; ++i) {
    const next = [i];
    for (let j = 1; j <= b.length; ++j)
      next[j] = Math.min(row[j] + 1, next[j - 1] + 1, row[j - 1] + (a[i - 1] === b[j - 1] ? 0 : 1));
    row = next;
  }
  return row[b.length];
}

/// The curve a custom transfer function starts from: a grey ramp with opacity rising over the upper window.
export const DEFAULT_POINTS = [
  [0, 0, 0, 0, 0],
  [0.3, 0.3, 0.3, 0.3, 0],
  [1, 1, 1, 1, 0.6],
];

export const FOV_DEG = 30; // the scene's default camera.fov, which the page never changes
const FIT_MARGIN = 1.05; // render/core Camera::kFitMargin
export const MIN_DIST = 0.2;
export const MAX_DIST = 50;

/// A fresh view of a dataset: the scene's default orbit, fitted; the default transfer function and window.
export function defaultView(dataset = "") {
  return {
    dataset,
    view: null, // a named view while the camera is exactly it
    az: 30,
    el: 20,
    dist: null, // bounding-sphere radii; null: fitted by the server
    pan: [0, 0], // the look-at point moved by this many radii along screen right and screen up
    tf: "grayscale", // a preset name, or "custom" for `points`
    points: DEFAULT_POINTS.map((p) => p.slice()),
    window: null, // [lo, hi] raw values; null: the dataset's value range
    shading: false,
    quality: "", // "psnr:DB" or "ms:N"; "": none
  };
}

/// The fitted distance in radii for a frame of `aspect` (width / height), as the server computes it.
export function fitDistance(aspect) {
  const tanHalf = Math.tan((FOV_DEG / 2) * (Math.PI / 180));
  return FIT_MARGIN / Math.sin(Math.atan(tanHalf * Math.min(1, aspect)));
}

/// The distance the view stands at, in radii.
export const distanceOf = (view, aspect) => view.dist ?? fitDistance(aspect);

/// World units of the plane through the look-at point per pixel of a frame `height` high, in radii.
export const radiiPerPixel = (view, aspect, height) =>
  (2 * distanceOf(view, aspect) * Math.tan((FOV_DEG / 2) * (Math.PI / 180))) / Math.max(1, height);

const add = (a, b) => a.map((v, i) => v + b[i]);
const scale = (a, s) => a.map((v) => v * s);
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const round = (v, digits = 4) => Number(v.toFixed(digits));

const IDENTITY = [
  [1, 0, 0],
  [0, 1, 0],
  [0, 0, 1],
];
const sameVectors = (a, b) => a.every((row, i) => row.every((v, j) => v === b[i][j]));

/// The world centre and bounding-sphere radius of a dataset from its DatasetInfo meta_json (PROTOCOL.md section 4):
/// a grid's box of dims x spacing placed by its orientation, or a mesh's bounds. A grid whose orientation is the
/// default one (identity axes, origin 0, no patient frame: nothing was stated) lies centred on the origin, as the
/// renderer's world frame (render/core/WorldFrame) places it.
export function worldSphere(meta) {
  if (meta.kind === "tet-mesh" && Array.isArray(meta.bounds)) {
    const [lo, hi] = meta.bounds;
    const center = lo.map((v, i) => (v + hi[i]) / 2);
    return { center, radius: Math.hypot(...hi.map((v, i) => v - lo[i])) / 2 };
  }
  const dims = meta.dims || [1, 1, 1];
  const spacing = meta.spacing || [1, 1, 1];
  const radius = Math.hypot(...dims.map((n, i) => n * spacing[i])) / 2;
  const o = meta.orientation || {};
  const axes = o.axes || IDENTITY;
  const origin = o.origin || [0, 0, 0];
  if (!o.patient && sameVectors(axes, IDENTITY) && sameVectors([origin], [[0, 0, 0]]))
    return { center: [0, 0, 0], radius };
  let center = origin;
  for (let k = 0; k < 3; ++k) center = add(center, scale(axes[k], ((dims[k] - 1) / 2) * spacing[k]));
  return { center, radius };
}

/// The scene's camera for `view`: a named view, an orbit (fitted or at a distance), or, once panned, eye, centre
/// and up in world coordinates built from the same orbit about +z (front +y, side -x).
export function sceneCamera(view, meta, aspect) {
  const panned = view.pan[0] !== 0 || view.pan[1] !== 0;
  if (view.view && !panned && view.dist === null) return { view: view.view };
  if (!panned) return { orbit: view.dist === null ? [view.az, view.el] : [view.az, view.el, view.dist] };
  const rad = Math.PI / 180;
  const [az, el] = [view.az * rad, view.el * rad];
  const horizontal = [-Math.sin(az), Math.cos(az), 0]; // cos az * front + sin az * side
  const dir = add(scale(horizontal, Math.cos(el)), [0, 0, Math.sin(el)]);
  const up = add(scale(horizontal, -Math.sin(el)), [0, 0, Math.cos(el)]);
  const right = cross(scale(dir, -1), up);
  const { center, radius } = worldSphere(meta);
  const lookAt = add(center, add(scale(right, view.pan[0] * radius), scale(up, view.pan[1] * radius)));
  const eye = add(lookAt, scale(dir, distanceOf(view, aspect) * radius));
  return { eye: eye.map((v) => round(v, 6)), center: lookAt.map((v) => round(v, 6)), up: up.map((v) => round(v, 6)) };
}

/// The keys a scene may carry for a moving camera, tried in this order of preference: the server refuses keys it
/// does not know (InvalidScene naming the key), and the viewer then drops that key for the session.
export const MOTION_KEYS = ["interactive", "time_budget_ms", "provisional_encoding", "progressive", "keyframe"];
/// Every scene key buildScene may send, a camera's as "camera.KEY". tests/browser/scene_keys.test.mjs holds each to
/// the scene's schema (`voxbrick scene --schema`) and every scene buildScene makes to this list.
export const SCENE_KEYS = [
  "camera.view",
  "camera.orbit",
  "camera.eye",
  "camera.center",
  "camera.up",
  "size",
  "transfer_function",
  "shading",
  "window",
  "quality",
  ...MOTION_KEYS,
  "accepts_webp",
  "accepts_vp9_444",
  "jpeg_quality",
];
/// The JPEG quality the address asks of moving frames (`jpeg_quality`: a whole number from 1 to 100), else 0 (the
/// server's own).
export function jpegQualityOf(text) {
  const q = Number(text);
  return Number.isInteger(q) && q >= 1 && q <= 100 ? q : 0;
}

/// The time budget of a provisional frame while dragging, in milliseconds: with one frame drawn at a time, at best about
/// twenty frames a second (the server's own default, 100 ms, is ten).
export const DRAG_TIME_BUDGET_MS = 50;

/// The scene of a Render: `phase` "drag" while the camera moves, "still" otherwise. `features` says which optional
/// keys the server took (`interactive`, `time_budget_ms`, `provisional_encoding`, `progressive`, `keyframe`: true
/// until refused), whether it offers jpeg, `video`: the video codec ("vp8" or "vp9") the server offers and the
/// browser decodes, or null, `accepts_vp9_444` (a vp9 stream may be 4:4:4: the server speaks version 9 and the browser
/// decodes it), `webp` ("auto": ask `accepts_webp`, while `accepts_webp` is not refused) and `jpeg_quality` (the
/// moving frames' JPEG quality, 0: the server's).
/// `ask.keyframe`: the video decoder waits for a key frame. This is the one place that picks how frames are made.
export function buildScene(view, meta, size, phase, features, ask = {}) {
  const scene = {
    camera: sceneCamera(view, meta, size[0] / size[1]),
    size,
    transfer_function: view.tf === "custom" ? { points: view.points } : view.tf,
    shading: view.shading,
  };
  if (view.window) scene.window = view.window;
  if (view.quality) scene.quality = view.quality;
  if (phase === "drag" && features.interactive) {
    // A provisional frame within the time budget, then (when the camera rests) the exact frame of the same id.
    scene.interactive = true;
    if (features.time_budget_ms) scene.time_budget_ms = DRAG_TIME_BUDGET_MS;
  } else if (features.progressive) {
    // Bricks not yet in memory stand in from a coarser level; the exact frame follows.
    scene.progressive = true;
  }
  // While the camera moves, provisional frames travel as the session's video stream (protocol version 4: inter frames
  // carry what changed, a fraction of a jpeg's bytes), or as jpeg where the browser decodes none of the server's
  // codecs; the exact frame keeps the Render's encoding (png).
  if (phase === "drag" && features.provisional_encoding) {
    if (features.video) {
      scene.provisional_encoding = features.video;
      if (ask.keyframe && features.keyframe) scene.keyframe = true;
      // VP9 with colour at every pixel: about a quarter fewer bytes for the same picture (protocol version 9).
      if (features.video === "vp9" && features.accepts_vp9_444) scene.accepts_vp9_444 = true;
    } else if (features.jpeg) {
      scene.provisional_encoding = "jpeg";
    }
    // The address's JPEG quality: for moving frames sent as jpeg (also a video stream's where the server falls back).
    if (features.jpeg_quality) scene.jpeg_quality = features.jpeg_quality;
  }
  // Png frames may come as lossless webp (protocol version 7), which the server sends while it finds the link slow:
  // the same pixels in about 0.6 of the bytes, for longer encoding.
  if (features.webp === "auto" && features.accepts_webp) scene.accepts_webp = true;
  return scene;
}

const list = (v) => v.map((x) => round(x)).join(",");
const numbers = (text, n) => {
  const v = (text || "").split(",").map(Number);
  return v.length === n && v.every(Number.isFinite) ? v : null;
};

/// Writes `view` into `params` (URLSearchParams), keeping every other parameter (token, server, size).
export function writeView(view, params) {
  for (const k of ["dataset", "view", "orbit", "pan", "tf", "points", "window", "shading", "quality"]) params.delete(k);
  if (view.dataset) params.set("dataset", view.dataset);
  if (view.view && view.dist === null) params.set("view", view.view);
  else params.set("orbit", list(view.dist === null ? [view.az, view.el] : [view.az, view.el, view.dist]));
  if (view.pan[0] || view.pan[1]) params.set("pan", list(view.pan));
  params.set("tf", view.tf);
  if (view.tf === "custom") params.set("points", view.points.map((p) => list(p)).join(";"));
  if (view.window) params.set("window", view.window.map((x) => String(x)).join(","));
  if (view.shading) params.set("shading", "1");
  if (view.quality) params.set("quality", view.quality);
  return params;
}

/// The view a URL's parameters describe; what is missing or unreadable keeps the default.
export function readView(params) {
  const v = defaultView(params.get("dataset") || "");
  const named = params.get("view");
  if (named && NAMED_VIEWS[named]) [v.view, v.az, v.el] = [named, ...NAMED_VIEWS[named]];
  const orbit = numbers(params.get("orbit"), 3) || numbers(params.get("orbit"), 2);
  if (orbit) {
    [v.view, v.az, v.el] = [null, orbit[0], orbit[1]];
    if (orbit.length === 3 && orbit[2] > 0) v.dist = Math.min(MAX_DIST, Math.max(MIN_DIST, orbit[2]));
  }
  v.pan = numbers(params.get("pan"), 2) || v.pan;
  const tf = params.get("tf");
  if (tf) v.tf = tf;
  if (tf === "custom") {
    const pts = (params.get("points") || "").split(";").map((p) => numbers(p, 5));
    if (pts.length && pts.every((p) => p && p.every((x) => x >= 0 && x <= 1))) v.points = pts;
  }
  const w = numbers(params.get("window"), 2);
  if (w && w[1] > w[0]) v.window = w;
  v.shading = params.get("shading") === "1";
  v.quality = params.get("quality") || "";
  return v;
}
