// The server's status page: reads /metrics (with the page's ?token=) every second and shows the server's own health:
// sessions, frames per second and latency by class, queue depth, how busy each render thread is, cache hit rates,
// memory and refusals. Rates and latencies are over the last WINDOW_S seconds of scrapes. Exposes a small hook for
// tests (window.voxbrickStatus).

import * as M from "./metrics.js";
import { takeToken } from "./token.js";

const params = new URLSearchParams(location.search);
/// The access token, out of the address from here on and kept in memory only (token.js).
const accessToken = takeToken(params);
const INTERVAL_MS = Math.max(200, Number(params.get("interval")) || 1000);
const WINDOW_S = 10;
const CLASSES = ["interactive", "still", "batch"];
const $ = (id) => document.getElementById(id);

const app = { scrapes: [], count: 0, error: "", figures: null };

function metricsUrl() {
  const server = params.get("server");
  const base = server ? `${location.protocol}//${server}/metrics` : new URL("metrics", location.href).pathname;
  return `${base}${accessToken ? `?token=${encodeURIComponent(accessToken)}` : ""}`;
}

const fmt = {
  n: (v, digits = 0) => (v === null || v === undefined || Number.isNaN(v) ? "–" : v.toFixed(digits)),
  ms: (s) => (s === null || s === undefined ? "–" : `${(s * 1000).toFixed(s < 0.1 ? 1 : 0)} ms`),
  pct: (v) => (v === null || v === undefined || Number.isNaN(v) ? "–" : `${(v * 100).toFixed(1)} %`),
  bytes: (b) => {
    if (b === null || b === undefined || Number.isNaN(b)) return "–";
    const units = ["B", "KiB", "MiB", "GiB", "TiB"];
    let i = 0;
    while (b >= 1024 && i < units.length - 1) [b, i] = [b / 1024, i + 1];
    return `${b.toFixed(i ? 1 : 0)} ${units[i]}`;
  },
  duration: (s) => {
    const d = Math.floor(s / 86400);
    const h = Math.floor((s % 86400) / 3600);
    const m = Math.floor((s % 3600) / 60);
    return `${d ? `${d} d ` : ""}${h || d ? `${h} h ` : ""}${m} min ${Math.floor(s % 60)} s`;
  },
};

/// The figures of the newest scrape `b` against `a`, the oldest within the window (null: none yet).
function figuresOf(a, b, seconds) {
  const r = (name, match) => M.rate(a, b, seconds, name, match);
  const v = (name, match) => M.total(b, name, match);
  const byClass = CLASSES.map((c) => ({
    class: c,
    framesPerS: r("voxbrick_frames_total", { class: c }),
    p50: M.quantile(a, b, "voxbrick_frame_latency_seconds", 0.5, { class: c }),
    p99: M.quantile(a, b, "voxbrick_frame_latency_seconds", 0.99, { class: c }),
    queued: v("voxbrick_queue_depth", { class: c }),
    frames: v("voxbrick_frames_total", { class: c }),
    bytesPerS: r("voxbrick_frame_bytes_total", { class: c }),
  }));
  const threads = M.labelValues(b, "voxbrick_render_thread_busy_seconds_total", "thread").map((t) => ({
    thread: t,
    busy: a ? r("voxbrick_render_thread_busy_seconds_total", { thread: t }) : null,
    seconds: v("voxbrick_render_thread_busy_seconds_total", { thread: t }),
  }));
  const datasets = M.labelValues(b, "voxbrick_cache_hits_total", "dataset").map((d) => {
    const hits = r("voxbrick_cache_hits_total", { dataset: d });
    const misses = r("voxbrick_cache_misses_total", { dataset: d });
    const allHits = v("voxbrick_cache_hits_total", { dataset: d });
    const allMisses = v("voxbrick_cache_misses_total", { dataset: d });
    return {
      dataset: d,
      hitRate: hits + misses > 0 ? hits / (hits + misses) : null,
      hitRateAll: allHits + allMisses > 0 ? allHits / (allHits + allMisses) : null,
      resident: v("voxbrick_cache_resident_bytes", { dataset: d }),
      budget: v("voxbrick_cache_budget_bytes", { dataset: d }),
      quarantined: v("voxbrick_dataset_quarantined", { dataset: d }) > 0,
    };
  });
  const refusals = M.labelValues(b, "voxbrick_refusals_total", "reason").map((reason) => ({
    reason,
    total: v("voxbrick_refusals_total", { reason }),
    perS: r("voxbrick_refusals_total", { reason }),
  }));
  return {
    uptimeS: v("voxbrick_uptime_seconds"),
    windowS: seconds,
    sessions: {
      tcp: v("voxbrick_sessions", { transport: "tcp" }),
      websocket: v("voxbrick_sessions", { transport: "websocket" }),
    },
    pending: v("voxbrick_pending_connections"),
    accepted: v("voxbrick_sessions_accepted_total"),
    framesPerS: r("voxbrick_frames_total"),
    framesTotal: v("voxbrick_frames_total"),
    bytesOutPerS: r("voxbrick_bytes_written_total"),
    byClass,
    threads,
    datasets,
    refusals,
    counters: {
      "render errors": v("voxbrick_render_errors_total"),
      superseded: v("voxbrick_renders_superseded_total"),
      refined: v("voxbrick_renders_refined_total"),
      cancelled: v("voxbrick_renders_cancelled_total"),
      "frames shared": v("voxbrick_frames_shared_total"),
      timeouts: v("voxbrick_timeouts_total"),
      "slow clients dropped": v("voxbrick_slow_clients_dropped_total"),
      "protocol errors": v("voxbrick_protocol_errors_total"),
    },
    memory: {
      rss: v("voxbrick_resident_memory_bytes"),
      peakRss: v("voxbrick_resident_memory_peak_bytes"),
      gpu: v("voxbrick_gpu_atlas_bytes"),
      gpuBudget: v("voxbrick_gpu_budget_bytes"),
      output: v("voxbrick_output_queued_bytes"),
      outputLimit: v("voxbrick_output_limit_bytes"),
      videoEncoders: v("voxbrick_video_encoders"),
      video: v("voxbrick_video_memory_bytes"),
      videoLimit: v("voxbrick_video_memory_limit_bytes"),
      videoJpegFrames: v("voxbrick_video_jpeg_frames_total"),
    },
  };
}

