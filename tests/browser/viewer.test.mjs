// The viewer in a real browser (Debian's Chromium, headless) against the real `voxbrick serve --http` process over
// two small datasets: listing, a still frame identical to `voxbrick render`, dragging, the exact frame after the
// release, a transfer-function change, two tabs, a foreign origin and a wrong token refused, and the server killed
// and restarted. Screenshots go to build/browser-screenshots/ (VOXBRICK_SCREENSHOTS).

import assert from "node:assert/strict";
import fs from "node:fs";
import path from "node:path";
import { after, before, describe, test } from "node:test";
import * as H from "./harness.mjs";

const SIZE = [160, 128];
const SIZE_PARAM = `size=${SIZE[0]}x${SIZE[1]}`;

/// Waits for an exact frame of the newest Render, newer than `afterId`, and returns the page's state.
/// The payload of the last frame shown, as the server sent it.
const lastPayload = async (page) =>
  Buffer.from(await page.evaluate(() => window.voxbrickViewer.lastPayload()), "base64");

/// Frames of one view from one server may differ by 1/255 with what its renderer drew before (see the still-frame
/// test): the other comparisons with `voxbrick render` allow that, and no more.
const assertNearlyEqual = (a, b, what) => {
  const d = H.compareImages(a, b);
  assert.ok(d.maxDiff <= 1 && d.differing < a.width * a.height * 0.02, `${what}: ${JSON.stringify(d)}`);
};

/// Where a frame shows the volume: how many pixels are brighter than black, and their centroid.
const footprint = (img) => {
  let lit = 0;
  let sx = 0;
  let sy = 0;
  for (let y = 0; y < img.height; ++y)
    for (let x = 0; x < img.width; ++x) {
      const i = 4 * (y * img.width + x);
      if (img.rgba[i] + img.rgba[i + 1] + img.rgba[i + 2] === 0) continue;
      ++lit;
      sx += x;
      sy += y;
    }
  return { lit, x: lit ? sx / lit : NaN, y: lit ? sy / lit : NaN };
};

const waitExact = H.waitExact;

/// `clients` TCP clients (`voxbrick load`) dragging the sparse store at 64x64 for `seconds` against `server`: the process, and
/// a promise of its exit.
function tcpDragger(server, clients = 1, seconds = 3) {
  const load = H.spawnTied(H.VOXBRICK, ["load", `127.0.0.1:${server.tcpPort}`, "--dataset", "sparse", "--clients", `${clients}`,
    "--size", "64x64", "--drag", "20", "--interactive", "50", "--duration", `${seconds}`], { stdio: "ignore" });
  return { load, loaded: new Promise((resolve) => load.on("exit", resolve)) };
}

/// A page on `url` once its first exact frame is shown, with the pointer pressed at the frame's centre: the page, that
/// first state and the centre.
async function pressOnFrame(browser, url) {
  const page = await H.openPage(browser, url);
  const start = await waitExact(page);
  const box = await (await page.$("#frame")).boundingBox();
  const [x0, y0] = [box.x + box.width / 2, box.y + box.height / 2];
  await page.mouse.move(x0, y0);
  await page.mouse.down();
  return { page, start, x0, y0 };
}

