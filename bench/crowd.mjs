// A crowd on one server: viewer tabs dragging the camera beside many TCP clients, judged against the targets of a
// fair scheduler, for this build's server and (with --baseline-exe) another build's, side by side in one run.
//   A   TABS tabs dragging beside DRAG_CLIENTS TCP clients dragging (`voxbrick load --drag --interactive`) at SIZE²;
//   B   the same tabs beside BATCH_CLIENTS clients asking BATCH_SIZE² still frames as fast as they can, as a new
//       user's script would (`voxbrick load --clients N --size WxH`, no --batch);
//   B'  the same with --batch.
// Each scenario runs on a fresh server of each binary. The load starts LEAD s before the tabs' drag and lasts until
// TAIL s after it, so each tab's exact frame after release is waited for beside the crowd.
// Usage: node bench/crowd.mjs --datasets DIR [--dataset mri] [--tf mri] [--out PREFIX] [--scenarios A,B,B']
//        [--tabs 16] [--drag-clients 64] [--batch-clients 64] [--size 512] [--batch-size 1024] [--duration 10]
//        [--hz 30] [--lead 1] [--tail 3] [--baseline-exe PATH] [--render-threads N] [--server-config server.toml]
// Writes PREFIX.csv, PREFIX.md and PREFIX.json.

import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { spawnSync } from "node:child_process";
import * as H from "../tests/browser/harness.mjs";
import * as D from "./drag_common.mjs";

const { pct, sum, jain, fmt } = D;
const args = D.parseArgs(process.argv.slice(2));
const opt = {
  datasets: args.datasets,
  dataset: args.dataset || "mri",
  tf: args.tf || "mri",
  out: args.out || "bench/results/crowd/crowd",
  scenarios: (args.scenarios || "A,B,B'").split(","),
  tabs: Number(args.tabs || 16),
  dragClients: Number(args["drag-clients"] || 64),
  batchClients: Number(args["batch-clients"] || 64),
  size: Number(args.size || 512),
  batchSize: Number(args["batch-size"] || 1024),
  duration: Number(args.duration || 10),
  hz: Number(args.hz || 30),
  lead: Number(args.lead || 1),
  tail: Number(args.tail || 3),
  baselineExe: args["baseline-exe"] || null,
  renderThreads: args["render-threads"] || null,
  serverConfig: args["server-config"] ? path.resolve(args["server-config"]) : null,
};
if (!opt.datasets) throw new Error("--datasets DIR is required");

// The targets every row is judged against.
const TARGET = { fps: 5, p99Ms: 1000, jain: 0.9, exactMs: 2000, budgetTimes: 3 };

const stillCrowd = `${opt.tabs} tabs dragging beside ${opt.batchClients} clients asking ${opt.batchSize}² still frames`;
const SCENARIOS = {
  A: {
    crowd: "drag",
    title: `${opt.tabs} tabs dragging beside ${opt.dragClients} TCP clients dragging, ${opt.size}²`,
    load: (features) =>
      ["--clients", String(opt.dragClients), "--size", `${opt.size}x${opt.size}`].concat(
        D.dragLoadOptions(features, opt.hz),
      ),
  },
  B: {
    crowd: "still",
    title: `${stillCrowd}, no --batch`,
    load: () => ["--clients", String(opt.batchClients), "--size", `${opt.batchSize}x${opt.batchSize}`],
  },
  "B'": {
    crowd: "still",
    title: `${stillCrowd} with --batch`,
    load: () => ["--clients", String(opt.batchClients), "--size", `${opt.batchSize}x${opt.batchSize}`, "--batch"],
  },
};
for (const s of opt.scenarios) if (!SCENARIOS[s]) throw new Error(`unknown scenario '${s}' (A, B or B')`);

/// The servers compared: this build's, and the baseline's when given (with the commit beside it, if it says one).
function servers() {
  // Where no git checkout is (a GPU machine's copy of the tree), VOXBRICK_BENCH_BUILD names the build.
  const git = (a) => (spawnSync("git", a, { cwd: H.SOURCE_DIR, encoding: "utf8" }).stdout || "").trim();
  const dirty = git(["status", "--porcelain", "--untracked-files=no"]) ? " (with uncommitted changes)" : "";
  const version = process.env.VOXBRICK_BENCH_BUILD || `${git(["rev-parse", "--short", "HEAD"]) || "unknown"}${dirty}`;
  const list = [{ name: "this build", exe: H.VOXBRICK, version }];
  if (opt.baselineExe) {
    const commitFile = path.join(path.dirname(opt.baselineExe), "COMMIT");
    const commit = fs.existsSync(commitFile) ? fs.readFileSync(commitFile, "utf8").trim().slice(0, 7) : "unknown";
    list.push({ name: "baseline", exe: path.resolve(opt.baselineExe), version: commit });
  }
  return list;
}

