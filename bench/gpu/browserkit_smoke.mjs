// The browser kit's Chromium driven by its node and puppeteer-core: a page from a local HTTP server (a secure
// context, as the viewer's), whose text is laid out in the kit's fonts and whose WebCodecs is asked for the codecs
// the viewer negotiates; then the shared libraries every process of the browser has mapped (it and its descendants,
// from /proc). Prints one line of JSON; check_browserkit.sh judges it.
//
//   cd KIT && CHROME=KIT/bin/chromium KIT/bin/node PATH/TO/browserkit_smoke.mjs
// (run from the kit's folder: puppeteer-core is resolved from its node_modules).
import fs from "node:fs";
import http from "node:http";
import { createRequire } from "node:module";
import path from "node:path";

const require = createRequire(path.join(process.cwd(), "package.json"));
const puppeteer = (await import(require.resolve("puppeteer-core"))).default;
const server = http.createServer((_, res) => {
  res.setHeader("Content-Type", "text/html");
  res.end('<span style="font: 20px sans-serif">voxbrick</span>');
});
await new Promise((resolve) => server.listen(0, "127.0.0.1", resolve));
const browser = await puppeteer.launch({
  executablePath: process.env.CHROME,
  headless: true,
  pipe: true,
  args: ["--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"],
});
try {
  const page = await browser.newPage();
  await page.goto(`http://127.0.0.1:${server.address().port}/`);
  const found = await page.evaluate(async () => {
    const codecs = {};
    for (const codec of ["vp8", "vp09.00.10.08"])
      codecs[codec] =
        typeof VideoDecoder === "undefined"
          ? false
          : (await VideoDecoder.isConfigSupported({ codec, codedWidth: 64, codedHeight: 64 })).supported;
    return { codecs, textWidth: document.querySelector("span").getBoundingClientRect().width };
  });
  const libraries = new Set();
  for (const pid of processTree(browser.process().pid))
    for (const line of readOr(`/proc/${pid}/maps`).split("\n")) {
      const file = line.split(/\s+/)[5];
      if (file && /\.so[.0-9]*$/.test(file)) libraries.add(file);
    }
  console.log(JSON.stringify({ version: await browser.version(), ...found, libraries: [...libraries].sort() }));
} finally {
  await browser.close();
  server.close();
}

function readOr(file) {
  try {
    return fs.readFileSync(file, "utf8");
  } catch {
    return "";
  }
}

/// `root` and every process descended from it.
function processTree(root) {
  const parent = new Map();
  for (const pid of fs.readdirSync("/proc").filter((n) => /^\d+$/.test(n))) {
    const stat = readOr(`/proc/${pid}/stat`);
    const ppid = Number(stat.slice(stat.lastIndexOf(")") + 2).split(" ")[1]);
    if (ppid) parent.set(Number(pid), ppid);
  }
  const tree = [root];
  for (let grown = true; grown; ) {
    grown = false;
    for (const [pid, ppid] of parent)
      if (tree.includes(ppid) && !tree.includes(pid)) tree.push(pid), (grown = true);
  }
  return tree;
}
