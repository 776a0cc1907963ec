// A 512² camera drag over TLS beside the same drag in the clear, in one run: two servers of one build on the same
// datasets, one plain and one with a certificate (made here by Debian's openssl, a test CA), and for each, in rounds
// whose order alternates (plain first, then TLS first, ...):
//   1. one Chromium tab dragging through the page's own gesture handlers over ws:// or wss:// (the viewer);
//   2. one `voxbrick load --drag` client over TCP in the clear or inside TLS (`--tls --ca`).
// Figures per run: frames shown a second while dragging, the age of the camera each frame was drawn for (p50/p99),
// bytes per frame, the exact frame after release; the report gives each figure's median over the rounds and the
// ratio TLS / plain.
// Usage: node bench/tls_drag.mjs --datasets DIR --dataset NAME --out PREFIX [--size 512] [--duration 8] [--rounds 3]
//        [--hz 30] [--tf mri]
// Writes PREFIX.csv, PREFIX.md and PREFIX.json.

import fs from "node:fs";
import path from "node:path";
import * as H from "../tests/browser/harness.mjs";
import * as D from "./drag_common.mjs";

const { pct, fmt } = D;
const args = D.parseArgs(process.argv.slice(2));
const opt = {
  datasets: args.datasets,
  dataset: args.dataset || "mri",
  out: args.out || "bench/results/server/tls-drag",
  size: Number(args.size || 512),
  duration: Number(args.duration || 8),
  rounds: Number(args.rounds || 3),
  hz: Number(args.hz || 30),
  tf: args.tf || "mri",
};
if (!opt.datasets) throw new Error("--datasets DIR is required");

const scratch = H.scratchDir("tls-drag");
const certs = H.testCertificates(scratch.dir);
const extra = ["--render-threads", "1"];
const servers = {};
let browser;
const rows = [];
const report = { options: opt, started: new Date().toISOString() };
try {
  fs.mkdirSync(path.join(scratch.dir, "plain"));
  fs.mkdirSync(path.join(scratch.dir, "tls"));
  servers.plain = await new H.Server({ dir: path.join(scratch.dir, "plain"), datasets: opt.datasets, extra }).start();
  servers.tls = await new H.Server({
    dir: path.join(scratch.dir, "tls"),
    datasets: opt.datasets,
    extra,
    tls: certs,
  }).start();
  // One browser for both: it trusts the test certificate by its key's hash, which changes nothing over ws://.
  browser = await H.launchBrowser([`--ignore-certificate-errors-spki-list=${certs.spki}`]);
  let features = {};
  for (let round = 0; round < opt.rounds; ++round) {
    const order = round % 2 === 0 ? ["plain", "tls"] : ["tls", "plain"];
    for (const mode of order) {
      const server = servers[mode];
      const page = await D.openTab(browser, server, { dataset: opt.dataset, tf: opt.tf, size: opt.size });
      const b = D.tabFigures(await D.tabDrag(page, { durationMs: opt.duration * 1000, hz: opt.hz }));
      await page.close();
      features = b.features;
      rows.push({ round, mode, transport: mode === "tls" ? "wss (browser)" : "ws (browser)", ...b });
      const json = path.join(scratch.dir, `load-${mode}-${round}.json`);
      const options = ["--clients", "1", "--duration", String(opt.duration), "--size", `${opt.size}x${opt.size}`]
        .concat(D.dragLoadOptions(features, opt.hz))
        .concat(mode === "tls" ? ["--tls", "--ca", certs.ca] : []);
      const t = await D.runLoad(server, { dataset: opt.dataset, tf: opt.tf, json, options });
      report[`load_command_${mode}`] = D.loadCommand(t.argv).replace(certs.ca, "CA.pem");
      rows.push({
        round,
        mode,
        transport: mode === "tls" ? "TLS over TCP (voxbrick load)" : "TCP (voxbrick load)",
        frames: t.frames,
        fps: t.frames_per_s,
        latency_p50_ms: t.latency_ms.p50,
        latency_p99_ms: t.latency_ms.p99,
        bytes_per_frame: t.payload_bytes_per_frame ?? null,
        exact_after_release_ms: null,
        errors: t.errors,
      });
      console.log(`round ${round} ${mode}: tab ${fmt(b.fps)} f/s p50 ${fmt(b.latency_p50_ms, 0)} ms; ` +
        `TCP ${fmt(t.frames_per_s)} f/s p50 ${fmt(t.latency_ms.p50, 0)} ms`);
    }
  }
} finally {
  if (browser) await browser.close();
  for (const s of Object.values(servers)) await s.kill("SIGTERM");
  scratch.remove();
}

