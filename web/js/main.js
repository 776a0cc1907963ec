// The viewer page: connects to the server's /ws, lists and opens datasets, turns the controls and gestures into the
// view, keeps the view in the URL, reconnects with backoff when the server goes away, and exposes a small hook for
// tests (window.voxbrickViewer).

import {Connection} from './connection.js';
import {FrameLoop} from './frames.js';
import {attachGestures} from './input.js';
import {bindPanel} from './panel.js';
import {Encoding, encodingName, ErrorCode, retryAfterMs, withoutRetryHint} from './protocol.js';
import {CurveEditor} from './tfeditor.js';
import {takeToken} from './token.js';
import {decodesVp9FullChroma, pickVideoCodec} from './video.js';
import * as V from './view.js';

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
/// The access token, out of the address from here on and kept in memory only (token.js).
const accessToken = takeToken(params);
const MAX_SIDE = 2048; // the largest frame side the page asks for, whatever the screen
const BACKOFF_MS = [500, 1000, 2000, 4000, 8000];

/// The fixed frame size of `?size=WxH`, or null: the canvas element's size times devicePixelRatio.
const fixedSize = (() => {
  const m = /^(\d+)x(\d+)$/.exec(params.get("size") || "");
  return m ? [Math.max(1, Math.min(MAX_SIDE, +m[1])), Math.max(1, Math.min(MAX_SIDE, +m[2]))] : null;
})();

const app = {
  view: V.readView(params),
  meta: null, // the open dataset's meta_json
  datasets: [],
  presets: null, // the server's presets: {name: points}
  capabilities: null,
  connection: null,
  state: "connecting", // connecting | ready | disconnected | refused | busy | idle
  reason: "",
  attempts: 0,
  reconnectTimer: 0,
  retryMs: 0, // the wait before the next connection attempt (the server's Busy hint when it gave one)
  features: {
    interactive: true,
    time_budget_ms: true,
    provisional_encoding: true,
    progressive: true,
    keyframe: true,
    jpeg: false,
    video: null, // "vp8" or "vp9": the video codec the server offers and this browser decodes (checked at connect)
    // Lossless frames as webp: null (the server has no webp, or `lossless=png`), "auto" (scene key accepts_webp: the
    // server sends webp where it measures the link slow), "always" (`lossless=webp`: every exact frame as webp).
    webp: null,
    accepts_webp: true, // until refused
    // A vp9 stream in 4:4:4 (scene key accepts_vp9_444): the stream is vp9, the server speaks version 9, this browser
    // decodes VP9's profile 1 and the address does not say `chroma=420`; false once refused.
    accepts_vp9_444: false,
    // The JPEG quality of moving frames sent as jpeg (scene key jpeg_quality, from the address's `jpeg_quality`: 1 to
    // 100); 0: the server's own (85, or loaded_jpeg_quality under a crowd); false once refused.
    jpeg_quality: V.jpegQualityOf(params.get("jpeg_quality")),
  },
  dragging: false,
  notes: [],
  opening: "", // the dataset asked for last (a Busy answer is retried while it still is)
  renderBusy: false, // the banner says a Render was answered Busy (until a frame shows)
};

// The server's status page carries the page's token (and server) on, as /ws does.
const statusLink = new URL("status.html", location.href);
statusLink.search = "";
if (accessToken) statusLink.searchParams.set("token", accessToken);
if (params.get("server")) statusLink.searchParams.set("server", params.get("server"));
$("status-link").href = statusLink.pathname + statusLink.search;

const canvas = $("frame");
const loop = new FrameLoop(canvas, {
  scene: (phase, ask) =>
    app.state === "ready" && app.meta ? V.buildScene(app.view, app.meta, frameSize(), phase, app.features, ask) : null,
  encoding: () => (app.features.webp === "always" ? Encoding.webp : Encoding.png),
  refused: refusedScene,
  shown: () => {
    if (app.renderBusy) {
      app.renderBusy = false;
      banner("");
    }
    drawOverlay();
  },
  failed: (e) => note(`${e.name}: ${e.message}`),
  // A Render answered Busy: the server takes no more dragging sessions now (or a quota is spent). Said until the next
  // frame shows; the page asks again after the hint.
  busy: (e, ms) => {
    app.renderBusy = true;
    banner(`The server is busy: ${withoutRetryHint(e.message)}. Asking again in ${(ms / 1000).toFixed(1)} s…`);
  },
});

