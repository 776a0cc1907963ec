// What the browser benchmarks (browser_drag.mjs, crowd.mjs) share: their options, percentiles and Jain's index, a
// tab opened on the viewer and its scripted drag, `voxbrick load` run beside the tabs, and the machine a result names.

import { spawn, spawnSync } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import * as H from "../tests/browser/harness.mjs";
import { DRAG_TIME_BUDGET_MS } from "../web/js/view.js";

export { DRAG_TIME_BUDGET_MS };
export const DEG_PER_MOVE = 2; // `voxbrick load --drag` turns 2 degrees a request
export const ORBIT = { el: 20, dist: 2.5 }; // the load tool's orbit
export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/// "--name value" pairs of the command line as {name: value}.
export const parseArgs = (argv) =>
  Object.fromEntries(
    argv.reduce((pairs, a, i, all) => (a.startsWith("--") ? [...pairs, [a.slice(2), all[i + 1]]] : pairs), []),
  );

/// The value below which a share `p` of `v` lies (as the load tool takes it); null when `v` is empty.
export const pct = (v, p) => {
  if (!v.length) return null;
  const s = [...v].sort((a, b) => a - b);
  return s[Math.min(s.length - 1, Math.floor(p * s.length))];
};
export const mean = (v) => (v.length ? v.reduce((a, b) => a + b, 0) / v.length : null);
export const sum = (v) => v.reduce((a, b) => a + b, 0);

/// Jain's fairness index of `x`: (Σx)² / (n Σx²), 1 when all are equal, 1/n when one has everything; null when `x` is
/// empty or all zero.
export function jain(x) {
  const squares = sum(x.map((v) => v * v));
  return x.length && squares > 0 ? sum(x) ** 2 / (x.length * squares) : null;
}

/// A tab on the viewer at `size`², the orbit of the load tool from `azimuth` (degrees), once its first exact frame is
/// shown.
export async function openTab(browser, server, { dataset, tf, size, azimuth = 0 }) {
  const orbit = `${azimuth},${ORBIT.el},${ORBIT.dist}`;
  const url = `${server.url}/?dataset=${dataset}&tf=${tf}&orbit=${orbit}&size=${size}x${size}`;
  const page = await H.openPage(browser, url, { width: Math.min(1400, size + 300), height: Math.min(1100, size + 40) });
  await H.waitForState(page, (s) => s.lastFrame && !s.lastFrame.provisional, 120000);
  return page;
}

/// Where tab `i` of `n` starts its drag: tabs spread round the orbit (and off the load tool's even degrees), so that
/// no two ask for the same camera at the same time. Tabs in step on one path would share their renders (the
/// server draws an identical frame once for every session asking it), which no crowd of people does.
export const tabAzimuth = (i, n) => (360 * i) / n + 1;

/// One tab's drag through the page's own gesture handlers (`hz` moves a second, DEG_PER_MOVE each) for `durationMs`:
/// figures from the frames it showed while the camera moved, and the exact frame after release (waited for up to
/// `exactWaitMs`; null if it did not come). `latencies` holds each moving frame's camera-to-frame ms.
export async function tabDrag(page, { durationMs, hz, exactWaitMs = 30000 }) {
  await page.evaluate(() => window.voxbrickViewer.resetFigures());
  const done = await page.evaluate((o) => window.voxbrickViewer.drag(o), { durationMs, hz, dAz: DEG_PER_MOVE });
  const s = await H.waitForState(page, (st) => st.exactAfterReleaseMs !== null, exactWaitMs).catch(() => null);
  const frames = await page.evaluate(() => window.voxbrickViewer.frames());
  const state = await H.viewerState(page);
  const moving = frames.filter((f) => f.phase === "drag");
  const lat = moving.map((f) => f.latencyMs);
  const budgets = moving.map((f) => f.budgetMs).filter((v) => typeof v === "number");
  return {
    moves: done.moves,
    frames: moving.length,
    fps: moving.length / (done.ms / 1000),
    provisional: moving.filter((f) => f.provisional).length,
    latency_p50_ms: pct(lat, 0.5),
    latency_p99_ms: pct(lat, 0.99),
    bytes_per_frame: mean(moving.map((f) => f.bytes)),
    jpeg_frames: moving.filter((f) => f.encoding === 3).length,
    exact_after_release_ms: s ? s.exactAfterReleaseMs : null,
    // The budget the server drew the moving frames to (their statistics; a page that does not record it: none).
    budget_ms: pct(budgets, 0.5),
    latency_split_ms: latencySplit(moving),
    errors: state.counts.errors,
    // Renders answered Busy (the server over capacity for one more dragging session), each waited out by the page.
    busy: state.counts.busy || 0,
    page_errors: page.errors.length,
    features: state.features,
    latencies: lat,
  };
}

/// The parts latencySplit splits a frame's latency into, in the order a frame meets them.
export const SPLIT = ["ask", "queue", "render", "encoder", "encode", "output", "decode", "page"];

