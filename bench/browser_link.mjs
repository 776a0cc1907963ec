// A drag in real Chromium, JPEG against the video stream, on loopback and over a slow link, side by side in one run
// against one server: for each link, frame size and encoding, a fresh tab on the viewer (its `video` parameter picks
// the encoding: off for jpeg, vp8, vp9) drags the MRI for DURATION seconds at HZ moves a second through its own
// gesture handlers. Figures of the frames shown while the camera moved: frames a second, camera-to-frame latency
// p50/p99, bytes a frame, the server's encode ms and the browser's decode ms; the PSNR of what the canvas showed against
// the exact frame of the same camera (SAMPLES canvases taken mid-drag, each exact frame asked of the server by
// `voxbrick request`); and the time from the release to the exact frame. The slow link is bench/link_relay.mjs (RATE
// Mbit/s, RTT ms round trip, a 200 ms queue) between the browser and the server's HTTP port: the page, its WebSocket
// and every frame pass through it.
//
// Usage: node bench/browser_link.mjs --datasets DIR [--dataset mri] [--tf mri] [--out PREFIX]
//        [--sizes 512x512,1024x1024,1920x1080] [--encodings jpeg,jpeg-qN,vp8,vp9,vp9-420] [--links loopback,relay]
//        [--duration 10]
//        [--hz 30] [--mbit 10] [--rtt-ms 40] [--samples 4] [--replay DIR --replay-draw-ms MS] [--frames-out DIR]
//        [--server-log FILE] [--replace]
// jpeg-qN: JPEG moving frames at quality N (the address's jpeg_quality; jpeg: the server's, 85). With two JPEG rows or
// more of a link and size, the table of bytes at equal PSNR gives each video row's bytes over JPEG's at its PSNR.
// --frames-out: each row's shown frames as the page recorded them (DIR/LINK-SIZE-ENCODING.json); --server-log FILE:
// the server's log, kept.
// --replay: the server draws nothing and answers each frame with the frame of DIR nearest its camera, taking MS ms
// (`voxbrick serve --replay-frames`): everything but the drawing, with a GPU's drawing time (bench/run_browser_link.sh
// --replay-draw-ms makes DIR).
// Writes PREFIX.csv, PREFIX.md and PREFIX.json (default PREFIX bench/results/video/browser-link). Where PREFIX.json
// holds rows (link, size, encoding) this run does not ask for, it stops first, naming them: --replace writes over them.

import { spawn, spawnSync } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { Encoding, encodingName } from "../web/js/protocol.js";
import { jpegQualityOf as qualityOfText } from "../web/js/view.js";
import * as H from "../tests/browser/harness.mjs";
import * as D from "./drag_common.mjs";

const { pct, mean, fmt, DEG_PER_MOVE, ORBIT, sleep } = D;
const args = D.parseArgs(process.argv.slice(2));
const opt = {
  datasets: args.datasets,
  dataset: args.dataset || "mri",
  tf: args.tf || "mri",
  out: args.out || "bench/results/video/browser-link",
  sizes: (args.sizes || "512x512,1024x1024,1920x1080").split(",").map((s) => s.split("x").map(Number)),
  encodings: (args.encodings || "jpeg,vp8,vp9").split(","),
  links: (args.links || "loopback,relay").split(","),
  duration: Number(args.duration || 10),
  hz: Number(args.hz || 30),
  mbit: Number(args.mbit || 10),
  rttMs: Number(args["rtt-ms"] || 40),
  samples: Number(args.samples || 4),
  replay: args.replay || null,
  framesOut: args["frames-out"] || null,
  serverLog: args["server-log"] || null,
  replayDrawMs: Number(args["replay-draw-ms"] || 0),
};
if (!opt.datasets) throw new Error("--datasets DIR is required");
for (const e of opt.encodings)
  if (!["jpeg", "vp8", "vp9", "vp9-420"].includes(e) && !jpegQualityOf(e))
    throw new Error(`--encodings: '${e}' is none of jpeg, jpeg-qN (N from 1 to 100), vp8, vp9, vp9-420`);
for (const l of opt.links) if (!["loopback", "relay"].includes(l)) throw new Error(`--links: '${l}' is none of loopback, relay`);
refuseToDropRows();

/// The quality N of an encoding "jpeg-qN" (1 to 100, as the viewer's address takes it), else 0.
function jpegQualityOf(encoding) {
  const m = /^jpeg-q(\d+)$/.exec(encoding);
  return m ? qualityOfText(m[1]) : 0;
}
function isJpeg(encoding) {
  return encoding === "jpeg" || jpegQualityOf(encoding) > 0;
}
/// The encoding the page's moving frames travel in for a row's `encoding`.
function movingEncoding(encoding) {
  return isJpeg(encoding) ? "jpeg" : encoding.replace("-420", "");
}

