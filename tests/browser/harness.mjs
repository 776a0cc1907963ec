// What the browser tests and the drag benchmark share: small datasets made with the real `voxbrick prep`, the real
// `voxbrick serve --http` process on free ports, Debian's Chromium driven by puppeteer-core, a PNG decoder (to read
// `voxbrick render`'s output without the browser) and screenshots.

import { spawn, spawnSync } from "node:child_process";
import crypto from "node:crypto";
import fs from "node:fs";
import http from "node:http";
import https from "node:https";
import net from "node:net";
import os from "node:os";
import path from "node:path";
import { fileURLToPath } from "node:url";
import zlib from "node:zlib";
import puppeteer from "puppeteer-core";

export const SOURCE_DIR = path.resolve(path.dirname(fileURLToPath(import.meta.url)), "../..");
export const VOXBRICK = process.env.VOXBRICK_EXE || path.join(SOURCE_DIR, "build/voxbrick");
export const CHROMIUM = process.env.VOXBRICK_CHROMIUM || "/usr/bin/chromium";
export const SCREENSHOTS = process.env.VOXBRICK_SCREENSHOTS || path.join(SOURCE_DIR, "build/browser-screenshots");
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/// Runs `voxbrick ARGS`; throws with its output if it fails.
export function voxbrick(args, options = {}) {
  const r = spawnSync(VOXBRICK, args, { encoding: "utf8", ...options });
  if (r.status !== 0) throw new Error(`voxbrick ${args.join(" ")} failed (${r.status}): ${r.stdout}${r.stderr}`);
  return r.stdout;
}

/// A fresh scratch directory, removed by `remove()`.
export function scratchDir(tag) {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), `voxbrick-${tag}-`));
  return { dir, remove: () => fs.rmSync(dir, { recursive: true, force: true }) };
}

/// Preps `specs` ({name: input}) into DIR/datasets with small bricks; returns the datasets directory.
export function prepDatasets(dir, specs) {
  const datasets = path.join(dir, "datasets");
  fs.mkdirSync(datasets, { recursive: true });
  for (const [name, input] of Object.entries(specs))
    voxbrick(["prep", input, "--brick", "16", "--no-vdb", "-q", "-o", path.join(datasets, name)]);
  return datasets;
}

/// A port no one listens on now (the kernel's pick, closed again).
export function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.on("error", reject);
    s.listen(0, "127.0.0.1", () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
  });
}

/// GET `url` (http:// or https://, `ca`: the PEM text of the CAs to trust for https): {status, body}, or null when
/// nothing answers.
export function httpGet(url, headers = {}, ca = undefined) {
  return new Promise((resolve) => {
    const get = url.startsWith("https:") ? https.get : http.get;
    const req = get(url, { headers, ...(ca ? { ca } : {}) }, (res) => {
      const chunks = [];
      res.on("data", (c) => chunks.push(c));
      res.on("end", () => resolve({ status: res.statusCode, headers: res.headers, body: Buffer.concat(chunks) }));
    });
    req.on("error", () => resolve(null));
    req.setTimeout(5000, () => req.destroy());
  });
}

/// spawn(), with the child tied to this process: Linux sends it SIGKILL if this process dies first (setpriv
/// --pdeathsig, util-linux), so a test killed by a timeout or a signal leaves no server behind. Without setpriv, a
/// plain spawn.
const SETPRIV = fs.existsSync("/usr/bin/setpriv") ? "/usr/bin/setpriv" : null;
export function spawnTied(exe, args, options) {
  return SETPRIV ? spawn(SETPRIV, ["--pdeathsig", "KILL", "--", exe, ...args], options) : spawn(exe, args, options);
}

let starts = 0; // servers started by this process, for their files' names

/// The real server: `voxbrick serve --no-config --port 0 --http PORT --datasets DIR [extra]` (PORT 0: a free one,
/// kept for restarts), its log in `dir`; `exe`: another build's binary (a benchmark's baseline), else VOXBRICK;
/// `tls`: {cert, key, ca} files (testCertificates) for TLS on both ports, its url then https://; `config`: a
/// server.toml read in place of no configuration (`datasets` may then be left to it).
export class Server {
  constructor({ dir, datasets = null, httpPort = 0, extra = [], exe = VOXBRICK, tls = null, config = null }) {
    Object.assign(this, { dir, datasets, httpPort, extra, exe, tls, config, proc: null });
  }

