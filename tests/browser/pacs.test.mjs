// A PACS's series in the viewer: a real Orthanc (Debian's, with its DICOMweb plugin) on loopback holding the cases of
// tests/brickstore/dicom_cases.py (pacs), the real `voxbrick serve --http` listing it through a [[pacs]] entry of its
// configuration, and the page in Debian's Chromium, headless. The page lists the image series (not the RT plan's or
// the report's), says in its banner that the server is fetching the one asked for while the server answers Busy, and
// shows its exact frame once the series is fetched; one chosen from the list goes the same way. Screenshots go to
// build/browser-screenshots/ (VOXBRICK_SCREENSHOTS).

import assert from "node:assert/strict";
import { spawnSync } from "node:child_process";
import crypto from "node:crypto";
import fs from "node:fs";
import path from "node:path";
import { after, before, describe, test } from "node:test";
import * as H from "./harness.mjs";

const ORTHANC = process.env.VOXBRICK_ORTHANC || "/usr/sbin/Orthanc";
const ORTHANC_DICOMWEB =
  process.env.VOXBRICK_ORTHANC_DICOMWEB || "/usr/share/orthanc/plugins/libOrthancDicomWeb.so";
const PYTHON = "/usr/bin/python3"; // Debian's: the one with python3-pydicom and numpy (scripts/setup.sh)
const SIZE = [160, 128];
const SIZE_PARAM = `size=${SIZE[0]}x${SIZE[1]}`;
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/// The *.dcm files under `dirs`, those without an image (no Rows: the RT plan, the report) first. Orthanc gives a
/// series the Modality of the first instance it stores, so the CT series, whose plan and report come first, is a
/// series of Modality RTPLAN or SR on the PACS: the hard case, on purpose. The server must still list it (it judges
/// such a series by its instances' SOP classes), and must not list the plan's and the report's own series.
function nonImagesFirst(dirs) {
  const script = [
    "import json, pathlib, sys, pydicom",
    "files = sorted(str(f) for d in sys.argv[1:] for f in pathlib.Path(d).rglob('*.dcm'))",
    "files.sort(key=lambda f: 'Rows' in pydicom.dcmread(f, stop_before_pixels=True))",
    "print(json.dumps(files))",
  ].join("\n");
  const r = spawnSync(PYTHON, ["-c", script, ...dirs], { encoding: "utf8" });
  if (r.status !== 0) throw new Error(`ordering the DICOM files failed: ${r.stdout}${r.stderr}`);
  return JSON.parse(r.stdout);
}

/// A real Orthanc as tests/dicomweb/Processes.cpp starts one: a generated configuration, HTTP on a free loopback
/// port, authentication on with one user of a random password, the DICOM port off, its storage in `dir`.
class Orthanc {
  constructor(dir) {
    this.dir = dir;
    this.user = "voxbrick";
    this.password = crypto.randomBytes(15).toString("base64url");
  }

  async start() {
    for (const f of [ORTHANC, ORTHANC_DICOMWEB])
      if (!fs.existsSync(f)) throw new Error(`no ${f} (scripts/setup.sh installs orthanc and orthanc-dicomweb)`);
    this.port = await H.freePort();
    const storage = path.join(this.dir, "storage");
    fs.mkdirSync(storage, { recursive: true });
    const config = path.join(this.dir, "orthanc.json");
    fs.writeFileSync(
      config,
      JSON.stringify(
        {
          Name: "voxbrick-test",
          StorageDirectory: storage,
          IndexDirectory: storage,
          HttpPort: this.port,
          DicomServerEnabled: false,
          RemoteAccessAllowed: false, // loopback clients only
          AuthenticationEnabled: true,
          RegisteredUsers: { [this.user]: this.password },
          Plugins: [ORTHANC_DICOMWEB],
          DicomWeb: { Enable: true, Root: "/dicom-web/", EnableWado: false },
          ConcurrentJobs: 1,
          HttpThreadsCount: 8,
        },
        null,
        2,
      ),
    );
    this.logFile = path.join(this.dir, "orthanc.log");
    const log = fs.openSync(this.logFile, "w");
    this.proc = H.spawnTied(ORTHANC, [config], { cwd: this.dir, stdio: ["ignore", log, log] });
    fs.closeSync(log);
    this.exited = new Promise((resolve) => this.proc.on("exit", (code, signal) => resolve(code ?? signal)));
    let gone = false;
    this.exited.then(() => (gone = true));
    const deadline = Date.now() + 30000;
    while (Date.now() < deadline) {
      if (gone) throw new Error(`${ORTHANC} exited: ${this.log()}`);
      const r = await H.httpGet(`${this.url}/system`, { Authorization: this.authorization });
      if (r && r.status === 200) return this;
      await sleep(50);
    }
    await this.kill();
    throw new Error(`Orthanc did not answer in 30 s: ${this.log()}`);
  }

