// The viewer in a notebook cell (python/voxbrick/notebook.py), in Chromium without Jupyter: the cell's HTML, made by
// the Python package, on a page of another origin whose `IPython.notebook.kernel.execute` is a stub that records the
// code it is given. The viewer in the cell's IFrame opens the view Python set, posts its view to the cell once asked
// (web/js/main.js), and the code the cell hands the kernel, run in Python, gives the Python view the viewer's state;
// its snapshot is the frame on the viewer's canvas.
import assert from "node:assert/strict";
import { spawnSync } from "node:child_process";
import http from "node:http";
import path from "node:path";
import { after, before, test } from "node:test";
import * as H from "./harness.mjs";

const PYTHON = process.env.VOXBRICK_PYTHON || "/usr/bin/python3";
const TOKEN = "nb-Token_1";
const ARGS = "camera=(30, 20), tf='hot', size=(160, 120)";

/// Runs Python code with the package on its path; its stdout parsed as JSON.
function python(code, ...args) {
  const r = spawnSync(PYTHON, ["-c", code, ...args], {
    encoding: "utf8",
    env: { ...process.env, PYTHONPATH: path.join(H.SOURCE_DIR, "python") },
    maxBuffer: 64 << 20,
  });
  if (r.status !== 0) throw new Error(`python failed (${r.status}): ${r.stderr}`);
  return JSON.parse(r.stdout);
}

let scratch, server, browser, page, pageServer;

before(async () => {
  scratch = H.scratchDir("notebook");
  const datasets = H.prepDatasets(scratch.dir, { blobs: "synthetic:blobs,n=32" });
  server = await new H.Server({ dir: scratch.dir, datasets, extra: ["--http-token", TOKEN] }).start();
  browser = await H.launchBrowser();
});

after(async () => {
  if (browser) await browser.close();
  if (pageServer) pageServer.close();
  if (server) await server.kill("SIGTERM");
  scratch.remove();
});

