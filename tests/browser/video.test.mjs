// The viewer's video stream (protocol version 4) in a real browser (Debian's Chromium, headless, whose WebCodecs
// decode VP8 and VP9) against the real `voxbrick serve --http`: a drag gets vp8 frames, every one decoded in the
// stream's order and those shown close to the exact frame; a browser that decodes no codec (or has no WebCodecs) gets
// jpeg (from version 8 a jpeg moving frame comes at the size it was drawn, and fills the canvas); a resize mid-drag, a
// reconnection and a failed decoder each get a key frame.

import assert from "node:assert/strict";
import fs from "node:fs";
import path from "node:path";
import { after, before, describe, test } from "node:test";
import * as H from "./harness.mjs";

const SIZE = [160, 128];
const SIZE_PARAM = `size=${SIZE[0]}x${SIZE[1]}`;

const waitExact = H.waitExact;

/// A scripted drag through the page's own gesture handlers (voxbrickViewer.drag); resolves once released.
const drag = (page, options) => page.evaluate((o) => window.voxbrickViewer.drag(o), options);
/// The viewer at `url` in a new page that runs `script` before the page's own scripts (what a browser without
/// a codec, or with a failing decoder, would do).
async function openPageWith(browser, url, script) {
  const page = await browser.newPage();
  page.errors = [];
  page.on("pageerror", (e) => page.errors.push(e.message));
  await page.setViewport({ width: 720, height: 420, deviceScaleFactor: 1 });
  await page.evaluateOnNewDocument(script);
  await page.goto(url, { waitUntil: "load" });
  await page.waitForFunction(() => window.voxbrickViewer !== undefined, { timeout: 10000 });
  return page;
}
const videoFrames = (page) => page.evaluate(() => window.voxbrickViewer.videoFrames());
const shownFrames = (page) => page.evaluate(() => window.voxbrickViewer.frames());

const psnr = H.psnrRgb;

/// The stream's frames as they arrived: each was given to the decoder, and stream_frame counts up by one, from 0 at
/// each key frame that starts an encoder (the first, or one of a new size or codec).
function assertWholeStream(frames) {
  assert.ok(frames.length > 0, "video frames arrived");
  frames.forEach((f, i) => {
    const restart = f.key && ["start", "size", "codec"].includes(f.keyReason);
    const expected = restart ? 0 : frames[i - 1].streamFrame + 1;
    assert.equal(f.streamFrame, expected, `frame ${i} of the stream: ${JSON.stringify(frames.slice(0, i + 1))}`);
    assert.ok(f.decoded, `frame ${i} was decoded: ${JSON.stringify(f)}`);
  });
}