  get url() {
    return `http://127.0.0.1:${this.port}`;
  }

  get authorization() {
    return `Basic ${Buffer.from(`${this.user}:${this.password}`).toString("base64")}`;
  }

  /// What an auth file (auth_file of [[pacs]]) holds for it.
  get credentials() {
    return `basic ${this.user}:${this.password}`;
  }

  /// POSTs each of `files` to /instances, in order, as a modality would store them; throws unless each is taken.
  async upload(files) {
    for (const file of files) {
      const r = await fetch(`${this.url}/instances`, {
        method: "POST",
        headers: { Authorization: this.authorization, "Content-Type": "application/dicom" },
        body: fs.readFileSync(file),
      });
      const text = await r.text();
      if (r.status !== 200) throw new Error(`POST /instances of ${file}: HTTP ${r.status} ${text}\n${this.log()}`);
    }
  }

  log() {
    try {
      return fs.readFileSync(this.logFile, "utf8");
    } catch {
      return "(no log)";
    }
  }

  async kill() {
    if (!this.proc || this.proc.exitCode !== null || this.proc.signalCode !== null) return;
    this.proc.kill("SIGKILL");
    await this.exited;
  }
}

const waitExact = H.waitExact;

/// Keeps every text the page's banner shows, in order, in window.banners ("" while hidden), each with the dataset open
/// and the frames shown then. Run before the page's scripts (openPage's `beforeLoad`): the Busy text lasts as long as
/// the server's retry hint (a second), and on a loaded machine the page may have shown it and opened the dataset
/// before a test could start watching; an observer there from the start cannot miss it.
const watchBanner = () => {
  window.banners = [];
  const record = () => {
    const b = document.getElementById("banner");
    if (!b) return;
    const s = window.voxbrickViewer ? window.voxbrickViewer.state() : { dataset: "", counts: { shown: 0 } };
    const r = { text: b.hidden ? "" : b.textContent, dataset: s.dataset, shown: s.counts.shown };
    if (!window.banners.length || window.banners[window.banners.length - 1].text !== r.text) window.banners.push(r);
  };
  const all = { attributes: true, childList: true, characterData: true, subtree: true };
  new MutationObserver(record).observe(document, all);
};

/// Starts window.banners again from what the banner shows now.
const recordBanner = (page) =>
  page.evaluate(() => {
    const b = document.getElementById("banner");
    const s = window.voxbrickViewer.state();
    window.banners = [{ text: b.hidden ? "" : b.textContent, dataset: s.dataset, shown: s.counts.shown }];
  });

const banners = (page) => page.evaluate(() => window.banners.slice());

/// Waits until the banner has shown what the page says of series `uid` while the server fetches it (then `more`, a
/// RegExp's source); returns that record.
const waitBusy = async (page, uid, more = "") => {
  const source = `series ${uid.replaceAll(".", "\\.")} of PACS 'ward'${more}`;
  const seen = (re) => window.banners.some((b) => new RegExp(re).test(b.text));
  try {
    await page.waitForFunction(seen, { timeout: 20000 }, source);
  } catch (e) {
    throw new Error(`${e.message}: no ${source} in the banner: ${JSON.stringify(await banners(page))}`);
  }
  return (await banners(page)).find((b) => new RegExp(source).test(b.text));
};