function frameSize() {
  if (fixedSize) return fixedSize.slice();
  const cap = Math.min(MAX_SIDE, app.capabilities ? app.capabilities.maxImageSide : MAX_SIDE);
  const dpr = Math.min(window.devicePixelRatio || 1, 2);
  let [w, h] = [Math.round(canvas.clientWidth * dpr), Math.round(canvas.clientHeight * dpr)];
  const over = Math.max(w, h) / cap;
  if (over > 1) [w, h] = [Math.floor(w / over), Math.floor(h / over)];
  return [Math.max(1, w), Math.max(1, h)];
}

function fitCanvas() {
  const [w, h] = frameSize();
  if (canvas.width !== w || canvas.height !== h) {
    [canvas.width, canvas.height] = [w, h];
    // Mid-drag, the frames of the new size keep moving (a video stream goes on with a key frame of the new size).
    loop.want(app.dragging ? "drag" : "still");
  }
}

/// A scene key the server refused: a motion key it does not know is dropped for the session; a quality target the
/// dataset has no table for is cleared with a note. True when the page changed what it asks. The server names an
/// unknown key as "unknown key 'NAME'" and a bad value by its quoted key.
function refusedScene(error) {
  const unknown = /unknown key '([^']+)'/.exec(error.message);
  const names = (key) => (unknown ? unknown[1] === key : error.message.includes(`'${key}'`));
  if (app.features.video && !unknown && names("provisional_encoding")) {
    // The server would not send this scene as video: moving frames go back to jpeg.
    note(`${app.features.video} refused (${error.message}): moving frames as jpeg`);
    app.features.video = null;
    return true;
  }
  for (const key of [...V.MOTION_KEYS, "accepts_webp", "accepts_vp9_444", "jpeg_quality"]) {
    if (app.features[key] && names(key)) {
      app.features[key] = false;
      return true;
    }
  }
  if (app.view.quality && (names("quality") || error.message.includes("quality table"))) {
    panel.qualityRefused(error.message);
    app.view.quality = "";
    viewChanged("still", false);
    return true;
  }
  note(`InvalidScene: ${error.message}`);
  return false;
}

function note(text) {
  app.notes.push(text);
  if (app.notes.length > 20) app.notes.shift();
  drawOverlay();
}

function drawOverlay() {
  const f = loop.figures();
  const ms = (v) => (v === null || v === undefined ? "–" : `${v.toFixed(0)} ms`);
  const ms1 = (v) => (v === null || v === undefined ? "–" : `${v.toFixed(1)} ms`);
  const lines = [];
  if (f.last) {
    const kind = f.last.provisional ? "provisional" : "exact";
    lines.push(`${f.fps} fps   ${f.last.width}×${f.last.height} ${encodingName(f.last.encoding)} ${kind}`);
    lines.push(`latency ${ms(f.last.latencyMs)}  p50 ${ms(f.p50)}  p99 ${ms(f.p99)}`);
    lines.push(
      `${(f.last.bytes / 1024).toFixed(1)} KiB/frame   decode ${ms1(f.last.decodeMs)}   render ${ms(f.last.renderMs)}` +
        `   stand-ins ${f.last.standin}`,
    );
  } else {
    lines.push("no frame yet");
  }
  // How moving frames travel: the video stream (its bitrate, set by the server from the link) or jpeg.
  const v = f.video;
  if (app.features.video)
    lines.push(
      `moving: ${v.codec || app.features.video}` +
        (v.bitrateKbps ? `  ${v.bitrateKbps} kbit/s` : "") +
        (v.scale !== null && v.scale < 1 ? `  at ${Math.round(v.scale * 100)} % size (${smallerBecause(v.scaledFor)})` : "") +
        `  decode ${ms1(v.lastDecodeMs)}  key frames ${v.keyFrames}` +
        (v.skipped || v.errors ? `  skipped ${v.skipped}  errors ${v.errors}` : "") +
        (f.last && f.last.videoFallback === "memory" ? "  (jpeg now: the server's video memory is full)" : ""),
    );
  else if (app.capabilities) {
    // From protocol version 8 a moving frame comes at the size it was drawn, and is shown scaled.
    const drawn = f.last && f.last.provisional && f.last.width < canvas.width ? f.last.width / canvas.width : null;
    lines.push(
      `moving: ${app.features.jpeg ? "jpeg" : "png"}` +
        (drawn ? `  drawn at ${Math.round(drawn * 100)} % size (to keep its frame rate)` : ""),
    );
  }
  if (app.notes.length) lines.push(app.notes[app.notes.length - 1]);
  $("overlay").textContent = lines.join("\n");
}

