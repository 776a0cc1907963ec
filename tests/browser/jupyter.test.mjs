// The viewer in a real Jupyter: a real Notebook 6 server (Debian's jupyter-notebook) with a real IPython kernel, the
// real `voxbrick serve --http`, and Chromium driving the notebook's own page. A notebook made here calls
// `voxbrick.view(...)`; the test runs its cell from Jupyter's UI, finds the viewer's IFrame in the output, waits for
// its exact frame, drags it through the viewer's own gesture handlers, and sees the camera turn and a new frame shown;
// a second cell then reads `v.state` in the kernel, which the cell's script has kept up to date (docs/python.md), and
// takes a snapshot, the frame on the canvas.
//
// Every process started here (Jupyter, its kernel, the server, Chromium) is ended in `after`, and again, by process
// id, when this process exits; Jupyter and the server are also killed by Linux if this process dies first (setpriv
// --pdeathsig, H.spawnTied), and the kernel ends itself once Jupyter is gone (ipykernel's parent poller).
import assert from "node:assert/strict";
import fs from "node:fs";
import http from "node:http";
import path from "node:path";
import { after, before, test } from "node:test";
import * as H from "./harness.mjs";

const PYTHON = process.env.VOXBRICK_PYTHON || "/usr/bin/python3";
const TOKEN = "jup-Token_1"; // the voxbrick server's
const JUPYTER_TOKEN = "jupyter-test-token"; // Jupyter's
const SIZE = [160, 120];
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const t0 = Date.now();
const elapsed = () => `${((Date.now() - t0) / 1000).toFixed(1)} s`;

let scratch, server, browser, page, jupyter;

/// Jupyter's REST API: {status, body}, or null when nothing answers.
function jupyterApi(method, route) {
  return new Promise((resolve) => {
    const req = http.request(
      `${jupyter.url}${route}`,
      { method, headers: { Authorization: `token ${JUPYTER_TOKEN}` } },
      (res) => {
        const chunks = [];
        res.on("data", (c) => chunks.push(c));
        res.on("end", () => resolve({ status: res.statusCode, body: Buffer.concat(chunks).toString() }));
      },
    );
    req.on("error", () => resolve(null));
    req.setTimeout(5000, () => req.destroy());
    req.end();
  });
}

/// The ids of the processes whose command line names `dir` (Jupyter's kernels: their connection files lie in the
/// scratch directory's runtime folder), this process excluded.
function processesNaming(dir) {
  const found = [];
  for (const entry of fs.readdirSync("/proc")) {
    if (!/^\d+$/.test(entry) || Number(entry) === process.pid) continue;
    try {
      if (fs.readFileSync(`/proc/${entry}/cmdline`, "utf8").includes(dir + path.sep)) found.push(Number(entry));
    } catch {
      // gone meanwhile
    }
  }
  return found;
}

const alive = (pid) => {
  try {
    process.kill(pid, 0);
    return true;
  } catch {
    return false;
  }
};

/// Ends Jupyter and its kernels: Jupyter's own shutdown first (it shuts its kernels down), then SIGKILL for what is
/// left.
async function stopJupyter() {
  if (!jupyter) return;
  if (jupyter.proc.exitCode === null && jupyter.proc.signalCode === null) {
    if (jupyter.url) await jupyterApi("POST", "/api/shutdown");
    const deadline = Date.now() + 5000;
    while (alive(jupyter.proc.pid) && jupyter.proc.exitCode === null && Date.now() < deadline) await sleep(50);
    if (jupyter.proc.exitCode === null && jupyter.proc.signalCode === null) {
      console.error("cleanup: Jupyter did not stop within 5 s of /api/shutdown: killed");
      jupyter.proc.kill("SIGKILL");
      await jupyter.exited;
    }
  }
  killLeftovers(path.join(scratch.dir, "jupyter")); // a kernel Jupyter left
}