describe("a PACS's series in the viewer", () => {
  let scratch, uids, orthanc, server, browser, page, datasets;
  const ct = () => `ward.${uids.ct.series}`;
  const enhanced = () => `ward.${uids.enhanced.series}`;

  before(async () => {
    scratch = H.scratchDir("pacs");
    const cases = path.join(scratch.dir, "cases");
    const made = spawnSync(PYTHON, [path.join(H.SOURCE_DIR, "tests/brickstore/dicom_cases.py"), "pacs", cases], {
      encoding: "utf8",
    });
    if (made.status !== 0)
      throw new Error(`dicom_cases.py pacs (needs Debian's python3-pydicom and numpy): ${made.stdout}${made.stderr}`);
    uids = JSON.parse(fs.readFileSync(path.join(cases, "uids.json"), "utf8"));
    orthanc = await new Orthanc(path.join(scratch.dir, "orthanc")).start();
    // The CT's study (its series, with an RT plan and a report filed in it, and the plan's and the report's series of
    // their own) and the Enhanced CT: what the listing must hold and leave out. The other cases (16 MB of noise, a
    // series of 160 files) would only slow the upload.
    await orthanc.upload(nonImagesFirst(["ct", "plan", "report", "enhanced"].map((f) => path.join(cases, f))));
    const auth = path.join(scratch.dir, "auth");
    fs.writeFileSync(auth, `${orthanc.credentials}\n`, { mode: 0o600 });
    datasets = path.join(scratch.dir, "datasets");
    fs.mkdirSync(datasets);
    const config = path.join(scratch.dir, "server.toml");
    fs.writeFileSync(
      config,
      [
        "[server]",
        `datasets = ${JSON.stringify(datasets)}`,
        "[[pacs]]",
        'id = "ward"',
        `url = "${orthanc.url}/dicom-web"`,
        `auth_file = ${JSON.stringify(auth)}`,
        "refresh_s = 2",
        "",
      ].join("\n"),
    );
    // One render thread: the CT's first frames are then those `voxbrick render --progressive` draws (viewer.test.mjs).
    server = await new H.Server({ dir: scratch.dir, config, extra: ["--render-threads", "1"] }).start();
    // The page lists the datasets once, when it connects: it must come after the server's first listing of the PACS.
    const deadline = Date.now() + 30000;
    for (;;) {
      const listed = spawnSync(H.VOXBRICK, ["request", `127.0.0.1:${server.tcpPort}`, "--list"], { encoding: "utf8" });
      if (listed.stdout && listed.stdout.includes(ct())) break;
      if (Date.now() > deadline)
        throw new Error(`the server did not list ${ct()} in 30 s: ${listed.stdout}${listed.stderr}\n${server.log()}`);
      await sleep(200);
    }
    browser = await H.launchBrowser();
  });

  after(async () => {
    if (browser) await browser.close();
    if (server) await server.kill();
    if (orthanc) await orthanc.kill();
    if (scratch) scratch.remove();
  });

  /// `voxbrick render` of the server's cached store of `dataset` (its PACS cache, datasets/.pacs) as the page's last
  /// Render asked it, decoded.
  const reference = (dataset, scene) => {
    const out = path.join(scratch.dir, `ref-${Date.now()}.png`);
    const flags = ["--size", `${SIZE[0]}x${SIZE[1]}`, "--orbit", scene.camera.orbit.join(",")];
    flags.push("--tf", scene.transfer_function);
    if (scene.progressive) flags.push("--progressive");
    H.voxbrick(["render", path.join(datasets, ".pacs", dataset), ...flags, "-o", out]);
    return H.decodePng(fs.readFileSync(out));
  };

  /// The pixels on the canvas: the PNG the server sent last, untouched, and not blank (measured: 7067 of the 20480
  /// pixels lit for the CT, 3173 for the Enhanced CT).
  const shownFrame = async (what) => {
    const shown = await H.canvasPixels(page);
    const payload = Buffer.from(await page.evaluate(() => window.voxbrickViewer.lastPayload()), "base64");
    assert.deepEqual(H.compareImages(shown, H.decodePng(payload)), { differing: 0, maxDiff: 0 }, what);
    assert.ok(H.litPixels(shown) > 500, `${what}: lit pixels ${H.litPixels(shown)}`);
    return shown;
  };

  test("the address's series: listed with the other image series, Busy while fetched, then its frame", async () => {
    page = await H.openPage(browser, `${server.url}/?dataset=${ct()}&${SIZE_PARAM}`, undefined, watchBanner);
    // (1) The image series are listed, in the page's state and in its panel's list; the RT plan's and the report's
    // series hold no image and are not.
    const listed = await H.waitForState(page, (s) => s.datasets.length > 0);
    assert.ok(listed.datasets.includes(ct()), JSON.stringify(listed.datasets));
    assert.ok(listed.datasets.includes(enhanced()), JSON.stringify(listed.datasets));
    for (const other of [uids.ct.plan, uids.ct.report])
      assert.ok(!listed.datasets.some((d) => d.includes(other)), `${other} listed: ${JSON.stringify(listed.datasets)}`);
    // The list's order and labels are the panel's business (a PACS's series may be grouped); its values are the names.
    // The panel fills its list once the server's statistics have labelled the series, after the state has the names:
    // wait for it (read at once, a busy machine found it still empty).
    await page.waitForFunction(
      (n) => document.querySelectorAll("#dataset option").length >= n,
      { timeout: 10000 },
      listed.datasets.length,
    );
    const options = await page.$$eval("#dataset option", (o) => o.map((x) => x.value));
    assert.deepEqual(options.sort(), [...listed.datasets].sort());
    // (2) While the server fetches the series, the banner says so; no dataset open, no frame yet.
    const busy = await waitBusy(page, uids.ct.series, " \\(7 instances\\)");
    assert.doesNotMatch(busy.text, /retry after/, "the retry hint is the page's business");
    assert.deepEqual([busy.dataset, busy.shown], ["", 0]);
    await H.screenshot(page, "pacs-busy");
    // (3) Then the series opens, and its exact frame is the one `voxbrick render` draws of the fetched store.
    const s = await waitExact(page, 0, 60000);
    assert.equal(s.dataset, ct());
    assert.equal(s.banner, "");
    assert.equal((await banners(page)).at(-1).text, "");
    const shown = await shownFrame("the CT");
    assert.deepEqual(
      H.compareImages(shown, reference(ct(), s.lastScene)),
      { differing: 0, maxDiff: 0 },
      `the CT's frame against voxbrick render: ${JSON.stringify(s.lastScene)}`,
    );
    await page.waitForFunction((d) => location.search.includes(`dataset=${d}`), {}, ct());
    await H.screenshot(page, "pacs");
    assert.deepEqual(page.errors, []);
  });

  test("another series chosen from the list: Busy while fetched, then its frame", async () => {
    assert.ok(page, "the page of the test before");
    const before = await H.viewerState(page);
    await recordBanner(page);
    await page.select("#dataset", enhanced());
    const busy = await waitBusy(page, uids.enhanced.series);
    assert.deepEqual([busy.dataset, busy.shown], ["", before.counts.shown], "nothing open, nothing shown meanwhile");
    const s = await H.waitForState(
      page,
      (st, [name, after]) =>
        st.dataset === name &&
        st.lastFrame &&
        !st.lastFrame.provisional &&
        st.lastFrame.id === st.newestId &&
        st.newestId > after,
      60000,
      [enhanced(), before.newestId],
    );
    assert.equal(s.banner, "");
    // The renderer drew the CT before: its frames may differ from a fresh one's by 1/255 (viewer.test.mjs), no more.
    const d = H.compareImages(await shownFrame("the Enhanced CT"), reference(enhanced(), s.lastScene));
    assert.ok(d.maxDiff <= 1 && d.differing < SIZE[0] * SIZE[1] * 0.02, `against voxbrick render ${JSON.stringify(d)}`);
    assert.equal((await banners(page)).at(-1).text, "");
    await page.waitForFunction((n) => location.search.includes(`dataset=${n}`), {}, enhanced());
    await H.screenshot(page, "pacs-enhanced");
    assert.deepEqual(page.errors, []);
    await page.close();
  });
});