  /// Starts the server; a restart listens on the HTTP port of the first start.
  async start() {
    // Unique among all servers of the process: a second server in the same directory must not read the first one's
    // port files.
    const tag = `${process.pid}-${starts++}`;
    const portFile = path.join(this.dir, `port-${tag}`);
    const httpPortFile = path.join(this.dir, `http-port-${tag}`);
    this.logFile = path.join(this.dir, `serve-${tag}.log`);
    const log = fs.openSync(this.logFile, "w");
    const args = ["serve", ...(this.config ? ["--config", this.config] : ["--no-config"])];
    args.push("--port", "0", "--port-file", portFile, ...(this.datasets ? ["--datasets", this.datasets] : []));
    args.push("--http", String(this.httpPort || 0), "--http-port-file", httpPortFile, ...this.extra);
    if (this.tls) args.push("--tls-cert", this.tls.cert, "--tls-key", this.tls.key);
    const ca = this.tls ? fs.readFileSync(this.tls.ca) : undefined;
    this.proc = spawnTied(this.exe, args, { stdio: ["ignore", log, log] });
    fs.closeSync(log);
    this.exited = new Promise((resolve) => this.proc.on("exit", (code, signal) => resolve(code ?? signal)));
    let gone = false;
    this.exited.then(() => (gone = true));
    const deadline = Date.now() + 60000;
    while (Date.now() < deadline) {
      if (gone) throw new Error(`the server exited: ${this.log()}`);
      if (fs.existsSync(portFile) && fs.existsSync(httpPortFile)) {
        this.tcpPort = Number(fs.readFileSync(portFile, "utf8"));
        this.httpPort = Number(fs.readFileSync(httpPortFile, "utf8"));
        const r = await httpGet(`${this.url}/`, {}, ca);
        if (r && r.status === 200) return this;
      }
      await sleep(50);
    }
    await this.kill();
    throw new Error(`the server did not answer HTTP within 60 s: ${this.log()}`);
  }

  get url() {
    return `${this.tls ? "https" : "http"}://127.0.0.1:${this.httpPort}`;
  }

  log() {
    try {
      return fs.readFileSync(this.logFile, "utf8");
    } catch {
      return "(no log)";
    }
  }

  /// Kills the process (SIGKILL by default: the server gone without a word) and waits for it.
  async kill(signal = "SIGKILL") {
    if (!this.proc || this.proc.exitCode !== null || this.proc.signalCode !== null) return;
    this.proc.kill(signal);
    await this.exited;
  }
}

/// A started Server over `datasets` configured by `toml` (written to `dir`/`name`.toml): a test's own limits.
export function configuredServer(dir, datasets, name, toml) {
  const config = path.join(dir, `${name}.toml`);
  fs.writeFileSync(config, toml);
  return new Server({ dir, datasets, config }).start();
}

/// A plain static server of web/ on another port: a page from another origin.
export function staticServer(port) {
  const web = path.join(SOURCE_DIR, "web");
  const types = { ".html": "text/html", ".js": "text/javascript", ".css": "text/css" };
  const s = http.createServer((req, res) => {
    const p = new URL(req.url, "http://x").pathname;
    const file = path.join(web, path.normalize(p === "/" ? "/index.html" : p));
    if (!file.startsWith(web)) return res.writeHead(404).end();
    fs.readFile(file, (e, d) => {
      if (e) return res.writeHead(404).end();
      res.writeHead(200, { "content-type": types[path.extname(file)] || "application/octet-stream" }).end(d);
    });
  });
  return new Promise((resolve) => s.listen(port, "127.0.0.1", () => resolve(s)));
}

/// A test CA and a server certificate it signs for 127.0.0.1 and localhost, made with Debian's openssl in `dir`:
/// {ca, cert, key} paths, and `spki`, the base-64 SHA-256 of the certificate's public key (what Chromium's
/// --ignore-certificate-errors-spki-list takes).
export function testCertificates(dir) {
  const run = (args) => {
    const r = spawnSync("openssl", args, { encoding: "utf8" });
    if (r.status !== 0) throw new Error(`openssl ${args.join(" ")} failed: ${r.stderr}`);
    return r.stdout;
  };
  const f = (name) => path.join(dir, name);
  const ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes"];
  run(["req", "-x509", ...ec, "-days", "2", "-subj", "/CN=voxbrick browser test CA", "-keyout", f("ca.key"),
       "-out", f("ca.pem"), "-addext", "basicConstraints=critical,CA:TRUE"]);
  run(["req", ...ec, "-subj", "/CN=voxbrick browser test", "-keyout", f("server.key"), "-out", f("server.csr")]);
  fs.writeFileSync(f("server.ext"), "subjectAltName=IP:127.0.0.1,DNS:localhost\nextendedKeyUsage=serverAuth\n");
  run(["x509", "-req", "-in", f("server.csr"), "-CA", f("ca.pem"), "-CAkey", f("ca.key"), "-CAcreateserial",
       "-days", "2", "-out", f("server.pem"), "-extfile", f("server.ext")]);
  const publicKey = new crypto.X509Certificate(fs.readFileSync(f("server.pem"))).publicKey;
  const spki = crypto.createHash("sha256").update(publicKey.export({ type: "spki", format: "der" })).digest("base64");
  return { ca: f("ca.pem"), cert: f("server.pem"), key: f("server.key"), spki };
}