describe("viewer video stream", () => {
  let scratch, datasets, server, browser;

  before(async () => {
    scratch = H.scratchDir("video");
    datasets = H.prepDatasets(scratch.dir, { sparse: "synthetic:sparse,n=64", ml: "synthetic:marschner-lobb,n=48" });
    server = await new H.Server({ dir: scratch.dir, datasets }).start();
    browser = await H.launchBrowser();
  });

  after(async () => {
    if (browser) await browser.close();
    if (server) await server.kill();
    if (scratch) scratch.remove();
  });

  test("a drag in a browser that decodes vp8 gets the vp8 stream, every frame decoded in order", async () => {
    const page = await H.openPage(browser, `${server.url}/?dataset=ml&${SIZE_PARAM}`);
    const start = await waitExact(page);
    assert.equal(start.capabilities.version, 9);
    assert.ok(start.capabilities.encodings.includes(4) && start.capabilities.encodings.includes(5));
    assert.equal(start.features.video, "vp8", "vp8 is the first codec asked, and Chromium decodes it");
    assert.equal(start.moving, "vp8");
    await page.evaluate(() => window.voxbrickViewer.resetFigures());
    await drag(page, { durationMs: 2500, hz: 30, dAz: 2 });
    const done = await waitExact(page, start.newestId);
    // The frames shown while dragging were vp8 frames, decoded and drawn; the exact frame after the release is png.
    const shown = await shownFrames(page);
    const moving = shown.filter((f) => f.provisional && f.phase === "drag");
    assert.ok(moving.length >= 5, `vp8 frames shown while dragging: ${moving.length}`);
    for (const f of moving) {
      assert.equal(f.encoding, 4, JSON.stringify(f));
      assert.ok(f.decodeMs >= 0 && f.decodeMs < 2000, `decode ms ${f.decodeMs}`);
      assert.ok(f.bitrateKbps > 0, `bitrate ${f.bitrateKbps}`);
    }
    assert.equal(done.lastFrame.encoding, 1, "the exact frame is png");
    const v = done.video;
    assert.equal(v.codec, "vp8");
    assert.equal(v.errors, 0);
    assert.equal(v.skipped, 0);
    assert.ok(v.decoded > 0 && v.decoded === v.frames, `decoded ${v.decoded} of ${v.frames}`);
    assert.ok(v.bitrateKbps > 0 && v.lastDecodeMs !== null, JSON.stringify(v));
    // Every frame of the stream came, in order (those not shown too), the first a key frame.
    const frames = await videoFrames(page);
    assertWholeStream(frames);
    assert.deepEqual([frames[0].key, frames[0].keyReason], [true, "start"]);
    assert.equal(frames.filter((f) => f.key).length, 1, "one key frame: the size and the dataset stayed");
    // The overlay names the codec, its bitrate and decode time.
    const overlay = await page.$eval("#overlay", (e) => e.textContent);
    assert.match(overlay, /moving: vp8 {2}\d+ kbit\/s {2}decode \d+\.\d ms {2}key frames 1/);
    assert.deepEqual(page.errors, []);
    await page.close();
  });

  test("a vp8 frame shows the image the server drew, within the codec's loss", async () => {
    // A drag that does not move (0 degrees a move): each provisional frame is of the camera of the exact frame that
    // follows the release; on this small frame the server draws it exactly (rung 0), so only the codec differs.
    const page = await H.openPage(browser, `${server.url}/?dataset=ml&orbit=40,25&tf=hot&${SIZE_PARAM}`);
    const start = await waitExact(page);
    const dragging = drag(page, { durationMs: 4000, hz: 20, dAz: 0 });
    const s = await H.waitForState(
      page,
      (st) =>
        st.lastFrame.encoding === 4 && st.lastStats.interactive && st.lastStats.interactive.rung === 0 && st.video.decoded > 3,
    );
    // A copy of the canvas, read out after the drag (as bench/browser_link.mjs samples a drag), and the frame it showed.
    const vp8Snapshot = await H.snapshotCanvas(page);
    await dragging;
    const vp8Pixels = await H.snapshotPixels(page, vp8Snapshot);
    assert.equal(vp8Pixels.frame.encoding, 4, "the snapshot shows a vp8 frame");
    assert.ok(vp8Pixels.frame.provisional);
    const exact = await waitExact(page, start.newestId);
    assert.equal(exact.lastFrame.encoding, 1);
    const pngPixels = await H.canvasPixels(page);
    assert.ok(H.litPixels(pngPixels) > 500, "the frame shows the volume");
    // A snapshot is the canvas's pixels exactly.
    const pngSnapshot = await H.snapshotPixels(page, await H.snapshotCanvas(page));
    assert.ok(pngSnapshot.rgba.equals(pngPixels.rgba), "the snapshot of the exact frame is the canvas, pixel for pixel");
    assert.equal(pngSnapshot.frame.id, exact.lastFrame.id);
    const db = psnr(vp8Pixels, pngPixels);
    // Measured: 37.5 dB; decoded as BT.709 full range in place of the stream's BT.601 limited range, 24.1 dB.
    assert.ok(db > 28, `vp8 frame against the exact png: ${db.toFixed(1)} dB (${JSON.stringify(s.lastFrame)})`);
    await page.close();
  });

  test("the address's video parameter picks vp9 (in 4:4:4 where the browser decodes it), or turns video off; " +
    "jpeg_quality sets its jpeg frames' quality", async () => {
    const refuses444 = () => {
      const asked = VideoDecoder.isConfigSupported.bind(VideoDecoder);
      VideoDecoder.isConfigSupported = async (config) =>
        config.codec.startsWith("vp09.01") ? { supported: false, config } : asked(config);
    };
    const jpegBytes = {};
    for (const [param, moving, encoding, chroma, script] of [
      ["video=vp9", "vp9", 5, "4:4:4", null],
      ["video=vp9&chroma=420", "vp9", 5, "4:2:0", null],
      ["video=vp9", "vp9", 5, "4:2:0", refuses444],
      ["video=off", "jpeg", 3, null, null],
      ["video=off&jpeg_quality=20", "jpeg", 3, null, null],
    ]) {
      const what = `${param}${script ? " (profile 1 refused)" : ""}`;
      const url = `${server.url}/?dataset=ml&${SIZE_PARAM}&${param}`;
      const page = script ? await openPageWith(browser, url, script) : await H.openPage(browser, url);
      const start = await waitExact(page);
      assert.equal(start.features.video, moving === "jpeg" ? null : moving, what);
      assert.equal(start.features.accepts_vp9_444, chroma === "4:4:4", what);
      assert.equal(start.moving, moving, what);
      await drag(page, { durationMs: 1200, hz: 30, dAz: 3 });
      const done = await waitExact(page, start.newestId);
      const shown = (await shownFrames(page)).filter((f) => f.provisional && f.phase === "drag");
      assert.ok(shown.length >= 3, `${what}: frames shown while dragging: ${shown.length}`);
      for (const f of shown) assert.equal(f.encoding, encoding, `${what}: ${JSON.stringify(f)}`);
      if (moving === "jpeg") {
        const quality = /jpeg_quality=(\d+)/.exec(param);
        for (const f of shown) assert.equal(f.scene.jpeg_quality, quality ? Number(quality[1]) : undefined, what);
        jpegBytes[param] = shown.reduce((sum, f) => sum + f.bytes, 0) / shown.length;
      }
      if (chroma) {
        // The server said each frame's colour sampling, and the decoder took the stream as it came.
        const frames = await videoFrames(page);
        assertWholeStream(frames);
        for (const f of frames) assert.equal(f.chroma, chroma, `${what}: ${JSON.stringify(f)}`);
        assert.equal(done.video.errors, 0, what);
        assert.equal(done.video.codec, chroma === "4:4:4" ? "vp9 4:4:4" : "vp9", what);
        const overlay = await page.$eval("#overlay", (e) => e.textContent);
        assert.match(overlay, chroma === "4:4:4" ? /moving: vp9 4:4:4 {2}\d+ kbit\/s/ : /moving: vp9 {2}\d+ kbit\/s/, what);
      }
      assert.deepEqual(page.errors, [], what);
      await page.close();
    }
    // The server took the address's quality: its frames a fraction of the default's (85) bytes.
    const [q85, q20] = [jpegBytes["video=off"], jpegBytes["video=off&jpeg_quality=20"]];
    assert.ok(q20 < 0.6 * q85, `jpeg moving frames at quality 20: ${q20.toFixed(0)} B a frame, at 85 ${q85.toFixed(0)}`);
  });

  test("a browser that decodes no video codec gets jpeg, as one without WebCodecs does", async () => {
    const cases = {
      "isConfigSupported says no": () => {
        VideoDecoder.isConfigSupported = async (config) => ({ supported: false, config });
      },
      "no VideoDecoder": () => {
        delete window.VideoDecoder;
      },
    };
    for (const [name, script] of Object.entries(cases)) {
      const page = await openPageWith(browser, `${server.url}/?dataset=sparse&${SIZE_PARAM}`, script);
      const start = await waitExact(page);
      assert.equal(start.capabilities.version, 9, name);
      assert.equal(start.features.video, null, name);
      assert.equal(start.moving, "jpeg", name);
      await drag(page, { durationMs: 1500, hz: 30, dAz: 3 });
      const done = await waitExact(page, start.newestId);
      const moving = (await shownFrames(page)).filter((f) => f.provisional && f.phase === "drag");
      assert.ok(moving.length >= 3, `${name}: jpeg frames while dragging: ${moving.length}`);
      for (const f of moving) assert.equal(f.encoding, 3, `${name}: ${JSON.stringify(f)}`);
      assert.equal(done.video.frames, 0, `${name}: no video frame came`);
      assert.match(await page.$eval("#overlay", (e) => e.textContent), /moving: jpeg/);
      assert.deepEqual(page.errors, [], name);
      await page.close();
    }
  });

  test("a jpeg moving frame drawn smaller than the view comes at its drawn size and fills the canvas", async () => {
    // interactive_fps 1000: each moving frame's budget is the 10 ms floor, so the ladder draws it smaller than the
    // view; from protocol version 8 it travels at that size and the page draws it scaled onto the canvas.
    const busy = await H.configuredServer(scratch.dir, datasets, "small-drawings", "[scheduler]\ninteractive_fps = 1000\n");
    try {
      // Every drawImage onto a canvas, with its source's size.
      const page = await openPageWith(browser, `${busy.url}/?dataset=sparse&size=640x480&video=off`, () => {
        window.drawCalls = [];
        const draw = CanvasRenderingContext2D.prototype.drawImage;
        CanvasRenderingContext2D.prototype.drawImage = function (image, ...args) {
          window.drawCalls.push([image.width, image.height, ...args]);
          return draw.call(this, image, ...args);
        };
      });
      const start = await waitExact(page);
      assert.equal(start.capabilities.version, 9);
      assert.equal(start.moving, "jpeg");
      // The overlay while dragging (its text every 100 ms).
      const overlays = [];
      const watching = setInterval(async () => {
        overlays.push(await page.$eval("#overlay", (e) => e.textContent).catch(() => ""));
      }, 100);
      await drag(page, { durationMs: 1500, hz: 30, dAz: 3 });
      clearInterval(watching);
      const done = await waitExact(page, start.newestId);
      const moving = (await shownFrames(page)).filter((f) => f.provisional && f.phase === "drag");
      const smaller = moving.filter((f) => f.encoding === 3 && f.width < 640);
      assert.ok(smaller.length >= 1, `jpeg frames smaller than the view: ${JSON.stringify(moving.map((f) => f.width))}`);
      const calls = await page.evaluate(() => window.drawCalls);
      const scaled = calls.filter((c) => c[0] < 640 && c.length === 6);
      assert.ok(scaled.length >= smaller.length, JSON.stringify(calls.slice(0, 20)));
      for (const c of scaled) assert.deepEqual(c.slice(2), [0, 0, 640, 480], `drawn onto the whole canvas: ${c}`);
      assert.deepEqual(done.canvas, [640, 480]);
      assert.equal(done.lastFrame.width, 640, "the exact frame has the view's size");
      assert.ok(H.litPixels(await H.canvasPixels(page)) > 500, "the exact frame shows the volume");
      assert.ok(overlays.some((o) => /moving: jpeg {2}drawn at \d+ % size/.test(o)), JSON.stringify(overlays));
      assert.deepEqual(page.errors, []);
      await page.close();
    } finally {
      await busy.kill();
    }
  });

  test("a server whose video memory is spent sends jpeg moving frames, and the viewer keeps turning", async () => {
    // memory.video_mb = 0: no encoder fits, so every moving frame comes as JPEG ("video_fallback": "memory").
    const spent = await new H.Server({ dir: scratch.dir, datasets, extra: ["--video-memory", "0"] }).start();
    try {
      const page = await H.openPage(browser, `${spent.url}/?dataset=sparse&${SIZE_PARAM}`);
      const start = await waitExact(page);
      assert.equal(start.features.video, "vp8", "the browser still asks for vp8");
      await drag(page, { durationMs: 1500, hz: 30, dAz: 3 });
      const done = await waitExact(page, start.newestId);
      const moving = (await shownFrames(page)).filter((f) => f.provisional && f.phase === "drag");
      assert.ok(moving.length >= 3, `jpeg frames while dragging: ${moving.length}`);
      for (const f of moving) assert.equal(f.encoding, 3, JSON.stringify(f));
      assert.equal(done.video.frames, 0, "no video frame came");
      assert.equal(done.video.errors, 0);
      assert.equal(done.lastFrame.encoding, 1, "the exact frame is png");
      for (const f of moving) assert.equal(f.videoFallback, "memory", JSON.stringify(f));
      assert.deepEqual(page.errors, []);
      await page.close();
    } finally {
      await spent.kill();
    }
  });

  test("a stream slower than its share of the server's encoders comes smaller, shown at the view's size", async () => {
    // One encoder thread and interactive_fps 1000: a millisecond of encoding for each moving frame, which no
    // 640x480 frame is encoded in; the stream goes smaller (docs/server.md, "Quality yields before latency"). (The
    // render threads' share leaves the drawing small too: stream_follows_drawing = false keeps the stream's size to
    // its link and encoders.)
    const busy = await H.configuredServer(scratch.dir, datasets, "encoders-busy",
      "[server]\nencode_threads = 1\n[scheduler]\ninteractive_fps = 1000\nstream_follows_drawing = false\n");
    try {
      const page = await H.openPage(browser, `${busy.url}/?dataset=sparse&size=640x480`);
      const start = await waitExact(page);
      await drag(page, { durationMs: 2000, hz: 30, dAz: 2 });
      const done = await waitExact(page, start.newestId);
      const frames = await videoFrames(page);
      assertWholeStream(frames);
      const at = frames.findIndex((f) => f.width < 640);
      assert.ok(at > 0, `smaller frames: ${JSON.stringify(frames.map((f) => [f.width, f.height]))}`);
      assert.deepEqual([frames[at].key, frames[at].keyReason], [true, "size"], JSON.stringify(frames[at]));
      assert.equal(frames[at].width * 480, frames[at].height * 640, "the scene's shape");
      // Shown on the view's canvas, at its size.
      const smaller = (await shownFrames(page)).filter((f) => f.encoding === 4 && f.width < 640);
      assert.ok(smaller.length >= 1, "a smaller vp8 frame was shown");
      assert.deepEqual(done.canvas, [640, 480]);
      const v = done.video;
      assert.ok(v.scale < 1, JSON.stringify(v));
      assert.equal(v.scaledFor, "encoders", JSON.stringify(v));
      assert.equal(v.errors, 0);
      assert.match(await page.$eval("#overlay", (e) => e.textContent),
        /moving: vp8 {2}\d+ kbit\/s {2}at \d+ % size \(the server's encoders are busy\)/);
      assert.equal(done.lastFrame.width, 640, "the exact frame has the view's size");
      assert.deepEqual(page.errors, []);
      await page.close();
    } finally {
      await busy.kill();
    }
  });

  test("a resize mid-drag gets a key frame of the new size", async () => {
    // No fixed size: the frame is the canvas's, which follows the window.
    const page = await H.openPage(browser, `${server.url}/?dataset=sparse`, { width: 560, height: 300 });
    const start = await waitExact(page);
    const before = start.canvas;
    const dragging = drag(page, { durationMs: 4000, hz: 30, dAz: 2 });
    await H.waitForState(page, (st) => st.video.decoded >= 5);
    await page.setViewport({ width: 500, height: 260, deviceScaleFactor: 1 });
    const resized = await H.waitForState(page, (st, b) => st.canvas[0] !== b[0], 5000, before);
    await dragging;
    await waitExact(page, start.newestId);
    const frames = await videoFrames(page);
    assertWholeStream(frames);
    const at = frames.findIndex((f) => f.width === resized.canvas[0] && f.height === resized.canvas[1]);
    assert.ok(at > 0, `frames of the new size ${resized.canvas}: ${JSON.stringify(frames.map((f) => f.width))}`);
    assert.deepEqual([frames[at].key, frames[at].keyReason], [true, "size"], JSON.stringify(frames[at]));
    assert.ok(frames.slice(0, at).every((f) => f.width === before[0] && f.height === before[1]));
    const later = frames.slice(at + 1);
    assert.ok(later.every((f) => !f.key), `one key frame for the resize: ${JSON.stringify(frames.slice(at))}`);
    assert.ok(frames.length - at >= 3, `frames after the resize: ${frames.length - at}`);
    // Frames of the new size were shown, drawn at their own size.
    const shown = (await shownFrames(page)).filter((f) => f.encoding === 4 && f.width === resized.canvas[0]);
    assert.ok(shown.length >= 1, "a vp8 frame of the new size was shown");
    const v = (await H.viewerState(page)).video;
    assert.equal(v.errors, 0);
    assert.equal(v.skipped, 0);
    assert.equal(v.keyFrames, 2);
    assert.deepEqual(page.errors, []);
    await page.close();
  });

  test("a new connection starts a new stream with a key frame", async () => {
    const own = await new H.Server({ dir: scratch.dir, datasets }).start();
    try {
      const page = await H.openPage(browser, `${own.url}/?dataset=sparse&${SIZE_PARAM}`);
      const start = await waitExact(page);
      await drag(page, { durationMs: 1000, hz: 30, dAz: 2 });
      await waitExact(page, start.newestId);
      const first = await videoFrames(page);
      assertWholeStream(first);
      // The server goes away and comes back: the page reconnects, and its next drag is a new stream.
      await own.kill();
      const down = await H.waitForState(page, (st) => st.connection === "disconnected");
      await own.start();
      const back = await H.waitForState(
        page,
        (st, shown) => st.connection === "ready" && !st.lastFrame.provisional && st.counts.shown > shown,
        30000,
        down.counts.shown,
      );
      await page.evaluate(() => window.voxbrickViewer.resetFigures());
      await drag(page, { durationMs: 1000, hz: 30, dAz: 2 });
      await waitExact(page, back.newestId);
      const frames = await videoFrames(page);
      assertWholeStream(frames);
      assert.deepEqual([frames[0].key, frames[0].keyReason], [true, "start"]);
      const v = (await H.viewerState(page)).video;
      assert.equal(v.errors, 0);
      assert.equal(v.skipped, 0);
      assert.ok(v.decoded === frames.length, `decoded ${v.decoded} of ${frames.length}`);
      await page.close();
    } finally {
      await own.kill();
    }
  });

  test("a decoder that fails asks for a key frame and goes on from it", async () => {
    // The browser's decoder refuses the stream's 6th chunk, as a decoder that fails on a frame would.
    const page = await openPageWith(browser, `${server.url}/?dataset=ml&${SIZE_PARAM}`, () => {
      const decode = VideoDecoder.prototype.decode;
      let chunks = 0;
      VideoDecoder.prototype.decode = function (chunk) {
        if (++chunks === 6) throw new DOMException("refused by the test", "EncodingError");
        return decode.call(this, chunk);
      };
    });
    const start = await waitExact(page);
    await drag(page, { durationMs: 3000, hz: 30, dAz: 2 });
    const done = await waitExact(page, start.newestId);
    const frames = await videoFrames(page);
    const v = done.video;
    assert.equal(v.errors, 1, JSON.stringify(v));
    assert.match(done.notes.join("\n"), /the video decoder failed: refused by the test/);
    // The failed frame, and the inter frames encoded before the server heard the ask, were skipped; then the key
    // frame the next Render asked for, and the stream decoded on.
    const failed = frames[5];
    assert.equal(failed.decoded, false, JSON.stringify(failed));
    const key = frames.findIndex((f, i) => i > 5 && f.key);
    assert.ok(key > 5, `a key frame after the failure: ${JSON.stringify(frames.slice(5, 12))}`);
    assert.equal(frames[key].keyReason, "asked");
    assert.ok(frames.slice(6, key).every((f) => !f.decoded), "deltas before the key frame are skipped");
    assert.ok(frames.slice(key).every((f) => f.decoded), "every frame from the key frame on is decoded");
    assert.ok(frames.length - key >= 3, `frames after the key frame: ${frames.length - key}`);
    assert.equal(v.skipped, key - 6);
    assert.equal(v.needKey, false);
    assert.equal(v.askKey, false, "no more key frames asked once one came");
    assert.equal(frames.slice(key + 1).filter((f) => f.key).length, 0, "one key frame answers the ask");
    const shownAfter = (await shownFrames(page)).filter((f) => f.encoding === 4 && f.id > frames[key].id);
    assert.ok(shownAfter.length >= 1, "vp8 frames shown after the recovery");
    assert.deepEqual(page.errors, []);
    await page.close();
  });
});