/// SIGKILL for Jupyter and every process naming `dir` (its kernels name their connection files in dir/jupyter; the
/// server its datasets in dir).
function killLeftovers(dir = scratch && scratch.dir) {
  if (jupyter && jupyter.proc.exitCode === null && jupyter.proc.signalCode === null) jupyter.proc.kill("SIGKILL");
  if (!dir) return;
  for (const pid of processesNaming(dir)) {
    try {
      process.kill(pid, "SIGKILL");
    } catch {
      // gone meanwhile
    }
  }
}

// Whatever happens to the test (a failure in `before`, an exception), nothing it started outlives it.
process.on("exit", () => killLeftovers());

/// Starts Notebook 6 on a free port, in the scratch directory, with its own kernel spec (PYTHON), its own
/// configuration, data and runtime folders (nothing of the user's), and the environment the notebook reads.
async function startJupyter(dir) {
  const port = await H.freePort();
  const home = path.join(dir, "jupyter");
  const kernels = path.join(home, "data", "kernels", "voxbrick-test");
  fs.mkdirSync(kernels, { recursive: true });
  fs.mkdirSync(path.join(home, "config"), { recursive: true });
  fs.mkdirSync(path.join(home, "runtime"), { recursive: true });
  fs.mkdirSync(path.join(home, "ipython"), { recursive: true });
  fs.writeFileSync(
    path.join(kernels, "kernel.json"),
    JSON.stringify({
      argv: [PYTHON, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
      display_name: "voxbrick test",
      language: "python",
    }),
  );
  const notebooks = path.join(dir, "notebooks");
  fs.mkdirSync(notebooks, { recursive: true });
  const args = [
    "notebook",
    "--no-browser",
    "--ip=127.0.0.1",
    `--port=${port}`,
    // The port is a hint: another test may take it between freePort and Jupyter's bind, so Jupyter tries the next
    // ones and the test reads the port it took from its server file (below).
    "--port-retries=50",
    `--notebook-dir=${notebooks}`,
    `--NotebookApp.token=${JUPYTER_TOKEN}`,
    "--NotebookApp.password=",
    "--MappingKernelManager.default_kernel_name=voxbrick-test",
    ...(process.getuid && process.getuid() === 0 ? ["--allow-root"] : []),
  ];
  const env = {
    ...process.env,
    PYTHONPATH: path.join(H.SOURCE_DIR, "python"),
    VOXBRICK_VIEWER: `${server.url}/?token=${TOKEN}`,
    VOXBRICK_DATASET: "blobs",
    JUPYTER_CONFIG_DIR: path.join(home, "config"),
    JUPYTER_DATA_DIR: path.join(home, "data"),
    JUPYTER_PATH: path.join(home, "data"),
    JUPYTER_RUNTIME_DIR: path.join(home, "runtime"),
    IPYTHONDIR: path.join(home, "ipython"),
    MPLBACKEND: "agg",
  };
  const logFile = path.join(dir, "jupyter.log");
  const log = fs.openSync(logFile, "w");
  // Tied to this process: Linux kills Jupyter if this process dies before `after`.
  const proc = H.spawnTied(PYTHON, ["-m", ...args], {
    cwd: notebooks,
    env,
    stdio: ["ignore", log, log],
  });
  fs.closeSync(log);
  jupyter = { proc, port: null, url: null, notebooks, logFile };
  jupyter.exited = new Promise((resolve) => proc.on("exit", (code, signal) => resolve(code ?? signal)));
  jupyter.log = () => fs.readFileSync(logFile, "utf8");
  // Notebook 6 writes its address to runtime/nbserver-<pid>.json once it listens.
  const serverFile = path.join(home, "runtime", `nbserver-${proc.pid}.json`);
  const deadline = Date.now() + 60000;
  while (Date.now() < deadline) {
    if (proc.exitCode !== null || proc.signalCode !== null)
      throw new Error(
        `Jupyter exited (${proc.exitCode ?? proc.signalCode}; scripts/setup.sh installs Debian's jupyter-notebook): ` +
          jupyter.log(),
      );
    if (!jupyter.port && fs.existsSync(serverFile)) {
      try {
        jupyter.port = JSON.parse(fs.readFileSync(serverFile, "utf8")).port;
        jupyter.url = `http://127.0.0.1:${jupyter.port}`;
      } catch {
        // written meanwhile: read again
      }
    }
    const r = jupyter.port && (await jupyterApi("GET", "/api/status"));
    if (r && r.status === 200) return jupyter;
    await sleep(100);
  }
  throw new Error(`Jupyter did not answer within 60 s: ${jupyter.log()}`);
}

/// The notebook: cell 0 shows the view, cell 1 prints what the kernel holds of it (its state and snapshot).
function writeNotebook(dir) {
  const code = (lines) => ({ cell_type: "code", metadata: {}, execution_count: null, outputs: [], source: lines });
  const notebook = {
    nbformat: 4,
    nbformat_minor: 5,
    metadata: { kernelspec: { name: "voxbrick-test", display_name: "voxbrick test", language: "python" } },
    cells: [
      code([
        "import base64, json, os, voxbrick\n",
        "v = voxbrick.view(os.environ['VOXBRICK_DATASET'], server=os.environ['VOXBRICK_VIEWER'],\n",
        `                  camera=(30, 20), tf='hot', size=(${SIZE[0]}, ${SIZE[1]}))\n`,
        "v",
      ]),
      code([
        "image = v.snapshot()\n",
        "print('VOXBRICK-KERNEL ' + json.dumps({'state': v.state, 'shape': image.shape,\n",
        "                                       'rgba': base64.b64encode(image.tobytes()).decode()}))",
      ]),
    ],
  };
  for (const [i, c] of notebook.cells.entries()) c.id = `cell-${i}`;
  fs.writeFileSync(path.join(dir, "view.ipynb"), JSON.stringify(notebook, null, 1));
}

/// Runs cell `i` from Jupyter's UI and waits until the kernel has answered it (its prompt numbered); its outputs.
async function runCell(i, timeout = 60000) {
  await page.evaluate((i) => {
    const cell = Jupyter.notebook.get_cell(i);
    cell.input_prompt_number = null;
    Jupyter.notebook.execute_cells([i]);
  }, i);
  try {
    await page.waitForFunction(
      (i) => {
        const cell = Jupyter.notebook.get_cell(i);
        return typeof cell.input_prompt_number === "number" && !Jupyter.notebook.kernel_busy;
      },
      { timeout, polling: 50 },
      i,
    );
  } catch (e) {
    const outputs = await page.evaluate((i) => Jupyter.notebook.get_cell(i).output_area.outputs, i).catch(() => null);
    throw new Error(`cell ${i} did not finish: ${e.message}; outputs ${JSON.stringify(outputs)}`);
  }
  const outputs = await page.evaluate((i) => Jupyter.notebook.get_cell(i).output_area.outputs, i);
  const errors = outputs.filter((o) => o.output_type === "error" || o.name === "stderr");
  assert.deepEqual(errors, [], `cell ${i} failed`);
  return outputs;
}

/// The views the cell's script handed the kernel (the `_report` calls), parsed.
const reports = () =>
  page.evaluate(() =>
    window.voxbrickReports.map((code) => {
      const m = /_report\(("[0-9a-f]{32}"), (".*")\)$/.exec(code);
      return m ? { id: JSON.parse(m[1]), ...JSON.parse(JSON.parse(m[2])) } : { unparsed: code };
    }),
  );

before(async () => {
  scratch = H.scratchDir("jupyter");
  const datasets = H.prepDatasets(scratch.dir, { blobs: "synthetic:blobs,n=32" });
  server = await new H.Server({ dir: scratch.dir, datasets, extra: ["--http-token", TOKEN] }).start();
  [browser] = await Promise.all([H.launchBrowser(), startJupyter(scratch.dir)]);
  writeNotebook(jupyter.notebooks);
  console.log(`# set up (prep, server, Jupyter, Chromium) in ${elapsed()}`);
});

after(async () => {
  const steps = [
    async () => browser && (await browser.close()),
    stopJupyter,
    async () => server && (await server.kill("SIGTERM")),
  ];
  for (const step of steps) {
    try {
      await step();
    } catch (e) {
      console.error(`cleanup: ${e.message}`);
    }
  }
  if (scratch) {
    const left = processesNaming(scratch.dir);
    if (left.length) console.error(`cleanup: processes left: ${left}`);
    scratch.remove();
  }
  console.log(`# done in ${elapsed()}`);
});

/// What the test saw of Jupyter and its page, for a failure's message: the page's errors and console, the end of
/// Jupyter's log (a kernel that died and restarted says so there).
function diagnosis() {
  const lines = [];
  if (page) {
    lines.push(`page errors: ${JSON.stringify(page.errors)}`);
    lines.push(`page console (last 20): ${JSON.stringify(page.consoleLines.slice(-20))}`);
  }
  if (jupyter) {
    const log = jupyter.log().trim().split("\n");
    lines.push(`Jupyter (port ${jupyter.port}) log, last 30 lines:\n  ${log.slice(-30).join("\n  ")}`);
  }
  return lines.join("\n");
}

test("a notebook's voxbrick.view turns in the browser and the kernel reads the view back", async () => {
  try {
    await notebookScenario();
  } catch (e) {
    console.error(`# failed at ${elapsed()}; what the test saw:\n${diagnosis()}`);
    throw e;
  }
});

async function notebookScenario() {
  page = await browser.newPage();
  page.errors = [];
  page.consoleLines = [];
  page.on("pageerror", (e) => page.errors.push(e.message));
  page.on("console", (m) => page.consoleLines.push(`${m.type()}: ${m.text()}`));
  await page.setViewport({ width: 1000, height: 800, deviceScaleFactor: 1 });
  await page.goto(`${jupyter.url}/notebooks/view.ipynb?token=${JUPYTER_TOKEN}`, { waitUntil: "load" });
  // The notebook is loaded and its kernel (a fresh IPython) connected.
  await page.waitForFunction(
    () =>
      window.Jupyter &&
      Jupyter.notebook &&
      Jupyter.notebook._fully_loaded &&
      Jupyter.notebook.kernel &&
      Jupyter.notebook.kernel.is_connected(),
    { timeout: 60000, polling: 50 },
  );
  // What the cell's script hands the kernel is recorded on its way (the call itself goes on unchanged).
  await page.evaluate(() => {
    const kernel = Jupyter.notebook.kernel;
    const execute = kernel.execute.bind(kernel);
    window.voxbrickReports = [];
    kernel.execute = (code, callbacks, options) => {
      if (code.includes("_voxbrick_nb._report(")) window.voxbrickReports.push(code);
      return execute(code, callbacks, options);
    };
  });
  console.log(`# notebook open, kernel connected at ${elapsed()}`);

  // Cell 0: the view, shown in its output as the viewer's IFrame.
  const shownOutputs = await runCell(0);
  const html = shownOutputs.map((o) => (o.data && o.data["text/html"]) || "").join("");
  assert.match(html, /<iframe src="http:\/\/127\.0\.0\.1:\d+\/\?dataset=blobs&amp;orbit=30,20&amp;tf=hot&amp;size=160/);
  // The output's IFrame, once it has navigated to the viewer (until then it is about:blank).
  await page.waitForSelector(".output_area iframe", { timeout: 30000 });
  const viewer = await page.waitForFrame((f) => f.url().startsWith(`${server.url}/`), { timeout: 40000 });
  await viewer.waitForFunction(() => window.voxbrickViewer !== undefined, { timeout: 30000 });
  // The cell's address carried the token (the HTML above); the page took it out of its address once read
  // (web/js/token.js), before its viewer started. Read in the page: the frame's `url()` follows the page's
  // history.replaceState only when Chromium's event for it has arrived.
  const address = await viewer.evaluate(() => location.href);
  assert.ok(address.startsWith(`${server.url}/?`), address);
  // The viewer may have written its view to the address meanwhile (its own order of the keys): compared as keys.
  assert.deepEqual(H.addressKeys(address), { dataset: "blobs", orbit: "30,20", tf: "hot", size: "160x120" });
  assert.match(html, /size=160x120&amp;token=/);
  const first = await H.waitForState(viewer, (s) => s.lastFrame && !s.lastFrame.provisional, 40000);
  assert.deepEqual([first.view.az, first.view.el, first.view.tf, first.canvas], [30, 20, "hot", SIZE]);
  const firstPixels = await H.canvasPixels(viewer);
  assert.ok(H.litPixels(firstPixels) > 100, "the first frame shows the volume");
  // The cell asked the viewer for its view, and handed the first one to the kernel.
  await page.waitForFunction(() => window.voxbrickReports.length >= 1, { timeout: 30000 });
  const id = (await reports())[0].id;
  console.log(`# first exact frame at ${elapsed()}`);

  // A drag: 16 moves of 3 degrees of azimuth and 1 of elevation through the viewer's own gesture handlers.
  const drag = await viewer.evaluate(() => window.voxbrickViewer.drag({ durationMs: 800, hz: 20, dAz: 3, dEl: 1 }));
  // The exact frame shown is of the released camera (`view` follows the moves at once, the frames after them).
  const turned = await H.waitForState(
    viewer,
    (s) =>
      s.lastFrame &&
      !s.lastFrame.provisional &&
      s.view.az !== 30 &&
      JSON.stringify(s.lastFrame.scene.camera) === JSON.stringify({ orbit: [s.view.az, s.view.el] }),
    40000,
  );
  assert.ok(drag.moves >= 5, `the drag moved ${drag.moves} times`);
  assert.equal(turned.view.view, null);
  assert.ok(Math.abs(turned.view.az - (30 + 3 * drag.moves)) < 1e-9, `az ${turned.view.az} after ${drag.moves} moves`);
  assert.ok(Math.abs(turned.view.el - (20 + drag.moves)) < 1e-9, `el ${turned.view.el} after ${drag.moves} moves`);
  assert.ok(turned.lastFrame.id > first.lastFrame.id, "a new exact frame is shown");
  const turnedPixels = await H.canvasPixels(viewer);
  const { differing } = H.compareImages(firstPixels, turnedPixels);
  assert.ok(differing > 100, `a new frame is shown (${differing} pixels changed)`);
  // The released view reaches the kernel (the viewer posts it within 250 ms of the release).
  let posted = await reports();
  for (const deadline = Date.now() + 30000; Date.now() < deadline; posted = await reports()) {
    const last = posted[posted.length - 1];
    if (last && last.view && last.view.az === turned.view.az && last.view.el === turned.view.el) break;
    await sleep(50);
  }
  const last = posted[posted.length - 1];
  assert.deepEqual([last.view.az, last.view.el], [turned.view.az, turned.view.el], "the released view is reported");
  assert.ok(posted.every((r) => r.id === id && r.view), JSON.stringify(posted));
  console.log(`# dragged (${drag.moves} moves), ${posted.length} views handed to the kernel, at ${elapsed()}`);

  // Cell 1: the kernel's view is the viewer's, and its snapshot is the frame on the canvas.
  const outputs = await runCell(1);
  const text = outputs.map((o) => o.text || "").join("");
  const line = text.split("\n").find((l) => l.startsWith("VOXBRICK-KERNEL "));
  assert.ok(line, `cell 1 printed: ${text.slice(0, 500)}`);
  const kernel = JSON.parse(line.slice("VOXBRICK-KERNEL ".length));
  assert.deepEqual(kernel.state, {
    dataset: "blobs",
    view: null,
    az: turned.view.az,
    el: turned.view.el,
    dist: null,
    pan: [0, 0],
    tf: "hot",
    points: null,
    window: null,
    shading: false,
    quality: "",
    size: SIZE,
  });
  assert.deepEqual(kernel.shape, [SIZE[1], SIZE[0], 4]);
  const snapshot = Buffer.from(kernel.rgba, "base64");
  let worst = 0;
  for (let i = 0; i < snapshot.length; ++i) worst = Math.max(worst, Math.abs(snapshot[i] - turnedPixels.rgba[i]));
  // One scene drawn twice by the server: the same within 1/255 (PROTOCOL.md, Session 8).
  assert.ok(worst <= 1, `the kernel's snapshot differs from the canvas by ${worst}/255`);
  assert.deepEqual(page.errors, []);
  await H.screenshot(page, "jupyter-notebook");
  console.log(`# the kernel holds the dragged view, at ${elapsed()}`);
}
