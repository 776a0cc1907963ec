// The server's status page (web/status.html) in a real browser against the real `voxbrick serve --http` with an
// access token: the page's metrics reader against the server's /metrics, the viewer's link carrying the token, the
// figures moving while `voxbrick load` renders, and a wrong token shown as such.

import assert from "node:assert/strict";
import { after, before, describe, test } from "node:test";
import * as H from "./harness.mjs";
import * as M from "../../web/js/metrics.js";

const TOKEN = "status-Token_1";

describe("status page", () => {
  let scratch, server, browser;

  before(async () => {
    scratch = H.scratchDir("status");
    const datasets = H.prepDatasets(scratch.dir, { sparse: "synthetic:sparse,n=32" });
    const extra = ["--http-token", TOKEN, "--render-threads", "1"];
    server = await new H.Server({ dir: scratch.dir, datasets, extra }).start();
    browser = await H.launchBrowser();
  });

  after(async () => {
    if (browser) await browser.close();
    if (server) await server.kill();
    if (scratch) scratch.remove();
  });

  test("the page's metrics reader reads the server's /metrics", async () => {
    const r = await H.httpGet(`${server.url}/metrics`, { authorization: `Bearer ${TOKEN}` });
    assert.equal(r.status, 200);
    const parsed = M.parseMetrics(r.body.toString());
    assert.equal(parsed.types.voxbrick_frames_total, "counter");
    assert.equal(parsed.types.voxbrick_frame_latency_seconds, "histogram");
    assert.deepEqual(M.labelValues(parsed, "voxbrick_queue_depth", "class"), ["interactive", "still", "batch"]);
    assert.equal(M.total(parsed, "voxbrick_render_threads"), 1);
    // A histogram's quantile between two scrapes: 4 observations, 2 at most 0.1 s and 2 at most 1 s.
    const scrape = (counts) =>
      M.parseMetrics(
        counts.map(([le, n]) => `h_bucket{class="still",le="${le}"} ${n}`).join("\n") + `\nh_sum{class="still"} 1\n`,
      );
    const a = scrape([["0.1", 10], ["1", 10], ["+Inf", 10]]);
    const b = scrape([["0.1", 12], ["1", 14], ["+Inf", 14]]);
    assert.equal(M.quantile(a, b, "h", 0.5, { class: "still" }), 0.1);
    assert.ok(Math.abs(M.quantile(a, b, "h", 0.75, { class: "still" }) - 0.55) < 1e-9);
    assert.equal(M.quantile(b, b, "h", 0.5), null, "no new observations");
    assert.equal(M.rate(a, b, 2, "h_bucket", { le: "1" }), 2);
    assert.throws(() => M.parseMetrics("not metrics at all"), /not a line/);
  });

  test("the viewer links to it with its token, which neither page keeps in its address", async () => {
    const page = await H.openPage(browser, `${server.url}/?token=${TOKEN}`);
    const href = await page.$eval("#status-link", (a) => a.href);
    assert.equal(href, `${server.url}/status.html?token=${TOKEN}`);
    assert.doesNotMatch(await page.evaluate(() => location.href), /token/);
    await page.goto(href, { waitUntil: "load" });
    await page.waitForFunction(() => window.voxbrickStatus && window.voxbrickStatus.state().scrapes >= 1);
    assert.equal(await page.evaluate(() => window.voxbrickStatus.state().error), "", "it read the metrics with the token");
    assert.equal(await page.evaluate(() => location.href), `${server.url}/status.html`);
    assert.equal(await page.$eval("#viewer-link", (a) => a.href), `${server.url}/?token=${TOKEN}`);
    await page.close();
  });

  test("its figures move while frames are rendered", async () => {
    const page = await browser.newPage();
    const errors = [];
    page.on("pageerror", (e) => errors.push(e.message));
    await page.goto(`${server.url}/status.html?token=${TOKEN}&interval=250`, { waitUntil: "load" });
    const state = () => page.evaluate(() => window.voxbrickStatus.state());
    await page.waitForFunction(() => window.voxbrickStatus && window.voxbrickStatus.state().scrapes >= 2, {
      timeout: 10000,
    });
    const idle = await state();
    assert.equal(idle.error, "");
    assert.equal(idle.figures.framesPerS, 0);
    // Frames for a second and a half, from two clients (the load tool waits for them: the page keeps polling).
    const load = ["--dataset", "sparse", "--clients", "2", "--duration", "1.5", "--size", "64x48"];
    H.voxbrick(["load", `127.0.0.1:${server.tcpPort}`, ...load]);
    await page.waitForFunction(
      (before) => {
        const f = window.voxbrickStatus.state().figures;
        const still = f.byClass.find((c) => c.class === "still");
        return f.framesTotal > before && still.framesPerS > 0 && still.p50 !== null && f.threads[0].busy > 0;
      },
      { timeout: 10000, polling: 100 },
      idle.figures.framesTotal,
    );
    const busy = await state();
    const sparse = busy.figures.datasets.find((d) => d.dataset === "sparse");
    assert.ok(sparse && sparse.hitRateAll !== null, `the cache's figures: ${JSON.stringify(busy.figures.datasets)}`);
    assert.ok(busy.figures.memory.rss > 1 << 20);
    // The video encoders' memory: the server's budget (memory.video_mb's default), none held by these still frames.
    assert.equal(busy.figures.memory.videoLimit, 4096 * 2 ** 20);
    assert.equal(busy.figures.memory.videoEncoders, 0);
    const memoryRow = await page.$eval("#memory tbody tr", (r) => r.textContent);
    assert.match(memoryRow, /0: 0 B of 4\.0 GiB/);
    const stillRow = await page.$$eval("#classes tbody tr", (rows) => rows.map((r) => r.textContent));
    assert.ok(stillRow.some((t) => t.startsWith("still") && !t.includes("–")), `the still row: ${stillRow}`);
    await H.screenshot(page, "status");
    assert.deepEqual(errors, []);
    await page.close();
  });

  test("a wrong token is shown as the server's refusal", async () => {
    const page = await browser.newPage();
    await page.goto(`${server.url}/status.html?token=wrong`, { waitUntil: "load" });
    await page.waitForFunction(() => document.getElementById("error").textContent.includes("HTTP 403"), {
      timeout: 10000,
    });
    const text = await page.$eval("#error", (e) => e.textContent);
    assert.match(text, /wrong access token/);
    await page.close();
  });
});