/// Why the server sends the video stream smaller than the view (the frame's `video.scaled_for`).
function smallerBecause(scaledFor) {
  if (scaledFor === "encoders") return "the server's encoders are busy";
  if (scaledFor === "link") return "the link is slow";
  if (scaledFor === "memory") return "the server's video memory is shared";
  if (scaledFor === "drawing") return "drawn smaller to keep its frame rate";
  return "smaller stream";
}

function banner(text, kind) {
  const b = $("banner");
  b.hidden = !text;
  b.textContent = text || "";
  b.className = kind || "";
}

let urlTimer = 0;
/// The view changed: ask for a frame and write the URL (at most every 250 ms).
function viewChanged(phase = "still", ask = true) {
  wake();
  if (ask) loop.want(phase);
  if (!urlTimer)
    urlTimer = setTimeout(() => {
      urlTimer = 0;
      history.replaceState(null, "", `${location.pathname}?${V.writeView(app.view, params)}`);
      tellEmbedder();
    }, 250);
}

// Embedded in another page (a notebook's output cell, docs/python.md): the page holding the frame may ask for the view
// by posting {type: "voxbrick-hello"}; from then on the viewer posts {type: "voxbrick-view", view, query, size} to that
// page's origin alone, at once and whenever the view changes (as often as the URL is written). `query` is the view as
// URL parameters (writeView's, without the token). A page that did not ask, or one of an opaque origin, gets nothing.
let embedder = null;
window.addEventListener("message", (e) => {
  if (window.parent === window || e.source !== window.parent || e.origin === "null") return;
  if (!e.data || e.data.type !== "voxbrick-hello") return;
  embedder = e.origin;
  tellEmbedder();
});

function tellEmbedder() {
  if (!embedder) return;
  const view = JSON.parse(JSON.stringify(app.view));
  const query = V.writeView(app.view, new URLSearchParams()).toString();
  window.parent.postMessage({ type: "voxbrick-view", view, query, size: frameSize() }, embedder);
}

/// The server's transfer-function presets with their curves (GET /presets.json, behind the same token as /ws); the
/// page keeps its built-in list of names if the server cannot say.
async function loadPresets() {
  try {
    const url = wsUrl().replace(/^ws/, "http").replace(/\/ws(\?|$)/, "/presets.json$1");
    const r = await fetch(url, { cache: "no-store" });
    if (!r.ok) throw new Error(`HTTP ${r.status}`);
    const list = await r.json();
    app.presets = Object.fromEntries(list.map((p) => [p.name, p.points]));
    panel.presets(app.presets);
  } catch (e) {
    note(`The server's presets could not be read (${e.message}): the curve shows custom curves only`);
  }
}

/// How exact frames travel (the address's `lossless`): "always" webp (`webp`), "auto" (absent or `auto`: png, or webp
/// where the server finds the link slow), or null (`png`, or a server without webp: always png).
function losslessWebp(encodings, asked) {
  if (!encodings.includes(Encoding.webp) || asked === "png") return null;
  return asked === "webp" ? "always" : "auto";
}

/// Saves the frame on the canvas as a PNG: the server's own bytes when the frame shown is its exact PNG, else the
/// canvas (an exact webp frame, whose pixels the canvas holds unchanged; a provisional jpeg or video frame, decoded).
function saveFrame() {
  const f = loop.lastFrame;
  const v = app.view;
  const where = v.view || `${Math.round(v.az)}_${Math.round(v.el)}`;
  const name = `voxbrick-${(v.dataset || "frame").replace(/[^\w.-]+/g, "_")}-${where}.png`;
  const download = (blob) => {
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = name;
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(a.href), 10000);
  };
  if (f && !f.provisional && f.encoding === Encoding.png && loop.lastPayload)
    download(new Blob([loop.lastPayload], { type: "image/png" }));
  else canvas.toBlob((blob) => blob && download(blob), "image/png");
  return name;
}

function wsUrl() {
  const host = params.get("server") || location.host;
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  return `${scheme}://${host}/ws${accessToken ? `?token=${encodeURIComponent(accessToken)}` : ""}`;
}

function connect() {
  clearTimeout(app.reconnectTimer);
  app.state = "connecting";
  banner(app.attempts ? `Reconnecting to the server (attempt ${app.attempts + 1})…` : "Connecting…", "connecting");
  const c = new Connection(wsUrl(), {
    onReady: (caps) => greeted(c, caps),
    onReply: (m) => c === app.connection && loop.reply(m),
    onClose: (info) => c === app.connection && closed(info),
  });
  app.connection = c;
  loop.attach(null);
}