test("the viewer in a cell reports its view to the kernel, and the snapshot is its frame", async () => {
  const cell = python(
    `import json, sys, voxbrick
v = voxbrick.view('blobs', server=sys.argv[1], token=sys.argv[2], ${ARGS})
print(json.dumps({'id': v.id, 'html': v._repr_html_()}))`,
    server.url,
    TOKEN,
  );
  // The notebook's page: another origin (its own port), a kernel that records what it is asked to run.
  const html = `<!doctype html><html><body><script>
window.executed = [];
window.IPython = { notebook: { kernel: { execute: (code, callbacks, options) => window.executed.push({ code, options }) } } };
</script>${cell.html}</body></html>`;
  pageServer = http.createServer((req, res) => res.writeHead(200, { "content-type": "text/html" }).end(html));
  await new Promise((resolve) => pageServer.listen(0, "127.0.0.1", resolve));
  page = await browser.newPage();
  page.errors = [];
  page.on("pageerror", (e) => page.errors.push(e.message));
  await page.setViewport({ width: 800, height: 600, deviceScaleFactor: 1 });
  await page.goto(`http://127.0.0.1:${pageServer.address().port}/`, { waitUntil: "load" });

  const viewer = page.frames().find((f) => f.url().startsWith(server.url));
  assert.ok(viewer, `the cell holds the viewer: ${page.frames().map((f) => f.url())}`);
  // The view's address, the token taken out of it once the page has read it (web/js/token.js), before its viewer
  // started. Read in the page: the frame's `url()` follows history.replaceState only once Chromium's event has come.
  await viewer.waitForFunction(() => window.voxbrickViewer !== undefined, { timeout: 20000 });
  // The viewer may have written its view to the address meanwhile (its own order of the keys): compared as keys.
  assert.deepEqual(H.addressKeys(await viewer.evaluate(() => location.href)), {
    dataset: "blobs",
    orbit: "30,20",
    tf: "hot",
    size: "160x120",
  });
  await page.waitForFunction(() => window.executed.length >= 1, { timeout: 20000 });
  // The view Python set, as the viewer holds it.
  const first = await H.waitForState(viewer, (s) => s.lastFrame && !s.lastFrame.provisional);
  assert.deepEqual([first.view.az, first.view.el, first.view.tf, first.canvas], [30, 20, "hot", [160, 120]]);

  // The person turns the camera and switches shading on: the cell hands the new view to the kernel.
  const before = await page.evaluate(() => window.executed.length);
  await viewer.evaluate(() => window.voxbrickViewer.setView({ view: null, az: 100, el: 5, dist: 3, shading: true }));
  // The report of the new view: the reports are sent at most every 250 ms, so one of the first view may still come
  // after setView.
  await page.waitForFunction(
    (n) => {
      if (window.executed.length <= n) return false;
      const m = /_report\("[0-9a-f]{32}", (".*")\)$/.exec(window.executed[window.executed.length - 1].code);
      const view = m && JSON.parse(JSON.parse(m[1])).view;
      return !!view && view.az === 100 && view.shading === true;
    },
    { timeout: 20000, polling: 25 },
    before,
  );
  // The exact frame shown is of the new view (`view` changes at once, the frame shown after).
  const shown = await H.waitForState(
    viewer,
    (s) =>
      s.lastFrame &&
      !s.lastFrame.provisional &&
      s.lastFrame.scene.shading === true &&
      JSON.stringify(s.lastFrame.scene.camera) === JSON.stringify({ orbit: [100, 5, 3] }),
  );
  const canvas = await H.canvasPixels(viewer);
  const executed = await page.evaluate(() => window.executed);
  for (const { code, options } of executed) {
    assert.match(code, /^import voxbrick\.notebook as _voxbrick_nb; _voxbrick_nb\._report\("[0-9a-f]{32}", "/);
    assert.deepEqual(options, { silent: true, store_history: false });
  }

  // The same code run in the kernel (a Python process with a view of the same id) gives the Python view that state,
  // and its snapshot is the frame on the canvas.
  const kernel = python(
    `import base64, json, sys, voxbrick, voxbrick.notebook as nb
v = voxbrick.view('blobs', server=sys.argv[1], token=sys.argv[2], ${ARGS})
del nb._views[v.id]
v.id = sys.argv[3]
nb._views[v.id] = v
for code in json.loads(sys.argv[4]):
    exec(code)
image = v.snapshot()
print(json.dumps({'state': v.state, 'shape': image.shape, 'rgba': base64.b64encode(image.tobytes()).decode()}))`,
    server.url,
    TOKEN,
    cell.id,
    JSON.stringify(executed.map((e) => e.code)),
  );
  assert.deepEqual(kernel.state, {
    dataset: "blobs",
    view: null,
    az: 100,
    el: 5,
    dist: 3,
    pan: [0, 0],
    tf: "hot",
    points: null,
    window: null,
    shading: true,
    quality: "",
    size: [160, 120],
  });
  assert.deepEqual(kernel.shape, [120, 160, 4]);
  const snapshot = Buffer.from(kernel.rgba, "base64");
  let worst = 0;
  for (let i = 0; i < snapshot.length; ++i) worst = Math.max(worst, Math.abs(snapshot[i] - canvas.rgba[i]));
  // The viewer's exact frame and the snapshot are one scene drawn twice by the server: the same within 1/255
  // (PROTOCOL.md, Session 8: where a brick lies in the atlas depends on the frames before).
  assert.ok(worst <= 1, `the snapshot differs from the canvas by ${worst}/255`);
  assert.ok(canvas.rgba.some((v, i) => i % 4 !== 3 && v > 50), "the canvas shows the volume");
  assert.equal(shown.lastFrame.scene.shading, true);
  assert.deepEqual(page.errors, []);
  await H.screenshot(page, "notebook-cell");
});
