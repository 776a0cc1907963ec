// The camera drag in the browser beside the same drag through the TCP client, in one run against one server:
//   1. one tab, a scripted drag (the page's own gesture handlers) at HZ moves a second for DURATION seconds, at each
//      size: frames shown per second, the age of the camera each shown frame was drawn for (p50/p99), bytes per
//      frame, and the time from the release to the exact frame;
//   2. the same drag through `voxbrick load --drag` (one TCP client, the same rate, size and orbit step);
//   3. TABS tabs dragging beside CLIENTS dragging TCP clients: errors and latency p99 of both.
// Usage: node bench/browser_drag.mjs --datasets DIR --dataset NAME --out PREFIX [--sizes 512,1024] [--duration 10]
//        [--hz 30] [--tabs 16] [--clients 64] [--multi-size 512] [--tf mri]
// Writes PREFIX.csv, PREFIX.md and PREFIX.json.

import { spawn, spawnSync } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import * as H from "../tests/browser/harness.mjs";
import { DRAG_TIME_BUDGET_MS } from "../web/js/view.js";

const args = Object.fromEntries(
  process.argv
    .slice(2)
    .reduce((pairs, a, i, all) => (a.startsWith("--") ? [...pairs, [a.slice(2), all[i + 1]]] : pairs), []),
);
const opt = {
  datasets: args.datasets,
  dataset: args.dataset || "mri",
  out: args.out || "bench/results/browser/browser-drag",
  sizes: (args.sizes || "512,1024").split(",").map(Number),
  duration: Number(args.duration || 10),
  hz: Number(args.hz || 30),
  tabs: Number(args.tabs || 16),
  clients: Number(args.clients || 64),
  multiSize: Number(args["multi-size"] || 512),
  tf: args.tf || "mri",
  renderThreads: args["render-threads"],
};
if (!opt.datasets) throw new Error("--datasets DIR is required");
const DEG_PER_MOVE = 2; // `voxbrick load --drag` turns 2 degrees a request
const ORBIT = { el: 20, dist: 2.5 }; // the load tool's orbit

const pct = (v, p) => {
  if (!v.length) return null;
  const s = [...v].sort((a, b) => a - b);
  return s[Math.min(s.length - 1, Math.floor(p * s.length))];
};
const mean = (v) => (v.length ? v.reduce((a, b) => a + b, 0) / v.length : null);

/// One tab's drag: figures from the frames it showed while the camera moved, and the exact frame after release.
async function tabDrag(page, durationMs) {
  await page.evaluate(() => window.voxbrickViewer.resetFigures());
  const done = await page.evaluate((o) => window.voxbrickViewer.drag(o), { durationMs, hz: opt.hz, dAz: DEG_PER_MOVE });
  const s = await H.waitForState(page, (st) => st.exactAfterReleaseMs !== null, 30000).catch(() => null);
  const frames = await page.evaluate(() => window.voxbrickViewer.frames());
  const state = await H.viewerState(page);
  const moving = frames.filter((f) => f.phase === "drag");
  const lat = moving.map((f) => f.latencyMs);
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
    errors: state.counts.errors,
    features: state.features,
  };
}