/// One scenario on a fresh server of `exe`: the tabs opened, the load started, the tabs' drag LEAD s later, then
/// everything's figures.
async function runScenario(browser, id, server, scratch) {
  const scenario = SCENARIOS[id];
  const extra = ["--max-sessions", "256"];
  if (opt.renderThreads) extra.push("--render-threads", opt.renderThreads);
  const dir = fs.mkdtempSync(path.join(scratch, "run-"));
  const config = opt.serverConfig;
  const s = await new H.Server({ dir, datasets: opt.datasets, extra, exe: server.exe, config }).start();
  try {
    const tabs = [];
    for (let i = 0; i < opt.tabs; ++i)
      tabs.push(await D.openTab(browser, s, {
        dataset: opt.dataset,
        tf: opt.tf,
        size: opt.size,
        azimuth: D.tabAzimuth(i, opt.tabs),
      }));
    const features = (await H.viewerState(tabs[0])).features;
    const options = scenario.load(features).concat(["--duration", String(opt.lead + opt.duration + opt.tail)]);
    const load = D.runLoad(s, { dataset: opt.dataset, tf: opt.tf, json: path.join(dir, "load.json"), options });
    await D.sleep(opt.lead * 1000);
    const drag = { durationMs: opt.duration * 1000, hz: opt.hz };
    const tabResults = await Promise.all(tabs.map((p) => D.tabDrag(p, drag)));
    const t = await load;
    await Promise.all(tabs.map((p) => p.close()));
    return { id, scenario, server, features, tabs: tabResults, load: t, gl: D.glRenderer(s) };
  } finally {
    await s.kill("SIGTERM");
  }
}

const present = (v) => v.filter((x) => x !== null && x !== undefined);
const maxOf = (v) => (present(v).length ? Math.max(...present(v)) : null);
const minOf = (v) => (present(v).length ? Math.min(...present(v)) : null);

const SPLIT = D.SPLIT;