async function greeted(c, caps) {
  app.capabilities = caps;
  app.features.jpeg = caps.encodings.includes(Encoding.jpeg);
  app.features.webp = losslessWebp(caps.encodings, params.get("lossless"));
  // Which video codec this browser decodes is asked while the datasets are listed; known before the first drag.
  const video = pickVideoCodec(caps.encodings, params.get("video"));
  const fullChroma = caps.version >= 9 && params.get("chroma") !== "420" ? decodesVp9FullChroma() : false;
  loadPresets();
  try {
    app.datasets = await c.listDatasets();
    // A PACS's series are named by their UIDs: the Stats say what each holds, for the list's labels.
    const pacs = app.datasets.some((n) => /\.\d+(\.\d+)+$/.test(n))
      ? await c.getStats().then((s) => s.pacs || [], () => [])
      : [];
    panel.datasets(app.datasets, pacs);
    if (!app.datasets.length) throw new Error("the server offers no dataset");
    const wanted = app.view.dataset;
    if (wanted && !app.datasets.includes(wanted)) {
      // The address names a dataset this server does not have: say so, open the likeliest or the first, and keep
      // the rest of the address's view (orbit, transfer function, window, shading).
      const guess = V.closestDataset(wanted, app.datasets);
      const opened = guess && guess.open ? guess.name : app.datasets[0];
      const suggest = guess && !guess.open ? ` Did you mean “${guess.name}”?` : "";
      panel.datasetNote(
        `No dataset “${wanted}” on this server; showing “${opened}”.${suggest} ` +
          `It has: ${app.datasets.map((n) => `“${n}”`).join(", ")}.`,
      );
      app.view.dataset = opened;
    }
    const name = app.view.dataset || app.datasets[0];
    app.features.video = await video;
    app.features.accepts_vp9_444 = app.features.video === "vp9" && (await fullChroma);
    await openDataset(c, name);
    app.attempts = 0;
  } catch (e) {
    if (c === app.connection) banner(`${e.name || "Error"}: ${e.message}`);
  }
}

async function openDataset(c, name) {
  // A dataset the server is still making (a PACS series being fetched) is answered Busy with where it stands: say
  // so, and ask again after the server's hint, as long as this is still the dataset wanted.
  app.opening = name;
  let info;
  for (;;) {
    try {
      info = await c.openDataset(name);
      break;
    } catch (e) {
      const wait = e.code === ErrorCode.Busy ? retryAfterMs(e.message) : null;
      if (wait === null || c !== app.connection || app.opening !== name) throw e;
      banner(`${withoutRetryHint(e.message)}…`);
      await new Promise((resolve) => setTimeout(resolve, wait));
      if (c !== app.connection || app.opening !== name) return;
    }
  }
  if (c !== app.connection) return;
  app.meta = JSON.parse(info.metaJson);
  if (app.view.dataset !== name) {
    // Another dataset: its own camera and window; the transfer function and shading stay.
    const fresh = V.defaultView(name);
    Object.assign(app.view, { ...fresh, tf: app.view.tf, points: app.view.points, shading: app.view.shading });
  }
  app.state = "ready";
  app.reason = "";
  banner("");
  panel.opened(app.meta);
  loop.attach(c);
  fitCanvas();
  viewChanged("still");
}

async function closed(info) {
  app.meta = null;
  loop.attach(null);
  canvas.style.opacity = "0.35";
  const idle = info.opened && app.connection.lastError && app.connection.lastError.name === "Timeout";
  if (idle) {
    // The server closes sessions idle for its idle timeout: reconnect when the person comes back, not in a loop.
    app.state = "idle";
    app.reason = info.reason;
    banner("The server closed this idle session. Drag, scroll or use a control to reconnect.", "connecting");
    return;
  }
  const cross = params.get("server") && params.get("server") !== location.host;
  let why = info.reason;
  if (!info.opened) {
    // The upgrade was refused or nobody listens. The page's own server says which over plain HTTP.
    why = cross
      ? `the server at ${params.get("server")} cannot be reached or refuses this page's origin (${location.origin})`
      : await refusalReason();
  }
  // A server over capacity answers the Hello Busy with when to come back: the page waits that long (a fifth more at
  // most, drawn at random, so that pages refused together do not all return in the same instant), not its backoff.
  const last = app.connection.lastError;
  const hint = last && last.code === ErrorCode.Busy ? retryAfterMs(last.message) : null;
  const refused = !info.opened && !why.startsWith("the server cannot be reached");
  app.state = hint !== null ? "busy" : refused || /origin|token/i.test(why) ? "refused" : "disconnected";
  app.reason = why;
  const backoff = BACKOFF_MS[Math.min(app.attempts, BACKOFF_MS.length - 1)];
  const delay = hint !== null ? Math.round(hint * (1 + 0.2 * Math.random())) : backoff;
  app.retryMs = delay;
  app.attempts++;
  if (hint !== null) {
    banner(`The server is busy: ${withoutRetryHint(last.message)}. Retrying in ${(delay / 1000).toFixed(1)} s…`);
  } else {
    const title = app.state === "refused" ? "Refused by the server" : "Disconnected from the server";
    banner(`${title}: ${why}. Retrying in ${(delay / 1000).toFixed(1)} s…`);
  }
  app.reconnectTimer = setTimeout(connect, delay);
}