/// `voxbrick load --drag` (run beside the event loop, which the tabs need): its JSON report. Its drag is the page's:
/// the same orbit and step, png exact frames, and the page's keys for a moving camera where the server took them.
function tcpDrag(server, size, clients, duration, json, features) {
  const argv = ["load", `127.0.0.1:${server.tcpPort}`, "--dataset", opt.dataset, "--tf", opt.tf, "--step", "0.75"]
    .concat(["--clients", String(clients), "--duration", String(duration), "--size", `${size}x${size}`])
    .concat(["--drag", String(opt.hz), "--encoding", "png", "--json", json]);
  if (features.interactive) argv.push("--interactive", String(DRAG_TIME_BUDGET_MS));
  if (features.interactive && features.jpeg && features.provisional_encoding)
    argv.push("--provisional-encoding", "jpeg");
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

/// A row of the table from `voxbrick load`'s report; frames per second per client.
const tcpRow = (run, size, t, clients) => ({
  run,
  size,
  frames: t.frames,
  fps: t.frames_per_s / Math.max(1, clients),
  latency_p50_ms: t.latency_ms.p50,
  latency_p99_ms: t.latency_ms.p99,
  bytes_per_frame: t.payload_bytes_per_frame ?? null,
  provisional: t.provisional,
  exact_after_release_ms: null,
  errors: t.errors,
});

async function openTab(browser, server, size) {
  const url = `${server.url}/?dataset=${opt.dataset}&tf=${opt.tf}&orbit=0,${ORBIT.el},${ORBIT.dist}&size=${size}x${size}`;
  const page = await H.openPage(browser, url, { width: Math.min(1400, size + 300), height: Math.min(1100, size + 40) });
  await H.waitForState(page, (s) => s.lastFrame && !s.lastFrame.provisional, 60000);
  return page;
}

const scratch = H.scratchDir("browser-drag");
const extra = ["--max-sessions", "256"];
if (opt.renderThreads) extra.push("--render-threads", opt.renderThreads);
const server = await new H.Server({ dir: scratch.dir, datasets: opt.datasets, extra }).start();
const browser = await H.launchBrowser();
const rows = [];
let features = {}; // the keys for a moving camera the server took, as the first tab found
const report = { options: opt, started: new Date().toISOString() };
try {
  for (const size of opt.sizes) {
    const page = await openTab(browser, server, size);
    const b = await tabDrag(page, opt.duration * 1000);
    await page.close();
    rows.push({ run: "browser, 1 tab", size, ...b });
    features = b.features;
    const t = await tcpDrag(server, size, 1, opt.duration, path.join(scratch.dir, `tcp-${size}.json`), features);
    rows.push(tcpRow("TCP client (voxbrick load --drag)", size, t, 1));
    report.tcp_command = `voxbrick ${t.argv.join(" ")}`
      .replace(/127\.0\.0\.1:\d+/, "127.0.0.1:PORT")
      .replace(/--json \S+/, "--json FILE");
  }
  // Tabs and TCP clients at once: every tab drags while the load tool's clients do.
  const tabs = [];
  for (let i = 0; i < opt.tabs; ++i) tabs.push(await openTab(browser, server, opt.multiSize));
  const tcpJson = path.join(scratch.dir, "tcp-multi.json");
  const tcp = tcpDrag(server, opt.multiSize, opt.clients, opt.duration, tcpJson, features);
  const tabResults = await Promise.all(tabs.map((p) => tabDrag(p, opt.duration * 1000)));
  const t = await tcp;
  const allLat = tabResults.flatMap((r) => [r.latency_p99_ms]).filter((v) => v !== null);
  rows.push({
    run: `browser, ${opt.tabs} tabs beside ${opt.clients} TCP clients`,
    size: opt.multiSize,
    frames: tabResults.reduce((a, r) => a + r.frames, 0),
    fps: mean(tabResults.map((r) => r.fps)),
    latency_p50_ms: mean(tabResults.map((r) => r.latency_p50_ms).filter((v) => v !== null)),
    latency_p99_ms: allLat.length ? Math.max(...allLat) : null,
    bytes_per_frame: mean(tabResults.map((r) => r.bytes_per_frame).filter((v) => v !== null)),
    provisional: tabResults.reduce((a, r) => a + r.provisional, 0),
    jpeg_frames: tabResults.reduce((a, r) => a + r.jpeg_frames, 0),
    exact_after_release_ms: pct(
      tabResults.map((r) => r.exact_after_release_ms).filter((v) => v !== null),
      0.5,
    ),
    errors: tabResults.reduce((a, r) => a + r.errors, 0),
  });
  rows.push(tcpRow(`TCP, ${opt.clients} clients beside ${opt.tabs} tabs`, opt.multiSize, t, opt.clients));
  report.tabs = tabResults;
  report.tcp_multi = t;
  await Promise.all(tabs.map((p) => p.close()));
} finally {
  await browser.close();
  await server.kill("SIGTERM");
  scratch.remove();
}

// Reports: CSV, markdown (with the command, machine and date) and the raw JSON.
const chromium = spawnSync(H.CHROMIUM, ["--version"], { encoding: "utf8" }).stdout.trim();
const cpu = (os.cpus()[0] || {}).model || "unknown CPU";
const machine = `${os.hostname()}: ${cpu}, ${os.cpus().length} cores, ${(os.totalmem() / 2 ** 30).toFixed(0)} GiB; ${chromium}`;
const command = process.env.VOXBRICK_BENCH_COMMAND || `node ${process.argv.slice(1).join(" ")}`;
const fmt = (v, d = 1) => (v === null || v === undefined ? "" : Number(v).toFixed(d));
const cols = [
  "run",
  "size",
  "frames",
  "fps",
  "latency_p50_ms",
  "latency_p99_ms",
  "bytes_per_frame",
  "provisional",
  "jpeg_frames",
  "exact_after_release_ms",
  "errors",
];
const csv = [cols.join(",")].concat(
  rows.map((r) => cols.map((c) => (c === "run" ? `"${r[c]}"` : (r[c] ?? ""))).join(",")),
);
fs.mkdirSync(path.dirname(opt.out), { recursive: true });
fs.writeFileSync(`${opt.out}.csv`, csv.join("\n") + "\n");
fs.writeFileSync(`${opt.out}.json`, JSON.stringify({ ...report, rows, machine, command }, null, 2) + "\n");
const moving = features.interactive
  ? `interactive, time budget ${features.time_budget_ms ? `${DRAG_TIME_BUDGET_MS} ms` : "the server's"}, provisional ` +
    `frames ${features.jpeg && features.provisional_encoding ? "jpeg" : "png"}`
  : `${features.progressive ? "progressive" : "plain Renders"} (this server refused interactive)`;
const md = [
  `# Camera drag: browser and TCP client side by side`,
  "",
  `- Command: \`${command}\``,
  `- Date: ${report.started}`,
  `- Machine: ${machine}`,
  `- Dataset \`${opt.dataset}\`, transfer function \`${opt.tf}\`; a drag of ${opt.duration} s at ${opt.hz} Hz, ${DEG_PER_MOVE}° a move, ` +
    `orbit elevation ${ORBIT.el}, distance ${ORBIT.dist} radii. The browser's drag runs in the page through its own gesture handlers.`,
  `- TCP clients: \`${report.tcp_command || ""}\` (and the same with --clients ${opt.clients} at ${opt.multiSize}²).`,
  `- Frames while the camera moves: ${moving}; exact frames png.`,
  "- Latency: the age of the camera each shown frame was drawn for (browser: from the camera change to the frame drawn " +
    "on the canvas; TCP: from the request sent to its frame received). Frames per second: frames shown (browser) or " +
    "received (TCP, per client) a second while dragging.",
  "",
  "| run | size | frames | frames/s | latency p50 ms | latency p99 ms | bytes/frame | provisional (jpeg) | " +
    "exact after release ms | errors |",
  "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
  ...rows.map(
    (r) =>
      `| ${r.run} | ${r.size}² | ${r.frames} | ${fmt(r.fps)} | ${fmt(r.latency_p50_ms, 0)} | ${fmt(r.latency_p99_ms, 0)} | ` +
      `${fmt(r.bytes_per_frame, 0)} | ${r.provisional ?? ""}${r.jpeg_frames === undefined ? "" : ` (${r.jpeg_frames})`} | ` +
      `${fmt(r.exact_after_release_ms, 0)} | ${r.errors} |`,
  ),
  "",
  `The ${opt.tabs}-tab row gives the mean frames per second and p50 over the tabs, and the worst tab's p99.`,
  "",
];
fs.writeFileSync(`${opt.out}.md`, md.join("\n"));
console.log(md.join("\n"));