/// A row of the table: the tabs' figures, the TCP crowd's, and each target's pass or fail.
function row(r) {
  const tabs = r.tabs;
  const tabFps = tabs.map((t) => t.fps);
  const exact = tabs.map((t) => t.exact_after_release_ms);
  // The tabs' budget: as the server drew their frames (their statistics), else the one they asked for.
  const askedBudget = r.features.interactive && r.features.time_budget_ms ? D.DRAG_TIME_BUDGET_MS : null;
  const drawnBudget = pct(present(tabs.map((t) => t.budget_ms)), 0.5);
  const budget = drawnBudget ?? askedBudget;
  const worstP99 = maxOf(tabs.map((t) => t.latency_p99_ms));
  const l = r.load;
  const perClient = l.per_client || [];
  const drag = r.scenario.crowd === "drag";
  const out = {
    scenario: r.id,
    server: r.server.name,
    version: r.server.version,
    tabs: tabs.length,
    tcp_clients: perClient.length,
    tcp_crowd: drag ? `dragging ${opt.size}²` : `still ${opt.batchSize}²${l.batch ? " --batch" : ""}`,
    tab_fps_mean: tabs.length ? sum(tabFps) / tabs.length : null,
    tab_fps_min: minOf(tabFps),
    tab_latency_p50_ms: pct(tabs.flatMap((t) => t.latencies), 0.5),
    tab_latency_p99_worst_ms: worstP99,
    jain_tabs: jain(tabFps),
    tab_exact_after_release_max_ms: exact.includes(null) ? null : maxOf(exact),
    tabs_without_exact: exact.filter((v) => v === null).length,
    tab_budget_asked_ms: askedBudget,
    tab_budget_ms: budget,
    tab_p99_over_budget: budget && worstP99 !== null ? worstP99 / budget : null,
    tab_errors: sum(tabs.map((t) => t.errors + t.page_errors)),
    // Tabs whose drag was answered Busy at least once (the server kept as many dragging sessions as it could).
    tabs_busy: tabs.filter((t) => t.busy > 0).length,
    // The camera moves each tab's page made (hz × duration asked): fewer when the machine starved the page.
    tab_moves_min: minOf(tabs.map((t) => t.moves)),
    tab_moves_median: pct(tabs.map((t) => t.moves), 0.5),
    // Where a tab's latency went (drag_common's latencySplit): the median over the tabs of each tab's medians.
    ...Object.fromEntries(
      SPLIT.map((part) => [`tab_${part}_ms`, pct(present(tabs.map((t) => t.latency_split_ms?.[part])), 0.5)]),
    ),
    tcp_fps_total: l.frames_per_s,
    tcp_fps_min: minOf(perClient.map((c) => c.frames_per_s)),
    tcp_latency_p50_ms: l.latency_ms.p50,
    tcp_latency_p99_worst_ms: maxOf(perClient.map((c) => c.latency_ms.p99)),
    jain_tcp: l.jain_index,
    tcp_busy: l.busy,
    tcp_let_in: perClient.filter((c) => c.frames > 0).length,
    tcp_batch_refused: l.batch_refused,
    tcp_protocol_version: l.protocol_version,
    tcp_errors: l.errors,
  };
  // Every interactive session: the tabs, and in A the dragging TCP clients too.
  const judge = (ok) => (ok ? "pass" : "fail");
  out.target_fps = judge(out.tab_fps_min >= TARGET.fps && (!drag || out.tcp_fps_min >= TARGET.fps));
  out.target_p99 = judge(
    worstP99 !== null && worstP99 <= TARGET.p99Ms && (!drag || out.tcp_latency_p99_worst_ms <= TARGET.p99Ms),
  );
  out.target_jain = judge(out.jain_tabs >= TARGET.jain && (!drag || out.jain_tcp >= TARGET.jain));
  const exactMax = out.tab_exact_after_release_max_ms;
  out.target_exact = judge(exactMax !== null && exactMax <= TARGET.exactMs);
  const overBudget = out.tab_p99_over_budget;
  out.target_budget = drag ? "n/a" : judge(overBudget !== null && overBudget <= TARGET.budgetTimes);
  out.errors = out.tab_errors + out.tcp_errors;
  out.pass = judge(
    ["target_fps", "target_p99", "target_jain", "target_exact", "target_budget"].every((k) => out[k] !== "fail") &&
      out.errors === 0,
  );
  return out;
}

const scratch = H.scratchDir("crowd");
const browser = await H.launchBrowser();
const machine = D.describeMachine();
const started = new Date().toISOString();
const runs = [];
try {
  // Every scenario on this build first, then on the baseline: a run cut short (a step's time limit on a lent machine)
  // keeps this build's whole set. The tables put each scenario's servers side by side (report).
  for (const server of servers())
    for (const id of opt.scenarios) {
      console.log(`${id} on ${server.name} (${server.exe}) ...`);
      const r = await runScenario(browser, id, server, scratch.dir);
      console.log(`  ${r.load.summary.split("\n")[0]}`);
      runs.push(r);
      report(runs);
    }
} finally {
  await browser.close();
  scratch.remove();
}
console.log(report(runs).join("\n"));