/// The results already at PREFIX keep rows of their own: a run that would write over them with fewer (a one-row check,
/// say) stops before it starts, naming them, unless --replace says so or --out names another prefix.
function refuseToDropRows() {
  if ("replace" in args || !fs.existsSync(`${opt.out}.json`)) return;
  let old;
  try {
    old = JSON.parse(fs.readFileSync(`${opt.out}.json`, "utf8")).rows || [];
  } catch {
    return; // not a results file this tool can read: written over
  }
  const key = (r) => `${r.link} ${r.size} ${r.encoding}`;
  const planned = new Set(opt.links.flatMap((link) => opt.sizes.flatMap((size) =>
    opt.encodings.map((encoding) => key({ link, size: `${size[0]}x${size[1]}`, encoding })))));
  const dropped = [...new Set(old.map(key))].filter((k) => !planned.has(k));
  if (dropped.length === 0) return;
  console.error(`browser_link: ${opt.out}.json holds rows this run does not ask for (${dropped.join(", ")}): ` +
    "writing its results there would lose them. Ask for the same rows, write elsewhere (--out PREFIX), or replace the " +
    "table (--replace).");
  process.exit(2);
}

/// The relay (bench/link_relay.mjs) in front of `port`; resolves with its process and port once it listens.
function startRelay(port) {
  const relay = spawn(process.execPath, [
    path.join(path.dirname(new URL(import.meta.url).pathname), "link_relay.mjs"),
    "--listen", "0", "--target", String(port), "--mbit", String(opt.mbit), "--delay-ms", String(opt.rttMs / 2),
  ], { stdio: ["ignore", "pipe", "inherit"] });
  return new Promise((resolve, reject) => {
    let out = "";
    relay.stdout.on("data", (d) => {
      out += d;
      const m = /listening on (\d+)/.exec(out);
      if (m) resolve({ proc: relay, port: Number(m[1]) });
    });
    relay.on("exit", (code) => reject(new Error(`the link relay exited (${code}) before it listened: ${out}`)));
  });
}

/// The exact frame of `scene` (a shown frame's, its motion keys removed) from the server itself, decoded.
function exactFrame(server, scene, file) {
  const exact = { ...scene };
  for (const k of ["interactive", "time_budget_ms", "provisional_encoding", "keyframe", "progressive"]) delete exact[k];
  fs.writeFileSync(`${file}.json`, JSON.stringify(exact));
  // Lossless webp: a 1920x1080 png of some cameras is above the server's 1 MiB message limit.
  const r = spawnSync(H.VOXBRICK, ["request", `127.0.0.1:${server.tcpPort}`, "--dataset", opt.dataset, "--scene",
    `${file}.json`, "--encoding", "webp", "-o", file], { encoding: "utf8" });
  if (r.status !== 0) throw new Error(`voxbrick request failed: ${r.stderr}`);
  return H.decodePng(fs.readFileSync(file));
}

