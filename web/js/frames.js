// Asking for frames and showing them: every new camera is asked for at once, up to MAX_OUTSTANDING Renders
// unanswered (one drawing, one waiting: the server's latest-wins replaces a waiting one with the newer and answers it
// Superseded, so a camera never waits for the frame before it, and there is never a backlog); frames are shown only
// going forward (a Frame of an older Render than the one shown is dropped; a Render's exact frame follows its
// provisional one); video Frames (a moving camera's, protocol version 4) all go to the session's decoder, shown or
// not; and the figures of the overlay: frames per second, the age of the camera each shown frame was drawn for, bytes
// per frame, stand-ins, the video's bitrate and decode time.

import { Encoding, ErrorCode, isVideo, retryAfterMs } from "./protocol.js";
import { VideoStream } from "./video.js";

const MIME = { [Encoding.png]: "image/png", [Encoding.jpeg]: "image/jpeg", [Encoding.webp]: "image/webp" };
const KEEP = 2000; // shown frames kept for the figures
// Renders sent and not yet answered at most: one being drawn, one waiting (replaced by each newer camera), and one
// more while a render thread of the server takes the waiting one.
const MAX_OUTSTANDING = 3;
const REMEMBERED = 16; // recent Renders kept, so that a late exact frame finds its camera