describe("viewer", () => {
  let scratch, datasets, server, browser;

  before(async () => {
    scratch = H.scratchDir("browser");
    // A NRRD with a patient frame (axes not the index axes, spacing not 1, an origin away from 0): the page's own
    // camera (eye, centre, up once panned) must place it as the server does.
    const nrrd = path.join(scratch.dir, "oriented.nrrd");
    fs.writeFileSync(nrrd, H.orientedNrrd());
    datasets = H.prepDatasets(scratch.dir, {
      sparse: "synthetic:sparse,n=64",
      ml: "synthetic:marschner-lobb,n=48",
      oriented: nrrd,
    });
    server = await new H.Server({ dir: scratch.dir, datasets }).start();
    browser = await H.launchBrowser();
  });

  after(async () => {
    if (browser) await browser.close();
    if (server) await server.kill();
    if (scratch) scratch.remove();
  });

  /// `voxbrick render` of a dataset with the page's frame size and these flags, decoded.
  const reference = (dataset, flags) => {
    const out = path.join(scratch.dir, `ref-${Date.now()}.png`);
    H.voxbrick(["render", path.join(datasets, dataset), "--size", `${SIZE[0]}x${SIZE[1]}`, ...flags, "-o", out]);
    return H.decodePng(fs.readFileSync(out));
  };

  test("the page loads, lists the datasets and opens the first", async () => {
    const page = await H.openPage(browser, `${server.url}/?${SIZE_PARAM}`);
    const s = await waitExact(page);
    assert.deepEqual([...s.datasets].sort(), ["ml", "oriented", "sparse"]);
    const options = await page.$$eval("#dataset option", (o) => o.map((x) => x.value));
    assert.deepEqual(options, s.datasets);
    assert.equal(s.dataset, s.datasets[0]);
    assert.deepEqual(s.canvas, SIZE);
    assert.ok(H.litPixels(await H.canvasPixels(page)) > 500, "the frame shows the volume");
    // The view is written to the URL, so the link opens the same dataset.
    await page.waitForFunction((d) => location.search.includes(`dataset=${d}`), {}, s.dataset);
    await H.screenshot(page, "load");
    assert.deepEqual(page.errors, []);
    await page.close();
  });

  test("a still frame is the frame voxbrick render draws, pixel for pixel", async () => {
    const cases = [
      { url: "dataset=sparse&orbit=30,20&tf=grayscale", flags: ["--orbit", "30,20", "--tf", "grayscale"] },
      {
        url: "dataset=ml&orbit=75,-30,3.5&tf=mri&window=0.1,0.9&shading=1",
        flags: ["--orbit", "75,-30,3.5", "--tf", "mri", "--window", "0.1,0.9", "--shading"],
      },
      { url: "dataset=ml&view=superior&tf=hot", flags: ["--view", "superior", "--tf", "hot"] },
    ];
    // A renderer's frame can differ from a fresh one's by 1/255 after it drew other views (`voxbrick orbit` shows it
    // too; so does `render --progressive` against `render`), so each case has a fresh server with one render thread,
    // whose first frames are those of the page's progressive Render, and the reference is drawn the same way.
    for (const c of cases) {
      const fresh = await new H.Server({ dir: scratch.dir, datasets, extra: ["--render-threads", "1"] }).start();
      try {
        const page = await H.openPage(browser, `${fresh.url}/?${c.url}&${SIZE_PARAM}`);
        const s = await waitExact(page);
        const shown = await H.canvasPixels(page);
        // The canvas holds the PNG the server sent, untouched: no scaling, no colour management.
        assert.deepEqual(H.compareImages(shown, H.decodePng(await lastPayload(page))), { differing: 0, maxDiff: 0 });
        assert.equal(s.lastScene.progressive, true);
        const ref = reference(s.dataset, [...c.flags, "--progressive"]);
        assert.ok(H.litPixels(ref) > 200, `the reference of ${c.url} shows the volume`);
        assert.deepEqual(
          H.compareImages(shown, ref),
          { differing: 0, maxDiff: 0 },
          `${c.url}: ${JSON.stringify(s.lastScene)}`,
        );
        await page.close();
      } finally {
        await fresh.kill();
      }
    }
  });

  test("a drag turns the camera, frames keep arriving, and the exact frame follows the release", async () => {
    const { page, start, x0, y0 } = await pressOnFrame(browser, `${server.url}/?dataset=sparse&${SIZE_PARAM}`);
    const steps = 30;
    for (let i = 1; i <= steps; ++i) {
      await page.mouse.move(x0 + i * 4, y0 + i * 1);
      await new Promise((r) => setTimeout(r, 33));
    }
    const during = await H.viewerState(page);
    await H.screenshot(page, "drag");
    await page.mouse.up();
    const shownDuring = during.counts.shown - start.counts.shown;
    assert.ok(shownDuring >= 4, `frames shown while dragging: ${shownDuring}`);
    assert.ok(Math.abs(during.view.az - (30 - steps * 4 * 0.4)) < 1e-6, `azimuth ${during.view.az}`);
    assert.ok(during.view.el > 20, `elevation ${during.view.el}`);
    const s = await H.waitForState(page, (st) => st.exactAfterReleaseMs !== null && !st.lastFrame.provisional);
    const done = await waitExact(page, 0);
    assert.deepEqual(done.lastScene.camera.orbit, [done.view.az, done.view.el], "the last frame is of the last camera");
    assert.ok(s.exactAfterReleaseMs < 5000, `exact frame ${s.exactAfterReleaseMs} ms after the release`);
    // Version 8 (video from 4 on): provisional frames of the drag travel as the vp8 stream (Chromium decodes it;
    // video.test.mjs has the rest), every exact frame as png (on loopback, no webp).
    assert.equal(done.capabilities.version, 9);
    assert.equal(done.features.video, "vp8");
    const frames = await page.evaluate(() => window.voxbrickViewer.frames());
    for (const f of frames) assert.equal(f.encoding, f.provisional && f.phase === "drag" ? 4 : 1, JSON.stringify(f));
    assert.equal(done.video.errors, 0);
    // Interactive Renders while dragging: provisional frames drawn within the time budget.
    assert.ok(done.features.interactive && done.features.time_budget_ms, JSON.stringify(done.features));
    assert.ok(
      frames.filter((f) => f.phase === "drag" && f.provisional).length >= 3,
      "provisional frames while dragging",
    );
    const ref = reference("sparse", ["--orbit", `${done.view.az},${done.view.el}`]);
    assertNearlyEqual(await H.canvasPixels(page), ref, "the exact frame after the release");
    // The address follows the view within 250 ms (it is written at most that often).
    const wanted = `orbit=${Number(done.view.az.toFixed(4))}`;
    await page.waitForFunction((w) => location.search.includes(w), { timeout: 5000 }, wanted).catch(() => {});
    const address = await page.evaluate(() => location.href);
    assert.ok(address.includes(wanted), address);
    await page.close();
  });

  test("a release asks for the last camera as a still Render, drawn exact without waiting for the camera to rest", async () => {
    const { page, start, x0, y0 } = await pressOnFrame(browser, `${server.url}/?dataset=sparse&${SIZE_PARAM}`);
    for (let i = 1; i <= 10; ++i) {
      await page.mouse.move(x0 - i * 4, y0);
      await new Promise((r) => setTimeout(r, 33));
    }
    await page.mouse.up(); // at once: the last drag Render's exact frame would wait for the camera to rest first
    const s = await H.waitForState(page, (st) => st.exactAfterReleaseMs !== null && !st.lastFrame.provisional);
    assert.ok(s.newestId > start.newestId, "Renders were sent");
    // The Render after the release is a still one of the last camera (unless that camera's exact frame had come
    // already, within the moment between the last move and the release).
    assert.ok(
      s.exactAfterReleaseMs === 0 || s.lastScene.interactive !== true,
      `the last Render: ${JSON.stringify(s.lastScene)}`,
    );
    assert.deepEqual(s.lastScene.camera.orbit, [s.view.az, s.view.el], "of the last camera");
    await page.close();
  });

  test("wheel zooms, shift-drag pans, and a pan of nothing is the orbit's frame", async () => {
    // The camera sent as eye, centre and up (a pan too small to move a pixel) gives the orbit's frame, for a volume
    // centred on the origin and for one in a patient frame.
    for (const dataset of ["oriented", "ml"]) {
      const p = await H.openPage(browser, `${server.url}/?dataset=${dataset}&orbit=40,25,3&${SIZE_PARAM}`);
      const orbitFrame = await waitExact(p);
      const orbitPixels = await H.canvasPixels(p);
      assert.ok(H.litPixels(orbitPixels) > 500, `${dataset} shows`);
      await p.evaluate(() => window.voxbrickViewer.setView({ pan: [1e-7, 0] }));
      const moved = await waitExact(p, orbitFrame.newestId);
      assert.ok(moved.lastScene.camera.eye && moved.lastScene.camera.center && moved.lastScene.camera.up);
      assertNearlyEqual(orbitPixels, await H.canvasPixels(p), `${dataset}: eye, centre and up against the orbit`);
      await p.close();
    }
    const page = await H.openPage(browser, `${server.url}/?dataset=ml&orbit=40,25,3&pan=0.00001,0&${SIZE_PARAM}`);
    const still = await waitExact(page);
    const stillPixels = await H.canvasPixels(page);
    const box = await (await page.$("#frame")).boundingBox();
    const [x0, y0] = [box.x + box.width / 2, box.y + box.height / 2];
    await page.mouse.move(x0, y0);
    await page.mouse.wheel({ deltaY: -200 });
    const zoomed = await H.waitForState(page, (st) => st.view.dist < 3 && st.lastScene.camera.eye !== undefined);
    await waitExact(page, still.newestId);
    // The frame too: the volume nearer (3 radii to 2.46), so larger. Measured: 18673 of the 20480 pixels differ, and
    // 1.37 times as many are lit (the frame's edges cut the volume, or it would be 1.49).
    const zoomedPixels = await H.canvasPixels(page);
    const [a, b] = [footprint(stillPixels), footprint(zoomedPixels)];
    const zoomDiff = H.compareImages(stillPixels, zoomedPixels);
    assert.ok(zoomDiff.differing > (SIZE[0] * SIZE[1]) / 2, `the zoomed frame differs: ${JSON.stringify(zoomDiff)}`);
    assert.ok(b.lit > a.lit * 1.2, `lit pixels ${a.lit} before the wheel, ${b.lit} after`);
    await page.keyboard.down("Shift");
    await page.mouse.down();
    for (let i = 1; i <= 5; ++i) await page.mouse.move(x0 + 6 * i, y0);
    await page.mouse.up();
    await page.keyboard.up("Shift");
    const panned = await waitExact(page, zoomed.newestId);
    assert.ok(panned.view.pan[0] < -0.05, `pan ${panned.view.pan}`);
    assert.equal(panned.view.az, 40, "a pan does not turn the camera");
    // The frame too: the volume follows the pointer, 30 pixels to the right, and stays at its height. Measured: the
    // lit pixels' centre moved 17.6 pixels right (the frame's right edge cuts off what moved past it) and 1.1 down.
    const c = footprint(await H.canvasPixels(page));
    assert.ok(c.x - b.x > 10 && c.x - b.x < 30, `the volume's centre moved from column ${b.x} to ${c.x}`);
    assert.ok(Math.abs(c.y - b.y) < 4, `the volume's centre moved from row ${b.y} to ${c.y}`);
    await page.waitForFunction(() => location.search.includes("pan="), { timeout: 5000 }).catch(() => {});
    const address = await page.evaluate(() => location.href);
    assert.ok(address.includes("pan="), address);
    await page.close();
  });

  test("touch: one finger orbits, two fingers pinch to zoom", async () => {
    const page = await H.openPage(browser, `${server.url}/?dataset=sparse&orbit=30,20,3&${SIZE_PARAM}`, {
      width: 720,
      height: 420,
      hasTouch: true,
      isMobile: false,
    });
    const start = await waitExact(page);
    const startPixels = await H.canvasPixels(page);
    const box = await (await page.$("#frame")).boundingBox();
    const [x, y] = [box.x + box.width / 2, box.y + box.height / 2];
    const cdp = await page.createCDPSession();
    const touch = (type, points) =>
      cdp.send("Input.dispatchTouchEvent", { type, touchPoints: points.map(([px, py], id) => ({ x: px, y: py, id })) });
    await touch("touchStart", [[x, y]]);
    for (let i = 1; i <= 5; ++i) await touch("touchMove", [[x + 10 * i, y]]);
    await touch("touchEnd", []);
    const turned = await waitExact(page, start.newestId);
    assert.ok(Math.abs(turned.view.az - (30 - 50 * 0.4)) < 1e-6, `azimuth ${turned.view.az}`);
    // The frame too: the volume turned 20 degrees (measured: 2151 pixels differ).
    const turnedPixels = await H.canvasPixels(page);
    const turnDiff = H.compareImages(startPixels, turnedPixels);
    assert.ok(turnDiff.differing > 1000, `the turned frame differs: ${JSON.stringify(turnDiff)}`);
    // Fingers 40 px apart, then 80: twice as close.
    await touch("touchStart", [
      [x - 20, y],
      [x + 20, y],
    ]);
    for (let i = 1; i <= 4; ++i)
      await touch("touchMove", [
        [x - 20 - 5 * i, y],
        [x + 20 + 5 * i, y],
      ]);
    await touch("touchEnd", []);
    const zoomed = await waitExact(page, turned.newestId);
    assert.ok(Math.abs(zoomed.view.dist - 1.5) < 1e-6, `distance ${zoomed.view.dist}`);
    assert.equal(zoomed.view.az, turned.view.az, "a pinch does not turn");
    // The frame too: the volume twice as near (measured: 3.9 times as many pixels lit).
    const [t, z] = [footprint(turnedPixels), footprint(await H.canvasPixels(page))];
    assert.ok(z.lit > t.lit * 2, `lit pixels ${t.lit} before the pinch, ${z.lit} after`);
    await page.close();
  });

  test("a transfer-function change draws again, and the curve editor shows the chosen preset", async () => {
    const page = await H.openPage(browser, `${server.url}/?dataset=ml&tf=grayscale&${SIZE_PARAM}`);
    await waitExact(page);
    const before = await H.waitForState(page, (st) => st.presets !== null);
    // The page lists the server's presets and draws each one's own curve: those `voxbrick presets --json` prints.
    const presets = JSON.parse(H.voxbrick(["presets", "--json"]));
    const byName = Object.fromEntries(presets.map((p) => [p.name, p.points]));
    assert.deepEqual(before.presets, byName);
    const options = await page.$$eval("#tf option", (o) => o.map((x) => x.value));
    assert.deepEqual(options, [...presets.map((p) => p.name), "custom"]);
    assert.deepEqual(before.curve, { points: byName.grayscale, active: false });
    const grey = await H.canvasPixels(page);
    await page.select("#tf", "hot");
    const s = await waitExact(page, before.newestId);
    assert.equal(s.lastScene.transfer_function, "hot");
    assert.deepEqual(s.curve, { points: byName.hot, active: false }, "the curve is hot's, not the grey ramp");
    assert.notDeepEqual(byName.hot, byName.mri);
    await page.select("#tf", "mri");
    assert.deepEqual((await H.viewerState(page)).curve.points, byName.mri);
    await page.select("#tf", "hot");
    const hot = await H.canvasPixels(page);
    assert.ok(H.compareImages(grey, hot).differing > 500, "the frame changed");
    // The curve editor: a double-click adds a point to the preset's curve and makes the transfer function that
    // inline curve.
    const curve = await (await page.$("#curve")).boundingBox();
    const hotNow = await waitExact(page, s.newestId);
    await page.mouse.click(curve.x + curve.width * 0.6, curve.y + curve.height * 0.2, { count: 2 });
    const c = await waitExact(page, hotNow.newestId);
    assert.equal(c.view.tf, "custom");
    assert.equal(c.lastScene.transfer_function.points.length, byName.hot.length + 1);
    assert.deepEqual(c.curve.active, true);
    await H.screenshot(page, "curve");
    assert.ok(H.compareImages(hot, await H.canvasPixels(page)).differing > 500, "the curve's frame differs");
    await page.close();
  });

  test("an unknown dataset in the address gets a note, and the rest of the address is kept", async () => {
    const rest = "orbit=75,-30,3.5&tf=mri&shading=1";
    const cases = [
      // Case aside, it names one: that one opens.
      { name: "SPARSE", opens: "sparse", note: /No dataset “SPARSE” on this server; showing “sparse”/ },
      // A few edits away: suggested, the first opens.
      { name: "sprase", opens: "ml", note: /showing “ml”\. Did you mean “sparse”\?/ },
      // Nothing near: the first, with the list.
      { name: "no-such", opens: "ml", note: /showing “ml”\. It has: “ml”, “oriented”, “sparse”\./ },
    ];
    for (const c of cases) {
      const page = await H.openPage(browser, `${server.url}/?dataset=${c.name}&${rest}&${SIZE_PARAM}`);
      const s = await waitExact(page);
      assert.equal(s.dataset, c.opens, c.name);
      assert.match(s.datasetNote, c.note, c.name);
      assert.deepEqual(s.lastScene.camera.orbit, [75, -30, 3.5], `${c.name}: the orbit is kept`);
      assert.equal(s.lastScene.transfer_function, "mri", `${c.name}: the transfer function is kept`);
      assert.equal(s.lastScene.shading, true, `${c.name}: shading is kept`);
      await page.waitForFunction((d) => location.search.includes(`dataset=${d}`), {}, c.opens);
      // Choosing a dataset clears the note.
      await page.select("#dataset", "oriented");
      await H.waitForState(page, (st) => st.dataset === "oriented" && st.datasetNote === "");
      await page.close();
    }
  });

  test("Save frame saves the server's exact frame as a PNG", async () => {
    const page = await H.openPage(browser, `${server.url}/?dataset=ml&view=left&tf=hot&${SIZE_PARAM}`);
    await waitExact(page);
    const downloads = fs.mkdtempSync(path.join(scratch.dir, "downloads-"));
    const cdp = await browser.target().createCDPSession();
    await cdp.send("Browser.setDownloadBehavior", { behavior: "allow", downloadPath: downloads });
    await page.click("#save");
    const file = path.join(downloads, "voxbrick-ml-left.png");
    const payload = await lastPayload(page);
    // Chromium may name the file before it has written it: wait for all of its bytes.
    const size = () => (fs.existsSync(file) ? fs.statSync(file).size : -1);
    const t0 = Date.now();
    while (size() < payload.length && Date.now() - t0 < 10000) await new Promise((r) => setTimeout(r, 50));
    assert.ok(fs.existsSync(file), `saved ${fs.readdirSync(downloads)}`);
    assert.deepEqual(fs.readFileSync(file), payload);
    assert.deepEqual(
      H.compareImages(H.decodePng(fs.readFileSync(file)), await H.canvasPixels(page)),
      { differing: 0, maxDiff: 0 },
    );
    await cdp.detach();
    await page.close();
  });

  test("lossless=webp: the exact frame travels as lossless webp, the canvas holds voxbrick render's frame, and Save frame writes it as a PNG", async () => {
    // By default the page accepts webp (scene key accepts_webp) and, on loopback, gets png.
    const auto = await H.openPage(browser, `${server.url}/?dataset=sparse&orbit=30,20&tf=grayscale&${SIZE_PARAM}`);
    const a = await waitExact(auto);
    assert.equal(a.lastScene.accepts_webp, true);
    assert.equal(a.lastFrame.encoding, 1, "png on a link that keeps up");
    await auto.close();
    // A fresh server with one render thread, whose first frames are the page's (see the still-frame test).
    const fresh = await new H.Server({ dir: scratch.dir, datasets, extra: ["--render-threads", "1"] }).start();
    try {
      const page = await H.openPage(browser, `${fresh.url}/?dataset=sparse&orbit=30,20&tf=grayscale&lossless=webp&${SIZE_PARAM}`);
      const s = await waitExact(page);
      assert.equal(s.capabilities.version, 9);
      assert.equal(s.lastFrame.encoding, 6, "webp");
      assert.equal(s.lastScene.accepts_webp, undefined, "asked as the Render's encoding");
      const payload = await lastPayload(page);
      assert.equal(payload.subarray(8, 12).toString(), "WEBP");
      const shown = await H.canvasPixels(page);
      const ref = reference("sparse", ["--orbit", "30,20", "--tf", "grayscale", "--progressive"]);
      assert.ok(H.litPixels(ref) > 200, "the reference shows the volume");
      assert.deepEqual(H.compareImages(shown, ref), { differing: 0, maxDiff: 0 });
      // Save frame writes a PNG of the canvas (not the webp's bytes): voxbrick render's image.
      const downloads = fs.mkdtempSync(path.join(scratch.dir, "downloads-"));
      const cdp = await browser.target().createCDPSession();
      await cdp.send("Browser.setDownloadBehavior", { behavior: "allow", downloadPath: downloads });
      await page.click("#save");
      const file = path.join(downloads, "voxbrick-sparse-30_20.png");
      const t0 = Date.now();
      let saved = null;
      while (!saved && Date.now() - t0 < 10000) {
        try {
          saved = H.decodePng(fs.readFileSync(file));
        } catch {
          await new Promise((r) => setTimeout(r, 50)); // not yet there, or not yet whole
        }
      }
      assert.ok(saved, `saved ${fs.readdirSync(downloads)}`);
      assert.deepEqual(H.compareImages(saved, ref), { differing: 0, maxDiff: 0 });
      await cdp.detach();
      assert.deepEqual(page.errors, []);
      await page.close();
    } finally {
      await fresh.kill();
    }
  });

  test("a quality target the dataset has no table for is dropped, and the page says why", async () => {
    const page = await H.openPage(browser, `${server.url}/?dataset=sparse&quality=psnr:40&${SIZE_PARAM}`);
    const s = await waitExact(page);
    assert.equal(s.view.quality, "");
    assert.equal(s.lastScene.quality, undefined);
    assert.equal(s.counts.refused, 1);
    const note = await page.$eval("#quality-note", (n) => (n.hidden ? "" : n.textContent));
    assert.match(note, /no quality table/);
    await page.waitForFunction(() => !location.search.includes("quality="));
    await page.close();
  });

  test("two tabs on different datasets each get their own frames", async () => {
    const [a, b] = await Promise.all([
      H.openPage(browser, `${server.url}/?dataset=sparse&${SIZE_PARAM}`),
      H.openPage(browser, `${server.url}/?dataset=ml&${SIZE_PARAM}`),
    ]);
    const [sa, sb] = await Promise.all([waitExact(a), waitExact(b)]);
    assert.equal(sa.dataset, "sparse");
    assert.equal(sb.dataset, "ml");
    // Both turn at once; each gets the frame of its own camera and dataset.
    await Promise.all([
      a.evaluate(() => window.voxbrickViewer.setView({ az: 120 })),
      b.evaluate(() => window.voxbrickViewer.setView({ az: 200 })),
    ]);
    const [ta, tb] = await Promise.all([waitExact(a, sa.newestId), waitExact(b, sb.newestId)]);
    assert.deepEqual(ta.lastScene.camera.orbit, [120, 20]);
    assert.deepEqual(tb.lastScene.camera.orbit, [200, 20]);
    const [pa, pb] = [await H.canvasPixels(a), await H.canvasPixels(b)];
    assertNearlyEqual(pa, reference("sparse", ["--orbit", "120,20"]), "tab a");
    assertNearlyEqual(pb, reference("ml", ["--orbit", "200,20"]), "tab b");
    await Promise.all([a.close(), b.close()]);
  });

  test("a page from another origin is refused and says why", async () => {
    const port = await H.freePort();
    const other = await H.staticServer(port);
    try {
      const page = await H.openPage(
        browser,
        `http://127.0.0.1:${port}/?server=127.0.0.1:${server.httpPort}&${SIZE_PARAM}`,
      );
      const s = await H.waitForState(page, (st) => st.connection === "refused");
      assert.match(s.banner, /Refused/);
      assert.match(s.banner, /origin/);
      assert.equal(s.counts.shown, 0);
      await H.screenshot(page, "other-origin");
      await page.close();
      // The server itself refuses the upgrade from that origin, and takes it from its own.
      const upgrade = (origin) =>
        H.httpGet(`${server.url}/ws`, {
          Connection: "Upgrade",
          Upgrade: "websocket",
          "Sec-WebSocket-Version": "13",
          "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==",
          Origin: origin,
        });
      assert.equal((await upgrade(`http://127.0.0.1:${port}`)).status, 403);
    } finally {
      other.close();
    }
  });

  test("a wrong token is refused and the right one is taken", async () => {
    const tokenServer = await new H.Server({
      dir: scratch.dir,
      datasets,
      extra: ["--http-token", "s3cret"],
    }).start();
    try {
      const bad = await H.openPage(browser, `${tokenServer.url}/?token=wrong&${SIZE_PARAM}`);
      const s = await H.waitForState(bad, (st) => st.connection === "refused");
      assert.match(s.banner, /Refused by the server: .*token/);
      assert.equal(s.counts.shown, 0);
      await H.screenshot(bad, "wrong-token");
      await bad.close();
      const good = await H.openPage(browser, `${tokenServer.url}/?token=s3cret&${SIZE_PARAM}`);
      await waitExact(good);
      // The token leaves the address (history, bookmarks, the address bar) once the page has it, and is kept in
      // memory: the view goes on being written there, the token never again; the link to the status page has it.
      await good.waitForFunction(() => location.search.includes("dataset="));
      assert.doesNotMatch(await good.evaluate(() => location.href), /token|s3cret/);
      assert.match(await good.$eval("#status-link", (a) => a.href), /status\.html\?token=s3cret$/);
      await good.close();
    } finally {
      await tokenServer.kill();
    }
  });

  test("a session the server closed as idle comes back when the person does", async () => {
    const idleServer = await new H.Server({ dir: scratch.dir, datasets, extra: ["--idle-timeout", "1"] }).start();
    try {
      const page = await H.openPage(browser, `${idleServer.url}/?dataset=sparse&${SIZE_PARAM}`);
      const first = await waitExact(page);
      const idle = await H.waitForState(page, (st) => st.connection === "idle", 10000);
      assert.match(idle.banner, /idle session/);
      assert.match(idle.reason, /Timeout/);
      // No reconnection loop while nobody is there.
      await new Promise((r) => setTimeout(r, 1500));
      assert.equal((await H.viewerState(page)).connection, "idle");
      const box = await (await page.$("#frame")).boundingBox();
      await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
      await page.mouse.wheel({ deltaY: 100 });
      const back = await H.waitForState(
        page,
        (st, shown) => st.connection === "ready" && !st.lastFrame.provisional && st.counts.shown > shown,
        10000,
        first.counts.shown,
      );
      assert.ok(back.view.dist > 0, "the wheel that woke it zoomed");
      await page.close();
    } finally {
      await idleServer.kill();
    }
  });

  test("a server over capacity answers Busy, and the page comes back after the server's hint", async () => {
    // One dragging session is all this server takes (max_interactive_sessions), and while it is taken a new session
    // is refused at Hello (busy_at_hello); a TCP client drags for 3 s.
    const busyServer = await H.configuredServer(scratch.dir, datasets, "busy",
      "[scheduler]\nmax_interactive_sessions = 1\nbusy_at_hello = true\n");
    const { load, loaded } = tcpDragger(busyServer);
    try {
      await new Promise((r) => setTimeout(r, 700)); // its first moving frames
      const page = await H.openPage(browser, `${busyServer.url}/?dataset=sparse&${SIZE_PARAM}`);
      const busy = await H.waitForState(page, (st) => st.connection === "busy", 10000);
      assert.match(busy.banner, /The server is busy: the server is over capacity/);
      assert.match(busy.banner, /Retrying in/);
      const hint = Number(/retry after (\d+) ms/.exec(busy.reason)[1]);
      assert.ok(hint > 0, busy.reason);
      // The wait is the server's hint (up to a fifth more), not the page's own backoff.
      assert.ok(busy.retryMs >= hint && busy.retryMs <= Math.ceil(1.2 * hint), `${busy.retryMs} against ${hint}`);
      await loaded;
      const back = await waitExact(page);
      assert.equal(back.connection, "ready");
      assert.equal(back.banner, "");
      await page.close();
    } finally {
      load.kill("SIGKILL");
      await busyServer.kill();
    }
  });

  test("a first drag beyond the server's capacity is answered Busy: the page waits out the hint, then drags", async () => {
    // The page is taken while nobody drags; then eight TCP clients drag for 3 s, on a server that keeps one dragging
    // session (max_interactive_sessions): one drags, the others wait in line, and the page's drag goes behind them.
    const busyServer = await H.configuredServer(scratch.dir, datasets, "busy-drag",
      "[scheduler]\nmax_interactive_sessions = 1\n");
    let load = null;
    try {
      const { page, start, x0, y0 } = await pressOnFrame(browser, `${busyServer.url}/?dataset=sparse&${SIZE_PARAM}`);
      const dragger = tcpDragger(busyServer, 8);
      load = dragger.load;
      const loaded = dragger.loaded;
      await new Promise((r) => setTimeout(r, 700)); // their first moving frames and refusals
      for (let i = 1; i <= 30; ++i) {
        await page.mouse.move(x0 + 2 * i, y0);
        await new Promise((r) => setTimeout(r, 30));
      }
      const held = await H.viewerState(page);
      // One drags, or none for a moment while a turn changes hands (a drag held 2 s while others wait is paused).
      const ahead = /^The server is busy: the server is over capacity: [01] sessions are dragging and (\d+) wait ahead/
        .exec(held.banner);
      assert.ok(ahead && Number(ahead[1]) >= 5, held.banner);
      // The hint: a quarter second for the first eight places in line, a quarter more for each eight behind.
      const hint = Math.min(0.25 * (1 + Math.floor(Number(ahead[1]) / 8)), 1);
      const again = Number(/Asking again in (\d+\.\d) s/.exec(held.banner)[1]);
      assert.ok(again >= hint - 0.05 && again <= hint * 1.2 + 0.05, `${held.banner}: the server's hint (${hint} s), a fifth more at most`);
      // Asked at every move, a second of dragging would have sent some thirty Renders to be refused; waiting out a
      // quarter second each, four or five.
      assert.ok(held.counts.busy >= 1 && held.counts.busy <= 8, `${held.counts.busy} Busy replies in a 1 s drag`);
      assert.equal(held.counts.errors, start.counts.errors, "Busy is no error");
      assert.equal(held.counts.shown, start.counts.shown, "no moving frame meanwhile");
      // Released while held: the exact frame is asked at once, not after the hint, and drawn as the drag's last.
      const upAt = await page.evaluate(() => performance.now());
      await page.mouse.up();
      const exact = await waitExact(page, held.newestId);
      assert.ok(exact.newestSentAt - upAt < 100, `asked at ${exact.newestSentAt}, released at ${upAt}`);
      assert.equal(exact.lastStats.class, "interactive", JSON.stringify(exact.lastStats));
      assert.equal(exact.banner, "", "the banner goes with the frame");
      await loaded;
      // Once the TCP client has stopped, the page's next drag is taken: its frames show.
      await page.mouse.down();
      for (let i = 1; i <= 5; ++i) await page.mouse.move(x0 + 60 - 4 * i, y0);
      const back = await H.waitForState(
        page,
        (st, n) => st.counts.shown > n && st.lastFrame.phase === "drag",
        15000,
        exact.counts.shown,
      );
      assert.equal(back.connection, "ready", "the session was kept throughout");
      await page.mouse.up();
      await page.close();
    } finally {
      if (load) load.kill("SIGKILL");
      await busyServer.kill();
    }
  });

  test("a drag held a whole turn while another waits is paused, and draws again when its turn comes back", async () => {
    // A server that keeps one dragging session, with the default turn (2 s): the page drags alone, then a TCP client
    // asks to drag and waits in line. The page's drag, two seconds old, is told Busy at its next move (its turn is
    // over); the TCP client drags its own turn, and the page, dragging all along, is taken again.
    const turnServer = await H.configuredServer(scratch.dir, datasets, "turn", "[scheduler]\nmax_interactive_sessions = 1\n");
    let load = null;
    let moving = true;
    let mover = null;
    try {
      const { page, start, x0, y0 } = await pressOnFrame(browser, `${turnServer.url}/?dataset=sparse&${SIZE_PARAM}`);
      mover = (async () => {
        for (let i = 0; moving; ++i) {
          await page.mouse.move(x0 + 40 * Math.sin(i / 10), y0);
          await new Promise((r) => setTimeout(r, 30));
        }
      })();
      const alone = await H.waitForState(
        page,
        (st, n) => st.counts.shown > n + 2 && st.lastFrame.phase === "drag",
        15000,
        start.counts.shown,
      );
      assert.equal(alone.counts.busy, start.counts.busy, "a drag alone is not paused");
      const dragger = tcpDragger(turnServer, 1, 12);
      load = dragger.load;
      const paused = await H.waitForState(page, (st) => /turn to drag is over/.test(st.banner), 15000);
      assert.match(paused.banner, /^The server is busy: this session's turn to drag is over \(2 s, interactive_turn_s\): 1 sessions wait to drag/);
      assert.equal(paused.counts.errors, start.counts.errors, "Busy is no error");
      const back = await H.waitForState(
        page,
        (st, n) => st.counts.shown > n && st.lastFrame.phase === "drag" && st.banner === "",
        15000,
        paused.counts.shown,
      );
      assert.equal(back.connection, "ready", "the session was kept throughout");
      moving = false;
      await mover;
      await page.mouse.up();
      await page.close();
    } finally {
      moving = false;
      if (mover) await mover.catch(() => {});
      if (load) load.kill("SIGKILL");
      await turnServer.kill();
    }
  });

  test("still Renders past a frame-rate quota are waited out, not asked again at once", async () => {
    const quotaServer = await H.configuredServer(scratch.dir, datasets, "quota", "[quotas]\nframes_per_s_per_address = 2\n");
    try {
      const page = await H.openPage(browser, `${quotaServer.url}/?dataset=sparse&${SIZE_PARAM}`);
      const first = await waitExact(page);
      const box = await (await page.$("#frame")).boundingBox();
      await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
      for (let i = 0; i < 8; ++i) await page.mouse.wheel({ deltaY: 40 }); // eight views at once: past 2 a second
      const done = await H.waitForState(
        page,
        (st, n) => st.counts.busy > 0 && st.lastFrame.id === st.newestId && !st.lastFrame.provisional && st.counts.shown > n,
        15000,
        first.counts.shown,
      );
      // Asked again at once, each refused still Render would have been followed by another within milliseconds
      // until the quota had room (half a second): dozens of refusals.
      assert.ok(done.counts.busy <= 4, `${done.counts.busy} Busy replies`);
      assert.equal(done.counts.errors, first.counts.errors, "Busy is no error");
      assert.equal(done.view.dist, (await H.viewerState(page)).view.dist, "the last view's frame is shown");
      await page.close();
    } finally {
      await quotaServer.kill();
    }
  });

  test("the server killed shows the error state, and a restart reconnects to the same view", async () => {
    const page = await H.openPage(browser, `${server.url}/?dataset=ml&orbit=100,10,3&tf=hot&${SIZE_PARAM}`);
    await waitExact(page);
    const before = await H.canvasPixels(page);
    await server.kill();
    const down = await H.waitForState(
      page,
      (st) => st.connection === "disconnected" && st.banner.includes("Disconnected"),
    );
    assert.match(down.banner, /Retrying/);
    await H.screenshot(page, "server-gone");
    await server.start();
    const back = await H.waitForState(
      page,
      (st, shown) =>
        st.connection === "ready" &&
        !st.lastFrame.provisional &&
        st.lastFrame.id === st.newestId &&
        st.counts.shown > shown,
      30000,
      down.counts.shown,
    );
    assert.equal(back.dataset, "ml");
    assert.deepEqual(back.lastScene.camera.orbit, [100, 10, 3]);
    assert.equal(back.banner, "");
    assertNearlyEqual(before, await H.canvasPixels(page), "the same view after reconnecting");
    await page.close();
  });
});
