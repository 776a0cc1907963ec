// How long a browser's WebCodecs VideoDecoder takes from a chunk put in to its frame coming out, for streams that
// bench_video wrote (--streams): Debian's Chromium, headless, launched as the viewer's tests launch it
// (tests/browser/harness.mjs). Each stream is fed as the viewer feeds a drag's frames (video.js: optimizeForLatency,
// BT.601 limited range), a chunk every INTERVAL ms; a decoder that holds a frame back until the next chunk arrives
// shows it as a latency near the interval, and as frames still out when the next chunk goes in ("held"). Prints one
// line of JSON a stream and interval. A FILE.jpg or FILE.png (a still frame) is decoded by createImageBitmap with
// its default options (the viewer's frames.js), with either or both of premultiplyAlpha and colorSpaceConversion
// "none", and by WebCodecs' ImageDecoder, each drawn to a canvas, 20 times: one line with the medians.
//
//   node bench/browser_decode.mjs [--intervals 33,250] FILE.chunks|FILE.jpg|FILE.png...
// (VOXBRICK_CHROMIUM overrides /usr/bin/chromium; the browser tests' packages must be installed: cd tests/browser &&
// npm ci).
import fs from "node:fs";
import http from "node:http";
import path from "node:path";
import * as H from "../tests/browser/harness.mjs";

const args = process.argv.slice(2);
let intervals = [33, 250];
const files = [];
for (let i = 0; i < args.length; ++i) {
  if (args[i] === "--intervals") intervals = args[++i].split(",").map(Number);
  else files.push(args[i]);
}
if (!files.length) {
  console.error("usage: node browser_decode.mjs [--intervals 33,250] FILE.chunks|FILE.jpg|FILE.png...");
  process.exit(2);
}

const server = http.createServer((req, res) => {
  const name = decodeURIComponent(req.url.slice(1));
  if (name === "") {
    res.setHeader("Content-Type", "text/html");
    return res.end("<!doctype html><title>decode</title>");
  }
  const file = files.find((f) => path.basename(f) === name);
  if (!file) {
    res.statusCode = 404;
    return res.end();
  }
  res.setHeader("Content-Type", "application/octet-stream");
  res.end(fs.readFileSync(file));
});
await new Promise((resolve) => server.listen(0, "127.0.0.1", resolve));
const browser = await H.launchBrowser();
try {
  const page = await browser.newPage();
  await page.goto(`http://127.0.0.1:${server.address().port}/`);
  for (const file of files.filter((f) => /\.(jpg|png|webp)$/.test(f))) {
    const name = path.basename(file);
    const result = await page.evaluate(async (name, repeats) => {
      const data = new Uint8Array(await (await fetch(`/${name}`)).arrayBuffer());
      const type = name.endsWith(".png") ? "image/png" : name.endsWith(".webp") ? "image/webp" : "image/jpeg";
      let ctx = null;
      // Each way: ms to the decoded image, and ms to draw it (the draw forced by reading a pixel back).
      const ways = {
        bitmap_no_premultiply_no_conversion: () =>
          createImageBitmap(new Blob([data], { type }), { premultiplyAlpha: "none", colorSpaceConversion: "none" }),
        bitmap_default: () => createImageBitmap(new Blob([data], { type })),
        bitmap_no_premultiply: () => createImageBitmap(new Blob([data], { type }), { premultiplyAlpha: "none" }),
        bitmap_no_conversion: () => createImageBitmap(new Blob([data], { type }), { colorSpaceConversion: "none" }),
      };
      if (typeof ImageDecoder !== "undefined")
        ways.image_decoder = async () => {
          const decoder = new ImageDecoder({ data, type });
          const { image } = await decoder.decode();
          decoder.close();
          return image;
        };
      const out = {};
      for (const [way, decode] of Object.entries(ways)) {
        const decodeMs = [], drawMs = [];
        for (let i = 0; i < repeats; ++i) {
          let start = performance.now();
          const image = await decode();
          decodeMs.push(performance.now() - start);
          const width = image.displayWidth || image.width, height = image.displayHeight || image.height;
          if (!ctx) ctx = new OffscreenCanvas(width, height).getContext("2d");
          start = performance.now();
          ctx.drawImage(image, 0, 0);
          ctx.getImageData(0, 0, 1, 1);
          drawMs.push(performance.now() - start);
          image.close();
        }
        const median = (a) => a.sort((x, y) => x - y)[Math.floor(a.length / 2)];
        out[way] = { decode_ms: Math.round(median(decodeMs) * 10) / 10, draw_ms: Math.round(median(drawMs) * 10) / 10 };
      }
      return { bytes: data.length, ...out };
    }, name, 20);
    console.log(JSON.stringify({ image: name, ...result }));
  }
  for (const file of files.filter((f) => f.endsWith(".chunks")))
    for (const interval of intervals) {
      const name = path.basename(file);
      const named = /^(vp8|vp9)-(\d+)x(\d+)-/.exec(name);
      if (!named) throw new Error(`${name}: not a stream of bench_video --streams (CODEC-WxH-...chunks)`);
      const [, codecName, width, height] = named;
      const result = await page.evaluate(
        async (name, codec, width, height, interval) => {
          const data = new Uint8Array(await (await fetch(`/${name}`)).arrayBuffer());
          const chunks = [];
          for (let at = 0; at + 5 <= data.length; ) {
            const n = data[at] | (data[at + 1] << 8) | (data[at + 2] << 16) | (data[at + 3] << 24);
            chunks.push({ key: data[at + 4] === 1, bytes: data.slice(at + 5, at + 5 + n) });
            at += 5 + n;
          }
          const fedAt = new Map();
          const latencies = [];
          let errors = 0;
          let held = 0;
          const decoder = new VideoDecoder({
            output: (frame) => {
              latencies.push(performance.now() - fedAt.get(frame.timestamp));
              fedAt.delete(frame.timestamp);
              frame.close();
            },
            error: () => ++errors,
          });
          decoder.configure({
            codec,
            codedWidth: width,
            codedHeight: height,
            colorSpace: { primaries: "smpte170m", transfer: "smpte170m", matrix: "smpte170m", fullRange: false },
            optimizeForLatency: true,
          });
          const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
          for (let i = 0; i < chunks.length; ++i) {
            if (fedAt.size > 0) ++held;
            const timestamp = i * 33333;
            fedAt.set(timestamp, performance.now());
            decoder.decode(new EncodedVideoChunk({ type: chunks[i].key ? "key" : "delta", timestamp, data: chunks[i].bytes }));
            await sleep(interval);
          }
          await decoder.flush();
          decoder.close();
          latencies.sort((a, b) => a - b);
          const q = (p) => latencies[Math.min(latencies.length - 1, Math.floor(p * latencies.length))];
          return { frames: chunks.length, decoded: latencies.length, held, errors, p50: q(0.5), p99: q(0.99), max: q(1) };
        },
        name,
        codecName === "vp8" ? "vp8" : name.endsWith("-444.chunks") ? "vp09.01.41.08.03" : "vp09.00.41.08",
        Number(width),
        Number(height),
        interval,
      );
      const round = (x) => Math.round(x * 10) / 10;
      console.log(
        JSON.stringify({
          stream: name,
          interval_ms: interval,
          ...result,
          p50: round(result.p50),
          p99: round(result.p99),
          max: round(result.max),
        }),
      );
    }
} finally {
  await browser.close();
  server.close();
}