/// A person is back at a page whose idle session the server closed: connect again (the view is kept).
function wake() {
  if (app.state === "idle") connect();
}
document.addEventListener("visibilitychange", () => document.visibilityState === "visible" && wake());

/// Why the page's own server refused /ws. A browser does not show a refused upgrade's answer to the page, so the page
/// asks for /ws again over plain HTTP: nothing answers (the server is gone), the server says why (a 4xx with its
/// text), or it answers that /ws is for WebSockets only (426). As the page is the server's own, its origin is
/// allowed, and the refusal is then the access token's.
async function refusalReason() {
  let r;
  try {
    r = await fetch(wsUrl().replace(/^ws/, "http"), { cache: "no-store" });
  } catch {
    return "the server cannot be reached";
  }
  const text = (await r.text().catch(() => "")).trim().slice(0, 200);
  if (r.status !== 426) return `HTTP ${r.status}${text ? `: ${text}` : ""}`;
  return accessToken
    ? "the access token this page was opened with (?token=...) is wrong"
    : "the server wants an access token: open the address it printed, with ?token=...";
}

const curve = new CurveEditor($("curve"), (points, done) => {
  Object.assign(app.view, { tf: "custom", points });
  panel.syncTf();
  viewChanged(done ? "still" : "drag");
});

const panel = bindPanel({
  view: app.view,
  changed: viewChanged,
  openDataset: (name) => {
    if (app.state !== "ready") return;
    const before = app.view.dataset;
    app.view.dataset = "";
    loop.attach(null);
    openDataset(app.connection, name).catch((e) => {
      // Still on the dataset open before (an unknown name leaves the session as it was).
      note(`${e.name}: ${e.message}`);
      app.view.dataset = before;
      panel.opened(app.meta);
      loop.attach(app.connection);
    });
  },
  save: saveFrame,
  curve,
});

const gestures = {
  begin: () => {
    wake();
    app.dragging = loop.dragging = true;
    app.view.view = null;
    panel.syncView();
  },
  orbit: (dAz, dEl) => {
    const v = app.view;
    v.az = ((((v.az + dAz) % 360) + 540) % 360) - 180;
    v.el = Math.max(-90, Math.min(90, v.el + dEl));
    viewChanged("drag");
  },
  pan: (dx, dy) => {
    const [w, h] = [canvas.width, canvas.height];
    const per = V.radiiPerPixel(app.view, w / h, h) * (h / Math.max(1, canvas.clientHeight));
    app.view.pan = [app.view.pan[0] - dx * per, app.view.pan[1] + dy * per];
    viewChanged("drag");
  },
  zoom: (factor) => {
    const v = app.view;
    v.view = null;
    v.dist = Math.max(V.MIN_DIST, Math.min(V.MAX_DIST, V.distanceOf(v, canvas.width / canvas.height) * factor));
    viewChanged(app.dragging ? "drag" : "still");
  },
  wheel: () => {},
  end: () => {
    app.dragging = loop.dragging = false;
    loop.released();
    viewChanged("still", false);
  },
};
attachGestures(canvas, gestures);

new ResizeObserver(() => fitCanvas()).observe(canvas);
if (fixedSize) canvas.classList.add("fixed");
setInterval(drawOverlay, 500);
window.addEventListener("beforeunload", () => app.connection && app.connection.close());

/// A canvas's (or an OffscreenCanvas') pixels as base64 of RGBA rows, top first.
function pixelsOf(source) {
  const d = source.getContext("2d").getImageData(0, 0, source.width, source.height, { colorSpace: "srgb" });
  return { width: d.width, height: d.height, rgba: base64(d.data) };
}
/// The test hook's copies of the canvas (snapshot).
const snapshots = [];