/// Headless Chromium, the system's (no browser download). Pages get 1 device pixel per CSS pixel, no colour
/// management, so a canvas holds a frame's pixels as they came. Driven over a pipe, not a WebSocket: Chromium ends
/// when this process does, even killed. `extraArgs`: more of Chromium's switches.
export function launchBrowser(extraArgs = []) {
  if (!fs.existsSync(CHROMIUM)) throw new Error(`no Chromium at ${CHROMIUM} (scripts/setup.sh installs Debian's)`);
  return puppeteer.launch({
    executablePath: CHROMIUM,
    headless: true,
    pipe: true,
    args: [
      ...(process.getuid && process.getuid() === 0 ? ["--no-sandbox"] : []),
      "--force-color-profile=srgb",
      "--disable-gpu",
      "--disable-dev-shm-usage",
      "--disable-background-timer-throttling",
      "--disable-renderer-backgrounding",
      "--disable-backgrounding-occluded-windows",
      ...extraArgs,
    ],
  });
}

/// A new page at `url`, its console errors collected in page.errors; `beforeLoad`, a function run in the page before
/// any of its own scripts (to watch what it does from the start).
export async function openPage(browser, url, viewport = { width: 720, height: 420 }, beforeLoad = null) {
  const page = await browser.newPage();
  page.errors = [];
  page.on("pageerror", (e) => page.errors.push(e.message));
  await page.setViewport({ ...viewport, deviceScaleFactor: 1 });
  if (beforeLoad) await page.evaluateOnNewDocument(beforeLoad);
  await page.goto(url, { waitUntil: "load" });
  await page.waitForFunction(() => window.voxbrickViewer !== undefined, { timeout: 10000 });
  return page;
}

export const viewerState = (page) => page.evaluate(() => window.voxbrickViewer.state());

/// Waits until `predicate(state)` (a function source run in the page on voxbrickViewer.state()) holds.
export async function waitForState(page, predicate, timeout = 20000, arg = null) {
  try {
    await page.waitForFunction(`(${predicate})(window.voxbrickViewer.state(), ${JSON.stringify(arg)})`, {
      timeout,
      polling: 25,
    });
  } catch (e) {
    const s = await viewerState(page).catch(() => null);
    if (s) delete s.lastStats;
    throw new Error(`${e.message}: waiting for ${predicate} in state ${JSON.stringify(s)}`);
  }
  return viewerState(page);
}

/// Waits for the viewer's exact frame of its newest request, one newer than request `afterId`.
export const waitExact = (page, afterId = 0, timeout = 20000) =>
  waitForState(
    page,
    (s, after) => s.lastFrame && !s.lastFrame.provisional && s.lastFrame.id === s.newestId && s.newestId > after,
    timeout,
    afterId,
  );

/// The query of a page's address as an object of its keys (decoded; a key given twice keeps its last value): what a
/// test compares when the order of the keys is the page's business.
export function addressKeys(address) {
  return Object.fromEntries(new URL(address).searchParams.entries());
}

/// The canvas pixels: {width, height, rgba: Buffer}.
export async function canvasPixels(page) {
  const p = await page.evaluate(() => window.voxbrickViewer.pixels());
  return { width: p.width, height: p.height, rgba: Buffer.from(p.rgba, "base64") };
}

/// Copies the canvas as it is now (the page's `snapshot`: a few ms, where reading the pixels out takes hundreds at
/// 1024x1024); resolves with the copy's index for `snapshotPixels`.
export function snapshotCanvas(page) {
  return page.evaluate(() => window.voxbrickViewer.snapshot());
}

/// Snapshot `index`'s pixels, as canvasPixels gives them, and `frame`: the frame the canvas showed then.
export async function snapshotPixels(page, index) {
  const p = await page.evaluate((i) => window.voxbrickViewer.snapshotPixels(i), index);
  return { width: p.width, height: p.height, rgba: Buffer.from(p.rgba, "base64"), frame: p.frame };
}

/// PSNR in dB of the RGB of two images of one size ({rgba} rows of 4 bytes a pixel); Infinity when they are equal.
export function psnrRgb(a, b) {
  if (a.rgba.length !== b.rgba.length) throw new Error(`psnrRgb: ${a.width}x${a.height} against ${b.width}x${b.height}`);
  let sum = 0;
  let n = 0;
  for (let i = 0; i < a.rgba.length; i += 4)
    for (let c = 0; c < 3; ++c) {
      const d = a.rgba[i + c] - b.rgba[i + c];
      sum += d * d;
      ++n;
    }
  return sum ? 10 * Math.log10((255 * 255 * n) / sum) : Infinity;
}

