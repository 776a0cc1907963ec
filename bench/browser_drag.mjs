// The camera drag in the browser beside the same drag through the TCP client, in one run against one server:
//   1. one tab, a scripted drag (the page's own gesture handlers) at HZ moves a second for DURATION seconds, at each
//      size: frames shown per second, the age of the camera each shown frame was drawn for (p50/p99), bytes per
//      frame, and the time from the release to the exact frame;
//   2. the same drag through `voxbrick load --drag` (one TCP client, the same rate, size and orbit step);
//   3. TABS tabs dragging beside CLIENTS dragging TCP clients: errors and latency p99 of both.
// Usage: node bench/browser_drag.mjs --datasets DIR --dataset NAME --out PREFIX [--sizes 512,1024] [--duration 10]
//        [--hz 30] [--tabs 16] [--clients 64] [--multi-size 512] [--tf mri]
// Writes PREFIX.csv, PREFIX.md and PREFIX.json.

import fs from "node:fs";
import path from "node:path";
import * as H from "../tests/browser/harness.mjs";
import * as D from "./drag_common.mjs";

const { pct, mean, fmt, DEG_PER_MOVE, ORBIT, DRAG_TIME_BUDGET_MS } = D;
const args = D.parseArgs(process.argv.slice(2));
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

/// One tab's drag: figures from the frames it showed while the camera moved, and the exact frame after release.
const tabDrag = async (page, durationMs) => D.tabFigures(await D.tabDrag(page, { durationMs, hz: opt.hz }));

/// `voxbrick load --drag` with `clients` clients: the page's drag (D.dragLoadOptions) at `size`².
const tcpDrag = (server, size, clients, duration, json, features) =>
  D.runLoad(server, {
    dataset: opt.dataset,
    tf: opt.tf,
    json,
    options: ["--clients", String(clients), "--duration", String(duration), "--size", `${size}x${size}`].concat(
      D.dragLoadOptions(features, opt.hz),
    ),
  });

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

const openTab = (browser, server, size, azimuth = 0) =>
  D.openTab(browser, server, { dataset: opt.dataset, tf: opt.tf, size, azimuth });

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
    report.tcp_command = D.loadCommand(t.argv);
  }
  // Tabs and TCP clients at once: every tab drags while the load tool's clients do.
  const tabs = [];
  for (let i = 0; i < opt.tabs; ++i) tabs.push(await openTab(browser, server, opt.multiSize, D.tabAzimuth(i, opt.tabs)));
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
const machine = D.describeMachine().line;
const command = D.benchCommand();
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
D.writeCsv(`${opt.out}.csv`, cols, rows);
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
