// A slow link between a client and the server, on this machine: a TCP relay that passes each direction's bytes
// through a bottleneck of RATE bit/s with DELAY ms one way (so a round trip of 2 x DELAY), and a queue of QUEUE bytes
// in front of it (a router's buffer; when full the relay stops reading, and TCP's own back-pressure takes over).
// Benchmarks put it between `voxbrick load` or a browser and `voxbrick serve` to measure frames over a WAN-like link
// without a network namespace (no `tc netem` here). Traffic stays on loopback.
//
//   node bench/link_relay.mjs --listen PORT --target PORT [--mbit 10] [--delay-ms 20] [--queue-ms 200]
//
// Prints "relay: listening on PORT" once ready; runs until killed. --listen 0 picks a free port.
import net from "node:net";

function option(name, fallback) {
  const at = process.argv.indexOf(`--${name}`);
  if (at < 0) return fallback;
  const value = Number(process.argv[at + 1]);
  if (!Number.isFinite(value) || value < 0) throw new Error(`--${name} needs a number, not '${process.argv[at + 1]}'`);
  return value;
}

const listenPort = option("listen", 0);
const targetPort = option("target", NaN);
if (!Number.isFinite(targetPort)) throw new Error("--target PORT is required");
const bytesPerMs = (option("mbit", 10) * 1e6) / 8 / 1000;
const delayMs = option("delay-ms", 20);
const queueBytes = Math.max(16384, option("queue-ms", 200) * bytesPerMs);

/// One direction of the link: bytes from `from` reach `to` after their turn on the bottleneck plus the delay, in the
/// order they came. One timer a direction delivers the chunks due, oldest first: a timer per chunk would not keep
/// them in order (Node's timers count whole milliseconds from the event loop's cached time, so a later chunk's timer
/// could fire first, and a stream of bytes came out reordered).
function pipe(from, to) {
  let linkFreeAt = 0; // when the bottleneck has sent everything given to it so far
  let queued = 0; // bytes waiting for or on the bottleneck
  const chunks = []; // { chunk, arriveAt }, oldest first
  const queuedSent = []; // { sentAt, length }: bytes still on the bottleneck
  let timer = null;
  let timerAt = Infinity; // when `timer` fires
  let ended = false;
  const due = () => {
    timer = null;
    timerAt = Infinity;
    const now = performance.now();
    while (chunks.length && chunks[0].arriveAt <= now) {
      const { chunk } = chunks.shift();
      if (!to.destroyed) to.write(chunk);
    }
    // Bytes leave the queue once the bottleneck has sent them (before the delay).
    while (queuedSent.length && queuedSent[0].sentAt <= now) queued -= queuedSent.shift().length;
    if (queued <= queueBytes / 2 && from.isPaused()) from.resume();
    if (chunks.length) schedule();
    else if (ended) to.end();
  };
  const schedule = () => {
    const next = Math.min(chunks.length ? chunks[0].arriveAt : Infinity,
      queuedSent.length ? queuedSent[0].sentAt : Infinity);
    if (timer && timerAt <= next) return;
    if (timer) clearTimeout(timer);
    timerAt = next;
    timer = setTimeout(due, Math.max(0, next - performance.now()));
  };
  from.on("data", (chunk) => {
    const now = performance.now();
    const sentAt = Math.max(now, linkFreeAt) + chunk.length / bytesPerMs;
    linkFreeAt = sentAt;
    queued += chunk.length;
    queuedSent.push({ sentAt, length: chunk.length });
    chunks.push({ chunk, arriveAt: sentAt + delayMs });
    if (queued > queueBytes) from.pause();
    schedule();
  });
  from.on("end", () => {
    ended = true;
    if (!chunks.length) to.end();
  });
  from.on("error", () => to.destroy());
}

const server = net.createServer((client) => {
  client.setNoDelay(true);
  const upstream = net.connect({ host: "127.0.0.1", port: targetPort }, () => upstream.setNoDelay(true));
  pipe(client, upstream);
  pipe(upstream, client);
  upstream.on("close", () => client.destroy());
  client.on("close", () => upstream.destroy());
});
server.listen(listenPort, "127.0.0.1", () => console.log(`relay: listening on ${server.address().port}`));