/// Where the camera-to-frame latency of `frames` (a tab's shown frames, as the page records them) went, medians in
/// ms: `ask`, the camera's wait for a Render slot in the page; on the server, `queue` (the Render's wait for a render
/// thread), `render` (its drawing: an interactive frame's planning, drawing and scaling up), `encoder` (the drawn
/// frame's way to its session and wait for its encoding to start: for the session's frame before it, an encoder
/// thread) and `encode`; `output`, the rest of the time from the Render sent to its reply's arrival (the frame's wait
/// on the server's output and the link's pace, and the link both ways); `decode`, the page's; `page`, the rest from
/// the reply's arrival to the frame drawn (the page's event loop, drawing). A frame drawn once for several sessions
/// (`shared`) carries the first session's queue and drawing times, not this one's: the server's parts leave it out.
/// Null where no frame says (a page or server that does not record it).
export function latencySplit(frames) {
  const has = (f, keys) => keys.every((k) => Number.isFinite(f[k]));
  const median = (keys, value, of = frames) => pct(of.filter((f) => has(f, keys)).map(value), 0.5);
  const own = frames.filter((f) => !f.shared);
  return {
    ask: median(["askMs"], (f) => f.askMs),
    queue: median(["queueMs"], (f) => f.queueMs, own),
    render: median(["drawMs"], (f) => f.drawMs, own),
    encoder: median(["encodeStartMs", "queueMs", "drawMs"], (f) => f.encodeStartMs - f.queueMs - f.drawMs, own),
    encode: median(["encodeMs"], (f) => f.encodeMs),
    output: median(["replyMs", "encodeStartMs", "encodeMs"], (f) => f.replyMs - f.encodeStartMs - f.encodeMs),
    decode: median(["decodeMs"], (f) => f.decodeMs),
    page: median(["pageMs", "decodeMs"], (f) => f.pageMs - f.decodeMs),
  };
}

/// `tabDrag`'s figures without the samples, for a report.
export const tabFigures = ({ latencies, ...figures }) => figures;

/// The options of `voxbrick load` for clients that drag as the page does: the same rate, png exact frames, and the
/// page's keys for a moving camera where the server took them (`features`, as a tab found).
export function dragLoadOptions(features, hz) {
  const argv = ["--drag", String(hz), "--encoding", "png"];
  if (features.interactive) argv.push("--interactive", String(DRAG_TIME_BUDGET_MS));
  if (features.interactive && features.jpeg && features.provisional_encoding)
    argv.push("--provisional-encoding", "jpeg");
  return argv;
}

/// `voxbrick load` (this build's) against `server` beside the event loop, which the tabs need: its JSON report, with
/// `argv` and the summary it printed. `options` follow the address and dataset.
export function runLoad(server, { dataset, tf, json, options }) {
  const argv = ["load", `127.0.0.1:${server.tcpPort}`, "--dataset", dataset, "--tf", tf, "--step", "0.75"]
    .concat(options)
    .concat(["--json", json]);
  return new Promise((resolve, reject) => {
    const p = spawn(H.VOXBRICK, argv, { stdio: ["ignore", "pipe", "pipe"] });
    let out = "";
    p.stdout.on("data", (d) => (out += d));
    p.stderr.on("data", (d) => (out += d));
    p.on("exit", (code) => {
      if (code !== 0) return reject(new Error(`voxbrick load failed (${code}): ${out}`));
      resolve({ ...JSON.parse(fs.readFileSync(json, "utf8")), summary: out.trim(), argv });
    });
  });
}

/// A load run's command line as a reader would type it (the port and the report's file left as words).
export const loadCommand = (argv) =>
  `voxbrick ${argv.join(" ")}`.replace(/127\.0\.0\.1:\d+/, "127.0.0.1:PORT").replace(/--json \S+/, "--json FILE");

/// The machine a result was measured on: host, CPU model, cores, memory, Chromium's version, the load average when
/// the run began.
export function describeMachine() {
  const chromium = spawnSync(H.CHROMIUM, ["--version"], { encoding: "utf8" }).stdout.trim();
  const cpu = (os.cpus()[0] || {}).model || "unknown CPU";
  const cores = os.cpus().length;
  const memory = `${(os.totalmem() / 2 ** 30).toFixed(0)} GiB`;
  const load = os.loadavg().map((v) => v.toFixed(2));
  return {
    cpu,
    cores,
    memory,
    chromium,
    load_average: load,
    line: `${os.hostname()}: ${cpu}, ${cores} cores, ${memory}; ${chromium}`,
  };
}

/// The GL renderer a server's render threads use, from its log ("render threads: ..."); null if it has not said.
export function glRenderer(server) {
  const m = /render threads: (.*)/.exec(server.log());
  return m ? m[1].trim() : null;
}

/// The command that ran this benchmark: the run script's (VOXBRICK_BENCH_COMMAND), else node's.
export const benchCommand = () => process.env.VOXBRICK_BENCH_COMMAND || `node ${process.argv.slice(1).join(" ")}`;

/// Writes `rows` as CSV with the columns `cols` (text quoted, fractions to 3 decimals).
export function writeCsv(file, cols, rows) {
  const cell = (v) =>
    v === null || v === undefined
      ? ""
      : typeof v === "string"
        ? `"${v.replace(/"/g, '""')}"`
        : typeof v === "number" && !Number.isInteger(v)
          ? Number(v.toFixed(3))
          : v;
  const lines = [cols.join(",")].concat(rows.map((r) => cols.map((c) => cell(r[c])).join(",")));
  fs.mkdirSync(path.dirname(file), { recursive: true });
  fs.writeFileSync(file, lines.join("\n") + "\n");
}

/// A number for a table: `d` decimals, empty when there is none.
export const fmt = (v, d = 1) => (v === null || v === undefined || Number.isNaN(v) ? "" : Number(v).toFixed(d));