/// One tab's drag at `size` with `encoding`, the page loaded from `base`.
async function dragRun(browser, server, base, size, encoding, scratch) {
  // vp9: in 4:4:4 where the browser decodes it (the page's way); vp9-420: the address's chroma=420; jpeg-qN: the
  // address's jpeg_quality.
  const quality = jpegQualityOf(encoding);
  const video = isJpeg(encoding) ? `off${quality ? `&jpeg_quality=${quality}` : ""}` :
    encoding === "vp9-420" ? "vp9&chroma=420" : encoding;
  const url = `${base}/?dataset=${opt.dataset}&tf=${opt.tf}&orbit=0,${ORBIT.el},${ORBIT.dist}&size=${size[0]}x${size[1]}` +
    `&video=${video}`;
  const page = await H.openPage(browser, url, { width: size[0] + 300, height: size[1] + 40 });
  try {
    await H.waitForState(page, (s) => s.lastFrame && !s.lastFrame.provisional, 120000);
    const start = await H.viewerState(page);
    if (start.moving !== movingEncoding(encoding))
      throw new Error(`the page moves frames as ${start.moving}, not ${encoding}`);
    await page.evaluate(() => window.voxbrickViewer.resetFigures());
    const durationMs = opt.duration * 1000;
    const dragging = page.evaluate((o) => window.voxbrickViewer.drag(o), { durationMs, hz: opt.hz, dAz: DEG_PER_MOVE });
    // Canvases mid-drag, each with the frame it shows (copied in one turn of the page's loop, so they agree), read
    // out once the drag is over: reading 1024x1024 pixels out mid-drag held the page for 0.4-0.6 s, a stall of the
    // drag's own frames that the measure made.
    const snapshots = [];
    for (let i = 1; i <= opt.samples; ++i) {
      await sleep(durationMs / (opt.samples + 1) - (i === 1 ? 0 : 5));
      snapshots.push(await page.evaluate(() => window.voxbrickViewer.snapshot()));
    }
    const done = await dragging;
    const s = await H.waitForState(page, (st) => st.exactAfterReleaseMs !== null, 30000).catch(() => null);
    // Read out once the exact frame after the release is shown: before, it would wait for the page.
    const shots = [];
    for (const index of snapshots) {
      const shot = await page.evaluate((i) => window.voxbrickViewer.snapshotPixels(i), index);
      if (shot.frame && shot.frame.provisional) shots.push({ pixels: shot, frame: shot.frame });
    }
    const frames = await page.evaluate(() => window.voxbrickViewer.frames());
    const state = await H.viewerState(page);
    const moving = frames.filter((f) => f.phase === "drag" && f.provisional);
    if (opt.framesOut) {
      // Every frame the page showed, for a closer look (its scene left out).
      fs.mkdirSync(opt.framesOut, { recursive: true });
      const file = path.join(opt.framesOut, `${base.includes(String(server.httpPort)) ? "loopback" : "relay"}-` +
        `${size[0]}x${size[1]}-${encoding}.json`);
      fs.writeFileSync(file, JSON.stringify(frames.map(({ scene, ...f }) => f), null, 1) + "\n");
    }
    const lat = moving.map((f) => f.latencyMs);
    const psnrs = shots.map((shot, i) => {
      const exact = exactFrame(server, shot.frame.scene, path.join(scratch, `exact-${i}.png`));
      const shown = { width: shot.pixels.width, height: shot.pixels.height, rgba: Buffer.from(shot.pixels.rgba, "base64") };
      return H.psnrRgb(shown, exact);
    });
    return {
      frames: moving.length,
      fps: moving.length / (done.ms / 1000),
      latency_p50_ms: pct(lat, 0.5),
      latency_p99_ms: pct(lat, 0.99),
      bytes_per_frame: mean(moving.map((f) => f.bytes)),
      decode_ms_p50: pct(moving.map((f) => f.decodeMs), 0.5),
      encode_ms_p50: pct(moving.map((f) => f.encodeMs).filter((v) => typeof v === "number"), 0.5),
      psnr_db_mean: mean(psnrs.filter(Number.isFinite)),
      psnr_db_min: psnrs.length ? Math.min(...psnrs) : null,
      psnr_samples: psnrs.length,
      rung_p50: pct(moving.map((f) => f.rung).filter((v) => typeof v === "number"), 0.5),
      key_frames: moving.filter((f) => f.key).length,
      bitrate_kbps_p50: pct(moving.map((f) => f.bitrateKbps).filter((v) => typeof v === "number"), 0.5),
      exact_after_release_ms: s ? s.exactAfterReleaseMs : null,
      // The exact frame after the release: how it travelled (png, or webp on a link the server measured slow).
      exact_encoding: s && s.lastFrame ? encodingName(s.lastFrame.encoding) : null,
      exact_bytes: s && s.lastFrame ? s.lastFrame.bytes : null,
      errors: state.counts.errors + page.errors.length,
      wrong_encoding: moving.filter((f) => f.encoding !== Encoding[movingEncoding(encoding)]).length,
      // Where a moving frame's latency went (medians, ms; bench/drag_common.mjs latencySplit).
      ...Object.fromEntries(Object.entries(D.latencySplit(moving)).map(([part, ms]) => [`split_${part}_ms`, ms])),
    };
  } finally {
    await page.close();
  }
}

const scratch = H.scratchDir("browser-link");
const replayArgs = opt.replay ? ["--replay-frames", opt.replay, "--replay-draw-ms", String(opt.replayDrawMs)] : [];
const server = await new H.Server({ dir: scratch.dir, datasets: opt.datasets, extra: replayArgs }).start();
const relay = opt.links.includes("relay") ? await startRelay(server.httpPort) : null;
const browser = await H.launchBrowser();
const rows = [];
const report = { options: opt, started: new Date().toISOString(), machine: D.describeMachine() };
try {
  for (const link of opt.links) {
    const base = link === "relay" ? `http://127.0.0.1:${relay.port}` : server.url;
    for (const size of opt.sizes)
      for (const encoding of opt.encodings) {
        const r = await dragRun(browser, server, base, size, encoding, scratch.dir);
        const row = { link, size: `${size[0]}x${size[1]}`, encoding, ...r };
        rows.push(row);
        console.log(JSON.stringify(row));
        // The files after each row: a run stopped part way (a step's time limit on a lent machine) keeps what it
        // measured.
        writeResults(false);
      }
  }
} finally {
  report.load_average_end = os.loadavg().map((v) => v.toFixed(2));
  await browser.close();
  if (relay) relay.proc.kill();
  report.gl = D.glRenderer(server);
  await server.kill("SIGTERM");
  if (opt.serverLog) fs.writeFileSync(opt.serverLog, server.log());
  scratch.remove();
}
console.log(writeResults(true).join("\n"));