function base64(bytes) {
  let s = "";
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

// The test hook: what the page shows and asks, so tests and benchmarks need no guessing.
window.voxbrickViewer = {
  state: () => ({
    connection: app.state,
    reason: app.reason,
    retryMs: app.retryMs,
    attempts: app.attempts,
    banner: $("banner").hidden ? "" : $("banner").textContent,
    datasets: app.datasets.slice(),
    dataset: app.meta ? app.view.dataset : "",
    capabilities: app.capabilities,
    features: { ...app.features },
    // How moving frames travel now: "vp8", "vp9", "jpeg" or "png"; and the video stream's figures.
    moving: app.features.video || (app.features.jpeg && app.features.provisional_encoding ? "jpeg" : "png"),
    video: loop.video.figures(),
    view: JSON.parse(JSON.stringify(app.view)),
    canvas: [canvas.width, canvas.height],
    lastFrame: loop.lastFrame,
    lastStats: loop.lastStats,
    lastScene: loop.newest ? loop.newest.scene : null,
    newestId: loop.newest ? loop.newest.id : 0,
    newestSentAt: loop.newest ? loop.newest.sentAt : null, // performance.now() when the newest Render was sent
    busyUntil: loop.holdUntil, // no moving camera is asked before this (a Busy reply's hint), performance.now()
    counts: { ...loop.counts },
    exactAfterReleaseMs: loop.exactAfterReleaseMs,
    notes: app.notes.slice(),
    datasetNote: $("dataset-note").hidden ? "" : $("dataset-note").textContent,
    curve: { points: curve.points.map((p) => p.slice()), active: curve.active },
    presets: app.presets,
    url: location.href,
  }),
  /// Saves the frame as the Save frame button does; returns the file's name.
  saveFrame,
  frames: () => loop.shownFrames.slice(),
  /// Every video Frame that arrived, shown or not: {id, streamFrame, key, keyReason, width, height, bytes, decoded}.
  videoFrames: () => loop.video.log.slice(),
  resetFigures: () => loop.resetFigures(),
  /// The canvas pixels as base64 of RGBA rows, top first.
  pixels: () => pixelsOf(canvas),
  /// Keeps a copy of the canvas as it is now, with the frame it shows, for `snapshotPixels` to read later; returns
  /// its index. Copying takes a few milliseconds where reading the pixels out (`pixels`) holds the page's thread for
  /// hundreds at 1024x1024: a benchmark's sample mid-drag must not stall the drag it measures.
  snapshot: () => {
    const copy = new OffscreenCanvas(canvas.width, canvas.height);
    const context = copy.getContext("2d");
    context.imageSmoothingEnabled = false;
    context.drawImage(canvas, 0, 0);
    snapshots.push({ copy, frame: loop.lastFrame ? structuredClone(loop.lastFrame) : null });
    return snapshots.length - 1;
  },
  /// Snapshot `index`'s pixels (as `pixels` gives them) and the frame it showed.
  snapshotPixels: (index) => ({ ...pixelsOf(snapshots[index].copy), frame: snapshots[index].frame }),
  /// The last shown frame's payload as the server sent it (base64).
  lastPayload: () => (loop.lastPayload ? base64(loop.lastPayload) : ""),
  /// A scripted drag through the gestures' own handlers: `dAz`, `dEl` degrees per move, `hz` moves a second, for
  /// `durationMs`; resolves with the moves made once released.
  drag: ({ durationMs = 10000, hz = 30, dAz = 2, dEl = 0 } = {}) =>
    new Promise((resolve) => {
      gestures.begin();
      const t0 = performance.now();
      let moves = 0;
      const move = () => {
        if (performance.now() - t0 >= durationMs) {
          gestures.end();
          return resolve({ moves, ms: performance.now() - t0 });
        }
        gestures.orbit(dAz, dEl);
        ++moves;
        setTimeout(move, Math.max(0, t0 + (moves * 1000) / hz - performance.now()));
      };
      move();
    }),
  setView: (changes) => {
    Object.assign(app.view, changes);
    panel.syncAll();
    viewChanged("still");
  },
};

// Shown frames make the canvas opaque again after a disconnection.
const shown = loop.hooks.shown;
loop.hooks.shown = (...a) => {
  canvas.style.opacity = "";
  shown(...a);
};

panel.syncAll();
connect();