// Medians over the rounds, per transport, and TLS / plain.
const figures = ["fps", "latency_p50_ms", "latency_p99_ms", "bytes_per_frame", "exact_after_release_ms"];
const median = (transport, f) =>
  pct(rows.filter((r) => r.transport === transport && r[f] !== null && r[f] !== undefined).map((r) => r[f]), 0.5);
const pairs = [
  ["ws (browser)", "wss (browser)"],
  ["TCP (voxbrick load)", "TLS over TCP (voxbrick load)"],
];
const summary = pairs.map(([plain, tls]) => {
  const row = { plain, tls };
  for (const f of figures) {
    row[`${f}_plain`] = median(plain, f);
    row[`${f}_tls`] = median(tls, f);
    row[`${f}_ratio`] = row[`${f}_plain`] ? row[`${f}_tls`] / row[`${f}_plain`] : null;
  }
  return row;
});
report.summary = summary;

const machine = D.describeMachine().line;
const command = D.benchCommand();
const cols = ["round", "mode", "transport", "frames", "fps", "latency_p50_ms", "latency_p99_ms", "bytes_per_frame",
  "exact_after_release_ms", "errors"];
D.writeCsv(`${opt.out}.csv`, cols, rows);
fs.writeFileSync(`${opt.out}.json`, JSON.stringify({ ...report, rows, machine, command }, null, 2) + "\n");
const md = [
  `# A ${opt.size}² drag over TLS beside the same drag in the clear`,
  "",
  `- Command: \`${command}\``,
  `- Date: ${report.started}`,
  `- Machine: ${machine}`,
  `- Dataset \`${opt.dataset}\`, transfer function \`${opt.tf}\`; a drag of ${opt.duration} s at ${opt.hz} Hz, ` +
    `${opt.rounds} rounds, the order of plain and TLS alternating. Two servers of one build, one render thread each, ` +
    "one in the clear and one with a certificate of a test CA (made by `openssl` for the run).",
  `- TCP clients: \`${report.load_command_plain || ""}\` and \`${report.load_command_tls || ""}\`.`,
  "- Latency: the age of the camera each shown frame was drawn for (browser: from the camera change to the frame on " +
    "the canvas; TCP: from the request sent to its frame received).",
  "",
  "Medians over the rounds, and TLS / plain:",
  "",
  "| transports | frames/s | latency p50 ms | latency p99 ms | bytes/frame | exact after release ms |",
  "|---|---:|---:|---:|---:|---:|",
  ...summary.map(
    (s) =>
      `| ${s.plain} → ${s.tls} | ${fmt(s.fps_plain)} → ${fmt(s.fps_tls)} (${fmt(s.fps_ratio, 2)}) | ` +
      `${fmt(s.latency_p50_ms_plain, 0)} → ${fmt(s.latency_p50_ms_tls, 0)} (${fmt(s.latency_p50_ms_ratio, 2)}) | ` +
      `${fmt(s.latency_p99_ms_plain, 0)} → ${fmt(s.latency_p99_ms_tls, 0)} (${fmt(s.latency_p99_ms_ratio, 2)}) | ` +
      `${fmt(s.bytes_per_frame_plain, 0)} → ${fmt(s.bytes_per_frame_tls, 0)} | ` +
      `${fmt(s.exact_after_release_ms_plain, 0)} → ${fmt(s.exact_after_release_ms_tls, 0)} |`,
  ),
  "",
  "Every run:",
  "",
  "| round | transport | frames | frames/s | latency p50 ms | latency p99 ms | bytes/frame | exact after release ms | errors |",
  "|---:|---|---:|---:|---:|---:|---:|---:|---:|",
  ...rows.map(
    (r) =>
      `| ${r.round} | ${r.transport} | ${r.frames} | ${fmt(r.fps)} | ${fmt(r.latency_p50_ms, 0)} | ` +
      `${fmt(r.latency_p99_ms, 0)} | ${fmt(r.bytes_per_frame, 0)} | ${fmt(r.exact_after_release_ms, 0)} | ${r.errors} |`,
  ),
  "",
];
fs.writeFileSync(`${opt.out}.md`, md.join("\n"));
console.log(md.join("\n"));