/// Writes PREFIX.csv, .json and .md of the scenarios run so far (after each one: a run stopped part way keeps what
/// it measured); returns the markdown's lines.
function report(ran) {
  // Scenario by scenario, this build before the baseline, whatever order they ran in.
  const names = servers().map((s) => s.name);
  const place = (r) => opt.scenarios.indexOf(r.id) * names.length + names.indexOf(r.server.name);
  const runs = [...ran].sort((a, b) => place(a) - place(b));
  // The load average once the crowds are gone: over the last minute it still holds the run's own work, so a figure well
  // above the start's over 5 and 15 minutes says something else ran beside it.
  const loadAtEnd = os.loadavg().map((v) => v.toFixed(2));
  const rows = runs.map(row);
  const cols = [
    "scenario",
    "server",
    "version",
    "tabs",
    "tcp_clients",
    "tcp_crowd",
    "tab_fps_mean",
    "tab_fps_min",
    "tab_latency_p50_ms",
    "tab_latency_p99_worst_ms",
    "jain_tabs",
    "tab_exact_after_release_max_ms",
    "tabs_without_exact",
    "tab_budget_asked_ms",
    "tab_budget_ms",
    "tab_p99_over_budget",
    "tab_errors",
    "tabs_busy",
    "tab_moves_min",
    "tab_moves_median",
    ...SPLIT.map((part) => `tab_${part}_ms`),
    "tcp_fps_total",
    "tcp_fps_min",
    "tcp_latency_p50_ms",
    "tcp_latency_p99_worst_ms",
    "jain_tcp",
    "tcp_busy",
    "tcp_let_in",
    "tcp_batch_refused",
    "tcp_protocol_version",
    "tcp_errors",
    "target_fps",
    "target_p99",
    "target_jain",
    "target_exact",
    "target_budget",
    "pass",
  ];
  const command = D.benchCommand();
  D.writeCsv(`${opt.out}.csv`, cols, rows);
  const loadCommands = Object.fromEntries(
    runs.map((r) => [r.id, D.loadCommand(r.load.argv)]),
  );
  const gl = runs.find((r) => r.gl)?.gl ?? "unknown";
  fs.writeFileSync(
    `${opt.out}.json`,
    JSON.stringify(
      {
        command,
        started,
        machine,
        load_average_at_end: loadAtEnd,
        gl_renderer: gl,
        options: opt,
        targets: TARGET,
        load_commands: loadCommands,
        rows,
        runs: runs.map((r) => ({
          scenario: r.id,
          server: r.server,
          features: r.features,
          tabs: r.tabs.map(D.tabFigures),
          load: r.load,
        })),
      },
      null,
      2,
    ) + "\n",
  );

  // A run smaller than the benchmark's says so at its head.
  const full = { tabs: 16, "drag-clients": 64, "batch-clients": 64, size: 512, "batch-size": 1024, duration: 10 };
  const optionOf = (flag) => flag.replace(/-(.)/g, (_, c) => c.toUpperCase()); // "drag-clients" -> "dragClients"
  const smaller = Object.keys(full)
    .filter((flag) => opt[optionOf(flag)] < full[flag])
    .map((flag) => `--${flag} ${opt[optionOf(flag)]}, not ${full[flag]}`);
  const mark = (v) => (v === "pass" ? "pass" : v === "fail" ? "**fail**" : v);
  const md = [
    "# A crowd on one server: viewer tabs beside many TCP clients",
    "",
    ...(smaller.length ? [`**A smoke run**, smaller than the benchmark: ${smaller.join("; ")}.`, ""] : []),
    `- Command: \`${command}\``,
    `- Date: ${started}`,
    `- Machine: ${machine.cpu}, ${machine.cores} cores, ${machine.memory}; load average at the start ` +
      `${machine.load_average.join(", ")}, at the end ${loadAtEnd.join(", ")} (1, 5, 15 min); ${machine.chromium}; ` +
      `GL: ${gl}`,
    `- Servers: ${servers()
      .map((s) => `${s.name} \`${s.exe}\` (${s.version})`)
      .join("; ")}. Each scenario runs on a fresh server of each, \`--max-sessions 256\`` +
      `${opt.serverConfig ? `, configured by \`${path.relative(process.cwd(), opt.serverConfig)}\`` : ""}` +
      `${opt.renderThreads ? `, \`--render-threads ${opt.renderThreads}\`` : ""}` +
      ".",
    `- Dataset \`${opt.dataset}\`, transfer function \`${opt.tf}\`. Tabs: the viewer at ${opt.size}², a drag of ` +
      `${opt.duration} s at ${opt.hz} Hz through the page's own gesture handlers, ${D.DEG_PER_MOVE}° a move. The TCP ` +
      `crowd starts ${opt.lead} s before the drag and lasts until ${opt.tail} s after it:`,
    ...opt.scenarios.map(
      (id) => `  - ${id}: ${SCENARIOS[id].title}: ${loadCommands[id] ? `\`${loadCommands[id]}\`` : "not run"}`,
    ),
    "- Tab figures: frames shown a second while dragging (mean and the slowest tab), camera-to-frame latency (p50 " +
      "over every tab's frames, and the worst tab's p99), Jain's index over the tabs' frames a second, the exact frame " +
      "after release (the slowest tab; none: some tab had none within 30 s; one later than the crowd's last " +
      `${opt.tail} s came from a quieter server), the time budget the server drew their moving frames to (their ` +
      "statistics; the one asked for where the page does not record it) and the worst p99 over it. TCP figures from " +
      "`voxbrick load --json`: frames a second in all and of the slowest client, latency, Jain's index over its " +
      "clients, `Busy` replies (waited out, not errors) and errors. `Busy`: the tabs whose drag was answered `Busy` " +
      "at least once, and the TCP clients' `Busy` replies.",
    `- Targets: every interactive session (the tabs; in A the dragging TCP clients too) ≥ ${TARGET.fps} frames shown a ` +
      `second, p99 ≤ ${TARGET.p99Ms / 1000} s, Jain ≥ ${TARGET.jain}, the exact frame ≤ ${TARGET.exactMs / 1000} s ` +
      `after release; beside the still crowd (B, B') the tabs' p99 ≤ ${TARGET.budgetTimes}× their time budget.`,
    "",
    "| scenario | server | tab frames/s mean (min) | tab p50 ms | tab worst p99 ms | Jain tabs | exact after release " +
      "ms | budget ms | p99/budget | TCP frames/s (slowest) | TCP p99 ms | Jain TCP | Busy | errors | ≥5/s | " +
      "p99 ≤1 s | Jain ≥0.9 | exact ≤2 s | p99 ≤3× budget | all |",
    "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---|---|---|---|",
    ...rows.map((r) => {
      const exact = r.tab_exact_after_release_max_ms;
      const cells = [
        r.scenario,
        r.server,
        `${fmt(r.tab_fps_mean)} (${fmt(r.tab_fps_min)})`,
        fmt(r.tab_latency_p50_ms, 0),
        fmt(r.tab_latency_p99_worst_ms, 0),
        fmt(r.jain_tabs, 3),
        exact === null ? `none (${r.tabs_without_exact} tabs)` : fmt(exact, 0),
        fmt(r.tab_budget_ms, 0),
        fmt(r.tab_p99_over_budget, 1),
        `${fmt(r.tcp_fps_total)} (${fmt(r.tcp_fps_min)})`,
        fmt(r.tcp_latency_p99_worst_ms, 0),
        fmt(r.jain_tcp, 3),
        `${r.tabs_busy ?? 0} tabs, ${r.tcp_busy}`,
        r.errors,
        ...["target_fps", "target_p99", "target_jain", "target_exact", "target_budget", "pass"].map((k) => mark(r[k])),
      ];
      return `| ${cells.join(" | ")} |`;
    }),
    "",
    "TCP p99 is the worst client's; `all` passes when every target that applies does and nothing failed. A server " +
      "that does not know the scene key `batch` (the baseline) refuses it and the load's clients go on without it " +
      "(`tcp_batch_refused` in the CSV); a server of protocol version 2 never sends `Busy` (`tcp_protocol_version`).",
    "",
    "Where a tab's moving frames' latency went, ms (each tab's medians, the median over the tabs; the parts' medians " +
      "need not add up to the p50): the camera's wait for a Render slot in the page (ask); on the server the Render's " +
      "wait for a render thread (queue), its drawing (render), the frame's way to its session and wait for its " +
      "encoding (encoder: the session's frame before it, an encoder thread; frames drawn once for several sessions " +
      "left out of these three) and the encoding (encode); the rest of the time from the Render " +
      "sent to its reply's arrival (output: the frame's wait on the server's output and the link's pace, and the link " +
      "both ways); the page's decoding (decode) and the rest of its time to the frame drawn (page: its event loop, " +
      "drawing). Empty: the page or server does not say. Moves: the camera moves the tabs' pages made, of the " +
      `${opt.hz * opt.duration} asked (median, and the fewest): fewer where the machine starved the pages.`,
    "",
    "| scenario | server | moves (fewest) | tab p50 ms | ask | queue | render | encoder | encode | output | decode | " +
      "page |",
    "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ...rows.map((r) => {
      const moves = `${fmt(r.tab_moves_median, 0)} (${fmt(r.tab_moves_min, 0)})`;
      const parts = SPLIT.map((p) => fmt(r[`tab_${p}_ms`], 0));
      return `| ${[r.scenario, r.server, moves, fmt(r.tab_latency_p50_ms, 0), ...parts].join(" | ")} |`;
    }),
    "",
  ];
  fs.writeFileSync(`${opt.out}.md`, md.join("\n"));
    return md;
  }