export class FrameLoop {
  /// `canvas`: where frames are drawn. `hooks`: scene(phase, {keyframe}) -> the scene to ask for now (asking the
  /// video stream for a key frame when `keyframe`), or null if none can be asked yet; encoding() -> the Render's
  /// encoding (absent: png); refused(error) -> true when the page changed what it asks (then the frame is asked
  /// again);
  /// shown(frame) after each frame drawn; failed(error) for an Error that is not handled; busy(error, ms) when a
  /// Render was answered Busy, and none of its kind (moving, or any for a still one) goes for `ms` (the server's hint,
  /// a fifth more at most).
  constructor(canvas, hooks) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d", { alpha: false, colorSpace: "srgb" });
    this.hooks = hooks;
    this.connection = null;
    this.video = new VideoStream({
      output: (frame, meta, decodeMs) => this.videoOutput(frame, meta, decodeMs),
      failed: (e) => hooks.failed({ name: "Decode", message: `the video decoder failed: ${e.message || e}` }),
    });
    this.reset();
    this.resetFigures();
  }

  /// Forgets what was asked (a new connection or dataset): nothing is outstanding.
  reset() {
    this.outstanding = new Set(); // ids of the Renders waiting for their first reply
    this.sent = new Map(); // id -> {id, cameraAt, phase, scene} of recent Renders
    this.newest = null; // the newest Render sent: {id, cameraAt, phase, scene}
    this.shownId = 0; // id of the Render whose frame is on the canvas
    this.shownExact = false; // and whether that frame was its exact one
    this.wanted = null; // {cameraAt, phase}: a frame is wanted that was not asked for yet
    this.decodeSerial = 0;
    this.keyAskId = 0; // the Render that asked for a key frame last
    // A Render answered Busy (the server over capacity for one more dragging session, or a quota): no moving camera
    // is asked before holdUntil (performance.now()), and no camera at all before holdAllUntil (a still Render was
    // refused: a quota); then the camera wanted is asked.
    this.holdUntil = 0;
    this.holdAllUntil = 0;
    clearTimeout(this.holdTimer);
    this.holdTimer = 0;
    // A new connection is a new video stream, and a new dataset starts one with a key frame: the decoder starts over.
    this.video.reset();
  }

  resetFigures() {
    this.shownFrames = []; // {id, at, latencyMs, bytes, provisional, encoding, standin, renderMs, budgetMs, phase}
    // errors: Error replies to Renders, except InvalidScene naming an optional key the page then dropped (refused)
    // and Superseded (a waiting camera replaced by a newer one).
    this.counts = { shown: 0, provisional: 0, exact: 0, dropped: 0, superseded: 0, errors: 0, refused: 0, busy: 0 };
    this.releaseAt = null;
    this.exactAfterReleaseMs = null;
    this.lastFrame = null;
    this.lastStats = null;
    this.lastPayload = null;
    this.video.resetFigures();
  }

  attach(connection) {
    this.connection = connection;
    this.reset();
  }

  /// The camera or anything else of the view changed at `cameraAt` (performance.now()); ask for a frame now, or as
  /// soon as fewer than MAX_OUTSTANDING Renders are unanswered. `phase`: "drag" while the pointer moves the camera, "still" otherwise.
  want(phase, cameraAt = performance.now()) {
    this.wanted = { cameraAt, phase };
    this.pump();
  }

  /// The drag ended: the exact frame of the last camera is what comes next.
  released() {
    this.releaseAt = performance.now();
    this.exactAfterReleaseMs = null;
    // A camera not yet asked for is asked as a still frame. So is the newest drag camera whose exact frame has not
    // come: the server draws a still Render's frame exact at once (as the end of the drag, and in place of that drag
    // Render's waiting frames: latest wins), where the drag Render's own exact frame would first wait for the
    // camera to rest (up to 150 ms after its provisional frame was drawn).
    if (this.wanted) this.wanted.phase = "still";
    else if (this.newest && this.newest.phase === "drag") {
      if (this.newest.exactShown) this.exactAfterReleaseMs = 0;
      else this.wanted = { cameraAt: this.newest.cameraAt, phase: "still" };
    }
    this.pump();
  }

  pump() {
    if (!this.connection || this.outstanding.size >= MAX_OUTSTANDING || !this.wanted) return;
    const held = (this.wanted.phase === "drag" ? this.holdUntil : this.holdAllUntil) - performance.now();
    if (held > 0) {
      // A Busy reply's hint: the camera is asked when it has passed (a timer may fire a little early: then it waits
      // again). After a refused drag a still camera, the exact frame a release waits for, goes at once: the server
      // takes it even when it takes no more dragging sessions.
      if (!this.holdTimer)
        this.holdTimer = setTimeout(() => {
          this.holdTimer = 0;
          this.pump();
        }, held + 1);
      return;
    }
    // While the decoder waits for a key frame, a Render asks for one, until one comes. The ask is that Render's own:
    // if its frame is replaced before it is encoded (latest wins: it is answered Superseded), the next Render asks
    // again. One ask at a time, or each Render in flight would cost a key frame.
    const keyframe = this.video.askKey && !this.outstanding.has(this.keyAskId);
    const scene = this.hooks.scene(this.wanted.phase, { keyframe });
    if (!scene) return;
    const id = this.connection.render(this.hooks.encoding ? this.hooks.encoding() : Encoding.png, scene);
    this.newest = { id, ...this.wanted, scene, sentAt: performance.now() };
    this.outstanding.add(id);
    if (scene.keyframe) this.keyAskId = id;
    this.sent.set(id, this.newest);
    if (this.sent.size > REMEMBERED) this.sent.delete(this.sent.keys().next().value);
    this.wanted = null;
  }

  /// A Frame or Error answering a Render (or with id 0).
  reply(m) {
    m.arrivedAt = performance.now(); // for the figures: when the page got the reply
    const answersNewest = this.newest && m.requestId === this.newest.id;
    let hint = null; // a Busy reply's retry hint, ms
    this.outstanding.delete(m.requestId);
    if (m.typeName === "Frame") {
      const request = this.sent.get(m.requestId);
      const stats = statsOf(m.body);
      const forward = request && this.advance(m, stats);
      if (isVideo(m.body.encoding)) this.decodeVideo(m, stats, request, forward);
      else if (forward) this.show(m, stats, request);
      if (!forward) this.counts.dropped++;
    } else if (m.typeName === "Error") {
      if (answersNewest && m.body.code === ErrorCode.InvalidScene && this.hooks.refused(m.body)) {
        this.counts.refused++;
        this.wanted = this.wanted || { cameraAt: this.newest.cameraAt, phase: this.newest.phase };
      } else if (m.body.code === ErrorCode.Superseded) {
        this.counts.superseded++; // a waiting camera replaced by a newer one: no error
      } else if (m.body.code === ErrorCode.Busy && (hint = retryAfterMs(m.body.message)) !== null) {
        // Not now: the camera is asked again after the server's hint (a fifth more at most, drawn at random, so that
        // pages refused together do not all come back in the same instant), not at every move meanwhile.
        this.counts.busy++;
        const wait = Math.round(hint * (1 + 0.2 * Math.random()));
        const until = performance.now() + wait;
        this.holdUntil = Math.max(this.holdUntil, until);
        const refused = this.sent.get(m.requestId);
        if (!refused || refused.phase !== "drag") this.holdAllUntil = Math.max(this.holdAllUntil, until);
        if (answersNewest && !this.wanted) this.wanted = { cameraAt: this.newest.cameraAt, phase: this.newest.phase };
        if (this.hooks.busy) this.hooks.busy(m.body, wait);
      } else {
        this.counts.errors++;
        if (answersNewest || m.requestId === 0) this.hooks.failed(m.body);
      }
    }
    this.pump();
  }

  /// Whether Frame `m` (its statistics `stats`) moves the canvas forward (a later Render's frame, or the exact frame
  /// of the Render shown); if so it becomes the one shown. A frame whose statistics cannot be read counts as exact.
  advance(m, stats) {
    const provisional = stats.provisional === true;
    const forward = m.requestId > this.shownId || (m.requestId === this.shownId && !this.shownExact && !provisional);
    if (forward) {
      this.shownId = m.requestId;
      this.shownExact = !provisional;
    }
    return forward;
  }

  /// A video Frame: decoded whether shown or not (the stream's next frames are drawn from it), and drawn once
  /// decoded if it moved the canvas forward and no later frame was shown meanwhile.
  decodeVideo(m, stats, request, forward) {
    const meta = { m, request, stats, serial: 0 };
    if (!this.video.decode(m.requestId, m.body, meta.stats, meta)) return;
    if (forward) meta.serial = ++this.decodeSerial;
  }

  videoOutput(frame, meta, decodeMs) {
    // Not to be shown, or a later frame was shown first: only decoded, for the frames after it.
    if (!meta.serial || meta.serial !== this.decodeSerial) return frame.close();
    try {
      this.draw(frame, meta.m.body);
    } finally {
      frame.close();
    }
    this.present(meta.m, meta.request, meta.stats, decodeMs);
  }

  /// Draws a decoded image at the frame's size; a canvas resized after the frame was asked shows it scaled until the
  /// next one.
  draw(image, f) {
    if (this.canvas.width !== f.width || this.canvas.height !== f.height)
      this.ctx.drawImage(image, 0, 0, this.canvas.width, this.canvas.height);
    else this.ctx.drawImage(image, 0, 0, f.width, f.height);
  }

  async show(m, stats, request) {
    const f = m.body;
    const serial = ++this.decodeSerial;
    const decodeStart = performance.now();
    let bitmap;
    try {
      const blob = new Blob([f.payload], { type: MIME[f.encoding] || "application/octet-stream" });
      // createImageBitmap's default options: asking for no premultiplied alpha or no colour conversion takes
      // Chromium's decoder off its fast path (a 1024x1024 JPEG in 43 ms instead of 19), and changes nothing in an
      // opaque frame without a colour profile, which is what the server sends (the still-frame test holds the canvas
      // to the PNG pixel for pixel; bench/results/browser/image-decode.md).
      bitmap = await createImageBitmap(blob);
    } catch (e) {
      this.hooks.failed({ name: "Decode", message: `a frame could not be decoded: ${e.message || e}` });
      return;
    }
    // A later frame whose decoding finished first wins; this one is dropped.
    if (serial !== this.decodeSerial) return bitmap.close();
    const decodeMs = performance.now() - decodeStart;
    this.draw(bitmap, f);
    bitmap.close();
    this.present(m, request, stats, decodeMs);
  }

  /// Records frame `m`, just drawn, in the figures and tells the page.
  present(m, request, stats, decodeMs) {
    const f = m.body;
    const now = performance.now();
    const provisional = stats.provisional === true;
    const frame = {
      id: m.requestId,
      at: now,
      latencyMs: now - request.cameraAt,
      bytes: f.payload.byteLength,
      width: f.width,
      height: f.height,
      encoding: f.encoding,
      provisional,
      standin: stats.bricks_standin || 0,
      renderMs: stats.ms ? stats.ms.total : null,
      // The render thread's time for it: an interactive frame's planning, drawing and scaling up (actual_ms), else
      // the drawing's.
      drawMs: stats.interactive && typeof stats.interactive.actual_ms === "number"
        ? stats.interactive.actual_ms
        : stats.ms ? stats.ms.total : null,
      encodeMs: typeof stats.encode_ms === "number" ? stats.encode_ms : null,
      // Where the latency went, for a benchmark: the camera's wait for a Render slot (MAX_OUTSTANDING) before it was
      // asked; the Render's wait for one of the server's render threads; its encoding's start after the Render
      // arrived; the Render sent to its reply's arrival (the server's time and the link's both ways); the reply's
      // arrival to the frame drawn (the page's).
      askMs: typeof request.sentAt === "number" ? request.sentAt - request.cameraAt : null,
      queueMs: typeof stats.queue_ms === "number" ? stats.queue_ms : null,
      encodeStartMs: typeof stats.encode_start_ms === "number" ? stats.encode_start_ms : null,
      shared: stats.shared === true, // drawn once for several sessions: its queue and drawing times are the first's
      replyMs: typeof request.sentAt === "number" && m.arrivedAt ? m.arrivedAt - request.sentAt : null,
      pageMs: m.arrivedAt ? now - m.arrivedAt : null,
      // An interactive frame's time budget as the server drew it (which may differ from the one asked for).
      budgetMs: stats.interactive ? stats.interactive.budget_ms : null,
      // Its rung: 0 drawn at the full size, each rung up a coarser frame (fewer pixels) scaled up on the canvas.
      rung: stats.interactive ? stats.interactive.rung : null,
      phase: request.phase,
      decodeMs,
      // A video frame: whether it was a key frame, and the stream's bitrate when it was encoded.
      key: stats.video ? stats.video.key === true : null,
      bitrateKbps: stats.video ? stats.video.bitrate_kbps : null,
      // A moving frame sent as JPEG in place of a video frame, and why ("memory": the server's encoders were full).
      videoFallback: typeof stats.video_fallback === "string" ? stats.video_fallback : null,
      // The scene the frame was asked with (its camera), so a benchmark can ask for the exact frame of what it shows.
      scene: request.scene,
    };
    this.shownFrames.push(frame);
    if (this.shownFrames.length > KEEP) this.shownFrames.shift();
    this.counts.shown++;
    this.counts[provisional ? "provisional" : "exact"]++;
    if (!provisional) request.exactShown = true;
    if (!provisional && this.releaseAt !== null && this.exactAfterReleaseMs === null && !this.dragging)
      this.exactAfterReleaseMs = now - this.releaseAt;
    this.lastFrame = frame;
    this.lastStats = stats;
    this.lastPayload = f.payload;
    this.hooks.shown(frame, stats);
  }

  /// Frames per second over the last second, the median and 99th percentile camera-to-frame latency of the last
  /// 100 frames, and bytes per frame.
  figures() {
    const now = performance.now();
    const recent = this.shownFrames.filter((f) => now - f.at <= 1000);
    const last = this.shownFrames.slice(-100).map((f) => f.latencyMs);
    last.sort((a, b) => a - b);
    const pick = (p) => (last.length ? last[Math.min(last.length - 1, Math.floor(p * last.length))] : null);
    return { fps: recent.length, p50: pick(0.5), p99: pick(0.99), last: this.lastFrame, video: this.video.figures() };
  }
}

/// A Frame's statistics; a frame without readable statistics is still shown, as an exact frame.
function statsOf(f) {
  try {
    return JSON.parse(f.statsJson);
  } catch {
    return {};
  }
}