/// A table body of `rows` (arrays of cell texts) under `headers`.
function table(headers, rows) {
  const t = document.createElement("table");
  const head = t.createTHead().insertRow();
  for (const h of headers) head.appendChild(document.createElement("th")).textContent = h;
  const body = t.createTBody();
  for (const row of rows) {
    const tr = body.insertRow();
    for (const cell of row) tr.insertCell().textContent = cell;
  }
  return t;
}

function show(f) {
  $("uptime").textContent = `up ${fmt.duration(f.uptimeS)} · figures over the last ${fmt.n(f.windowS, 0)} s`;
  const put = (id, el) => $(id).replaceChildren(el);
  put(
    "sessions",
    table(
      ["TCP", "WebSocket", "pending", "accepted", "frames/s", "out"],
      [
        [f.sessions.tcp, f.sessions.websocket, f.pending, f.accepted].map(String).concat([
          fmt.n(f.framesPerS, 1),
          `${fmt.bytes(f.bytesOutPerS)}/s`,
        ]),
      ],
    ),
  );
  put(
    "classes",
    table(
      ["class", "frames/s", "p50", "p99", "queued", "frames", "out"],
      f.byClass.map((c) => [
        c.class,
        fmt.n(c.framesPerS, 1),
        fmt.ms(c.p50),
        fmt.ms(c.p99),
        String(c.queued),
        String(c.frames),
        `${fmt.bytes(c.bytesPerS)}/s`,
      ]),
    ),
  );
  put(
    "threads",
    table(
      ["render thread", "busy", "busy in all"],
      f.threads.map((t) => [t.thread, fmt.pct(t.busy), `${fmt.n(t.seconds, 1)} s`]),
    ),
  );
  put(
    "datasets",
    f.datasets.length
      ? table(
          ["dataset", "cache hits (recent)", "cache hits (all)", "cache", "state"],
          f.datasets.map((d) => [
            d.dataset,
            fmt.pct(d.hitRate),
            fmt.pct(d.hitRateAll),
            `${fmt.bytes(d.resident)} of ${fmt.bytes(d.budget)}`,
            d.quarantined ? "quarantined" : "ok",
          ]),
        )
      : document.createTextNode("no dataset open yet"),
  );
  const m = f.memory;
  put(
    "memory",
    table(
      ["resident", "peak", "GPU atlases", "replies queued", "video encoders", "moving frames as JPEG for want of it"],
      [
        [
          fmt.bytes(m.rss),
          fmt.bytes(m.peakRss),
          `${fmt.bytes(m.gpu)} of ${fmt.bytes(m.gpuBudget)}`,
          `${fmt.bytes(m.output)} of ${fmt.bytes(m.outputLimit)}`,
          `${m.videoEncoders}: ${fmt.bytes(m.video)} of ${fmt.bytes(m.videoLimit)}`,
          String(m.videoJpegFrames),
        ],
      ],
    ),
  );
  put(
    "refusals",
    table(
      ["refused for", "in all", "per s"],
      f.refusals.map((x) => [x.reason, String(x.total), fmt.n(x.perS, 2)]),
    ),
  );
  put("counters", table(Object.keys(f.counters), [Object.values(f.counters).map(String)]));
}

async function poll() {
  try {
    const r = await fetch(metricsUrl(), { cache: "no-store" });
    const text = await r.text();
    if (!r.ok) throw new Error(`HTTP ${r.status}: ${text.trim().slice(0, 200)}`);
    const parsed = M.parseMetrics(text);
    const now = performance.now();
    app.scrapes.push({ at: now, parsed });
    while (app.scrapes.length > 2 && now - app.scrapes[1].at >= WINDOW_S * 1000) app.scrapes.shift();
    const first = app.scrapes.length > 1 ? app.scrapes[0] : null;
    app.figures = figuresOf(first && first.parsed, parsed, first ? (now - first.at) / 1000 : 0);
    app.count++;
    app.error = "";
    show(app.figures);
  } catch (e) {
    app.error = e.message;
  }
  $("error").hidden = !app.error;
  $("error").textContent = app.error ? `The server's metrics could not be read: ${app.error}` : "";
  setTimeout(poll, INTERVAL_MS);
}

const viewer = new URL("./", location.href);
viewer.search = "";
if (accessToken) viewer.searchParams.set("token", accessToken);
if (params.get("server")) viewer.searchParams.set("server", params.get("server"));
$("viewer-link").href = viewer.pathname + viewer.search;

// The test hook: what the page shows, so tests need no scraping of its tables.
window.voxbrickStatus = {
  state: () => ({ scrapes: app.count, error: app.error, figures: app.figures }),
};

poll();