/// Writes PREFIX.csv, .json and .md of the rows so far; `done` once every row ran (until then the load average at
/// the end is the latest one). Returns the markdown's lines.
function writeResults(done) {
  const loadNow = report.load_average_end || os.loadavg().map((v) => v.toFixed(2));
  const gl = "gl" in report ? report.gl : D.glRenderer(server); // the server's log is gone once the run ended
  const cols = ["link", "size", "encoding", "frames", "fps", "latency_p50_ms", "latency_p99_ms", "bytes_per_frame",
    "encode_ms_p50", "decode_ms_p50", "psnr_db_mean", "psnr_db_min", "psnr_samples", "rung_p50", "key_frames",
    "bitrate_kbps_p50", "exact_after_release_ms", "exact_encoding", "exact_bytes", "errors", "wrong_encoding",
    ...D.SPLIT.map((part) => `split_${part}_ms`)];
  D.writeCsv(`${opt.out}.csv`, cols, rows);
  fs.writeFileSync(`${opt.out}.json`,
    JSON.stringify({ ...report, load_average_end: loadNow, gl, complete: done, rows, command: D.benchCommand() }, null,
      2) + "\n");
  const jpegOf = (r) => rows.find((j) => j.link === r.link && j.size === r.size && j.encoding === "jpeg");
  const md = [
    "# A drag in Chromium: JPEG against the video stream, on loopback and over a slow link",
    "",
    `- Command: \`${D.benchCommand()}\``,
    `- Date: ${report.started}`,
    `- Machine: ${report.machine.line}; load average at the start ${report.machine.load_average.join(", ")}, at the ` +
      `end ${loadNow.join(", ")} (above the cores' count, other work shared the machine)`,
    opt.replay
      ? `- Server: \`voxbrick serve --replay-frames DIR --replay-draw-ms ${opt.replayDrawMs}\`: **it draws nothing**; ` +
        `each frame is the frame drawn beforehand (\`voxbrick orbit\`, 2° apart) nearest its camera, after ` +
        `${opt.replayDrawMs} ms, a GPU's drawing time: everything but the drawing is measured (${gl || "unknown"})`
      : `- Server: \`voxbrick serve\` (its defaults), GL: ${gl || "unknown"}`,
    `- Dataset \`${opt.dataset}\`, transfer function \`${opt.tf}\`; a drag of ${opt.duration} s at ${opt.hz} Hz, ` +
      `${DEG_PER_MOVE}° a move, through the page's own gesture handlers; a fresh tab for each row, its \`video\` ` +
      "parameter picking the encoding of the moving frames (off: jpeg); exact frames lossless (png, or webp where the " +
      "server measures the link slow: the exact frame column says which, and its bytes).",
    `- relay: bench/link_relay.mjs between the browser and the server, ${opt.mbit} Mbit/s each way, ${opt.rttMs} ms ` +
      "round trip, a 200 ms queue; the page, its WebSocket and every frame pass through it.",
    "- Latency: from the camera change to the frame drawn on the canvas. Frames/s: frames shown a second while " +
      "dragging. PSNR: the canvas mid-drag against the exact frame of the camera it shows (from the server, lossless), " +
      `${opt.samples} samples a row; rung: the median moving frame's (0: drawn at full size, each rung coarser, scaled up); ` +
      "bytes ratio: against JPEG's on the same link and size.",
    ...(done ? [] : [`- **Part of a run**: ${rows.length} rows so far; the run did not finish.`]),
    "",
    "| link | size | encoding | frames/s | latency p50 ms | p99 ms | bytes/frame | ratio | PSNR dB mean (min) | rung | " +
      "encode ms | decode ms | kbit/s | exact after release ms | exact frame | errors |",
    "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|",
    ...rows.map((r) => {
      const j = jpegOf(r);
      const ratio = j && j.bytes_per_frame ? r.bytes_per_frame / j.bytes_per_frame : null;
      return `| ${r.link} | ${r.size} | ${r.encoding} | ${fmt(r.fps)} | ${fmt(r.latency_p50_ms, 0)} | ` +
        `${fmt(r.latency_p99_ms, 0)} | ${fmt(r.bytes_per_frame, 0)} | ${fmt(ratio, 2)} | ${fmt(r.psnr_db_mean)} ` +
        `(${fmt(r.psnr_db_min)}) | ${fmt(r.rung_p50, 0)} | ${fmt(r.encode_ms_p50)} | ${fmt(r.decode_ms_p50)} | ` +
        `${fmt(r.bitrate_kbps_p50, 0)} | ${fmt(r.exact_after_release_ms, 0)} | ` +
        `${r.exact_encoding ? `${r.exact_encoding}, ${fmt(r.exact_bytes, 0)} B` : ""} | ${r.errors + r.wrong_encoding} |`;
    }),
    ...equalPsnrTable(rows),
    "",
    "Where a moving frame's latency went, medians in ms (bench/drag_common.mjs `latencySplit`): ask (the camera's " +
      "wait for a Render slot), queue (the server's render queue), render (drawing), encoder (the wait for an " +
      "encoder), encode, output (the server's output queue, the link's pace and the link), decode (the browser's) " +
      "and page (the rest of the page's work until the canvas shows it).",
    "",
    `| link | size | encoding | ${D.SPLIT.join(" | ")} |`,
    `|---|---|---|${D.SPLIT.map(() => "---:").join("|")}|`,
    ...rows.map((r) => `| ${r.link} | ${r.size} | ${r.encoding} | ` +
      `${D.SPLIT.map((part) => fmt(r[`split_${part}_ms`], 0)).join(" | ")} |`),
    "",
  ];
  fs.writeFileSync(`${opt.out}.md`, md.join("\n"));
  return md;
}

