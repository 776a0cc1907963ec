// The viewer over https:// and wss:// in Debian's Chromium, against the real `voxbrick serve --tls-cert --tls-key
// --http`, with a certificate made at test time by a test CA: Chromium trusts it only by its public key's hash
// (--ignore-certificate-errors-spki-list), refuses it without, and the page, loaded over https with a token, draws
// frames over wss and keeps the token out of its address.

import assert from "node:assert/strict";
import { after, before, describe, test } from "node:test";
import * as H from "./harness.mjs";

const TOKEN = "tls-Token_1";

describe("viewer over TLS", () => {
  let scratch, server, certs;

  before(async () => {
    scratch = H.scratchDir("tls");
    certs = H.testCertificates(scratch.dir);
    const datasets = H.prepDatasets(scratch.dir, { sparse: "synthetic:sparse,n=32" });
    const extra = ["--http-token", TOKEN, "--render-threads", "1"];
    server = await new H.Server({ dir: scratch.dir, datasets, extra, tls: certs }).start();
  });

  after(async () => {
    if (server) await server.kill();
    if (scratch) scratch.remove();
  });

  test("a browser that does not trust the certificate does not load the page", async () => {
    const browser = await H.launchBrowser();
    try {
      const page = await browser.newPage();
      await assert.rejects(page.goto(`${server.url}/?token=${TOKEN}`), /ERR_CERT_AUTHORITY_INVALID/);
    } finally {
      await browser.close();
    }
  });

  test("with the certificate trusted, the viewer draws over wss and keeps the token out of its address", async () => {
    const browser = await H.launchBrowser([`--ignore-certificate-errors-spki-list=${certs.spki}`]);
    try {
      const page = await H.openPage(browser, `${server.url}/?token=${TOKEN}&dataset=sparse&size=160x120`);
      const s = await H.waitForState(
        page,
        (st) => st.connection === "ready" && st.lastFrame && !st.lastFrame.provisional,
        30000,
      );
      assert.equal(s.counts.shown > 0, true);
      assert.equal(await page.evaluate(() => location.protocol), "https:");
      assert.doesNotMatch(await page.evaluate(() => location.href), /token|tls-Token/);
      assert.deepEqual(page.errors, []);
      await H.screenshot(page, "viewer-over-tls");
      // A page over https reaches the server only over wss (ws:// would be mixed content): the frame came over TLS.
      assert.doesNotMatch(server.log(), /tls-Token_1/, "no token in the server's log");
    } finally {
      await browser.close();
    }
  });
});