export async function screenshot(page, name) {
  fs.mkdirSync(SCREENSHOTS, { recursive: true });
  const file = path.join(SCREENSHOTS, `${name}.png`);
  await page.screenshot({ path: file });
  return file;
}

/// Decodes an 8-bit, non-interlaced PNG (RGBA, RGB, grey or grey-alpha) into RGBA rows.
export function decodePng(buffer) {
  if (buffer.readUInt32BE(0) !== 0x89504e47) throw new Error("not a PNG");
  let at = 8;
  let width, height, depth, colour, interlace;
  const idat = [];
  while (at < buffer.length) {
    const len = buffer.readUInt32BE(at);
    const type = buffer.toString("latin1", at + 4, at + 8);
    const data = buffer.subarray(at + 8, at + 8 + len);
    if (type === "IHDR")
      [width, height, depth, colour, interlace] = [
        data.readUInt32BE(0),
        data.readUInt32BE(4),
        data[8],
        data[9],
        data[12],
      ];
    else if (type === "IDAT") idat.push(data);
    else if (type === "IEND") break;
    at += 12 + len;
  }
  const channels = { 0: 1, 2: 3, 4: 2, 6: 4 }[colour];
  if (depth !== 8 || !channels || interlace) throw new Error(`PNG depth ${depth} colour ${colour} not read here`);
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const stride = width * channels;
  const rows = Buffer.alloc(stride * height);
  for (let y = 0; y < height; ++y) {
    const filter = raw[y * (stride + 1)];
    const src = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let x = 0; x < stride; ++x) {
      const a = x >= channels ? rows[y * stride + x - channels] : 0;
      const b = y > 0 ? rows[(y - 1) * stride + x] : 0;
      const c = x >= channels && y > 0 ? rows[(y - 1) * stride + x - channels] : 0;
      const paeth = () => {
        const p = a + b - c;
        const [pa, pb, pc] = [Math.abs(p - a), Math.abs(p - b), Math.abs(p - c)];
        return pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      };
      const pred = [0, a, b, (a + b) >> 1, filter === 4 ? paeth() : 0][filter];
      if (pred === undefined) throw new Error(`PNG filter ${filter}`);
      rows[y * stride + x] = (src[x] + pred) & 0xff;
    }
  }
  const rgba = Buffer.alloc(width * height * 4);
  for (let i = 0; i < width * height; ++i) {
    const s = rows.subarray(i * channels, (i + 1) * channels);
    const [r, g, b, al] =
      channels >= 3 ? [s[0], s[1], s[2], channels === 4 ? s[3] : 255] : [s[0], s[0], s[0], channels === 2 ? s[1] : 255];
    rgba.set([r, g, b, al], i * 4);
  }
  return { width, height, rgba };
}

/// A small NRRD in a patient frame (24 x 20 x 16 u8; index axes i, j, k along anterior, left and superior with
/// spacing 1.5, 1 and 2; origin (10, -20, 30)): an off-centre ball and a slab, so a misplaced camera shows.
export function orientedNrrd() {
  const [nx, ny, nz] = [24, 20, 16];
  const data = Buffer.alloc(nx * ny * nz);
  for (let k = 0; k < nz; ++k)
    for (let j = 0; j < ny; ++j)
      for (let i = 0; i < nx; ++i) {
        const ball = Math.max(0, Math.min(255, Math.round(255 - Math.hypot(i - 6, j - 12, k - 10) * 22)));
        data[i + nx * (j + ny * k)] = Math.min(255, ball + (i > 18 ? 60 : 0));
      }
  const header = [
    "NRRD0004",
    "type: uint8",
    "dimension: 3",
    "space: right-anterior-superior",
    `sizes: ${nx} ${ny} ${nz}`,
    "space directions: (0,1.5,0) (-1,0,0) (0,0,2)",
    "space origin: (10,-20,30)",
    "encoding: raw",
    "endian: little",
    "",
    "",
  ].join("\n");
  return Buffer.concat([Buffer.from(header), data]);
}

/// Pixels that differ between two RGBA images of one size (any channel), and the largest difference.
export function compareImages(a, b) {
  if (a.width !== b.width || a.height !== b.height) return { differing: Infinity, maxDiff: Infinity };
  let differing = 0;
  let maxDiff = 0;
  for (let i = 0; i < a.rgba.length; i += 4) {
    let d = 0;
    for (let c = 0; c < 4; ++c) d = Math.max(d, Math.abs(a.rgba[i + c] - b.rgba[i + c]));
    if (d) differing++;
    maxDiff = Math.max(maxDiff, d);
  }
  return { differing, maxDiff };
}

/// Pixels brighter than black: a frame that shows something.
export const litPixels = (img) => {
  let n = 0;
  for (let i = 0; i < img.rgba.length; i += 4) if (img.rgba[i] + img.rgba[i + 1] + img.rgba[i + 2] > 0) n++;
  return n;
};