/// Each video row's bytes a frame against JPEG's at the same PSNR, where the run has two JPEG rows or more of its link
/// and size (jpeg, jpeg-qN): JPEG's bytes at the row's mean PSNR, log-linear between the two JPEG rows whose PSNRs hold
/// it; outside them, the nearest JPEG row and whether the row is below or above. No lines where no such rows.
function equalPsnrTable(all) {
  const ok = (r) => Number.isFinite(r.psnr_db_mean) && r.bytes_per_frame > 0;
  const lines = [];
  for (const r of all.filter((x) => !isJpeg(x.encoding) && ok(x))) {
    const jpegs = all.filter((j) => j.link === r.link && j.size === r.size && isJpeg(j.encoding) && ok(j))
      .sort((a, b) => a.psnr_db_mean - b.psnr_db_mean);
    if (jpegs.length < 2) continue;
    const db = r.psnr_db_mean;
    const hi = jpegs.findIndex((j) => j.psnr_db_mean >= db);
    let at, bytes = null;
    const named = (j) => `${j.encoding}'s ${fmt(j.psnr_db_mean)} dB (${fmt(j.bytes_per_frame, 0)} B)`;
    if (hi === 0 && jpegs[0].psnr_db_mean > db) at = `below ${named(jpegs[0])}`;
    else if (hi < 0) at = `above ${named(jpegs[jpegs.length - 1])}`;
    else {
      const [a, b] = [jpegs[Math.max(0, hi - 1)], jpegs[hi]];
      const t = b.psnr_db_mean > a.psnr_db_mean ? (db - a.psnr_db_mean) / (b.psnr_db_mean - a.psnr_db_mean) : 0;
      bytes = Math.exp(Math.log(a.bytes_per_frame) + t * (Math.log(b.bytes_per_frame) - Math.log(a.bytes_per_frame)));
      at = a === b ? `at ${b.encoding}'s` : `between ${a.encoding} and ${b.encoding}`;
    }
    lines.push(`| ${r.link} | ${r.size} | ${r.encoding} | ${fmt(db)} | ${fmt(r.bytes_per_frame, 0)} | ` +
      `${bytes === null ? "" : fmt(bytes, 0)} | ${at} | ${bytes === null ? "" : fmt(r.bytes_per_frame / bytes, 2)} |`);
  }
  if (!lines.length) return [];
  return [
    "",
    "Bytes at equal PSNR: each video row's bytes a frame against JPEG's at the PSNR its canvas showed (the mean " +
      "over its samples), JPEG's taken log-linear between the two JPEG rows of the same link and size whose PSNRs " +
      "hold it.",
    "",
    "| link | size | encoding | PSNR dB | bytes/frame | JPEG's bytes at that PSNR | JPEG rows | ratio |",
    "|---|---|---|---:|---:|---:|---|---:|",
    ...lines,
  ];
}
