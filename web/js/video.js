// A session's video stream (PROTOCOL.md section 5, rule 11): the server sends a moving camera's provisional frames
// as one VP8 or VP9 stream, whose inter frames decode only after every frame before them. So every video Frame goes
// to one WebCodecs VideoDecoder in the order it arrived, also those the page will not show (a newer Render's frame
// exists), and only those the frame loop would show are drawn. A decoder that fails, or a stream that lost a frame,
// waits for the next key frame and asks the server for one.

import { Encoding } from "./protocol.js";

/// The video encodings the page can ask for, in the order it prefers them, with their WebCodecs codec strings
/// (VP9 profile 0, level 4.1, 8 bits: what the server's encoder makes).
export const VIDEO_CODECS = [
  { encoding: Encoding.vp8, name: "vp8", codec: "vp8" },
  { encoding: Encoding.vp9, name: "vp9", codec: "vp09.00.41.08" },
];
const codecOf = (encoding) => VIDEO_CODECS.find((c) => c.encoding === encoding);
/// VP9 in 4:4:4 (profile 1, level 4.1, 8 bits, colour at every pixel): what a vp9 stream is when the page's scenes
/// say `accepts_vp9_444` (protocol version 9) and its frames' statistics say `video.chroma` "4:4:4".
export const VP9_FULL_CHROMA = { encoding: Encoding.vp9, name: "vp9 4:4:4", codec: "vp09.01.41.08.03" };

/// Whether this browser decodes VP9 in 4:4:4 (Chromium's software VP9 does; a hardware decoder may not).
export async function decodesVp9FullChroma() {
  if (typeof VideoDecoder === "undefined") return false;
  try {
    return (await VideoDecoder.isConfigSupported({ codec: VP9_FULL_CHROMA.codec })).supported === true;
  } catch {
    return false; // a codec string the browser does not know
  }
}

// Timestamps only order the chunks and match outputs to them: one frame's worth (30 a second) apart, in µs.
const TIMESTAMP_STEP_US = 33333;
const KEEP = 200; // video frames kept in the log the tests read

/// The name ("vp8" or "vp9") of the first video encoding of `offered` (Capabilities' encodings) this browser decodes,
/// or null: no WebCodecs (an insecure context, an old browser) or no codec in common. `wanted` (the address's `video`
/// parameter) narrows the choice: "off" asks for none (moving frames as jpeg), "vp8" or "vp9" for that codec alone;
/// anything else, or nothing, leaves the page's own order.
export async function pickVideoCodec(offered, wanted = null) {
  if (wanted === "off" || typeof VideoDecoder === "undefined") return null;
  const named = VIDEO_CODECS.some((c) => c.name === wanted);
  for (const c of VIDEO_CODECS) {
    if (!offered.includes(c.encoding) || (named && c.name !== wanted)) continue;
    try {
      if ((await VideoDecoder.isConfigSupported({ codec: c.codec })).supported) return c.name;
    } catch {
      /* a codec string the browser does not know: not supported */
    }
  }
  return null;
}

export class VideoStream {
  /// `hooks`: output(videoFrame, meta, decodeMs) for each decoded frame (the hook closes it); failed(error) when the
  /// decoder fails.
  constructor(hooks) {
    this.hooks = hooks;
    this.decoder = null;
    this.configured = null; // {codec, width, height} the decoder was configured for
    this.reset();
    this.resetFigures();
  }

  /// A new stream (a new connection or dataset): the decoder is closed and the next frame must be a key frame, which
  /// the server sends then of itself.
  reset() {
    this.closeDecoder();
    this.needKey = true; // delta frames are skipped until a key frame
    this.askKey = false; // the next Renders ask the server for a key frame
    this.pending = new Map(); // timestamp -> {meta, at}
  }

  resetFigures() {
    // Every video Frame that arrived: {id, streamFrame, key, keyReason, chroma, width, height, bytes, decoded}.
    this.log = [];
    this.counts = { frames: 0, decoded: 0, keyFrames: 0, skipped: 0, errors: 0 };
    this.lastDecodeMs = null;
    this.bitrateKbps = null;
    this.scale = null; // the stream's size as a fraction of the scene's, and why it is smaller ("link", "encoders", "drawing", "memory")
    this.scaledFor = null;
    this.codec = null;
  }

  closeDecoder() {
    if (this.decoder && this.decoder.state !== "closed") this.decoder.close();
    this.decoder = null;
    this.configured = null;
    this.timestamp = 0;
  }

  /// Feeds Frame body `f` of request `id` (its statistics `stats`) to the decoder; `meta` comes back with its output.
  /// Returns whether it was decoded: false for a delta frame without its key frame, which is skipped.
  decode(id, f, stats, meta) {
    const video = stats.video || {};
    const key = video.key === true;
    const codec = f.encoding === Encoding.vp9 && video.chroma === "4:4:4" ? VP9_FULL_CHROMA : codecOf(f.encoding);
    this.counts.frames++;
    if (video.bitrate_kbps) this.bitrateKbps = video.bitrate_kbps;
    if (typeof video.scale === "number") {
      this.scale = video.scale;
      this.scaledFor = typeof video.scaled_for === "string" ? video.scaled_for : null;
    }
    const entry = {
      id,
      streamFrame: video.stream_frame ?? null,
      key,
      keyReason: video.key_reason || null,
      chroma: video.chroma || null,
      width: f.width,
      height: f.height,
      bytes: f.payload.byteLength,
      decoded: false,
    };
    this.log.push(entry);
    if (this.log.length > KEEP) this.log.shift();
    if (!key && (this.needKey || !this.decoder)) {
      // The decoder has not the frames this one is drawn from: wait for a key frame, and ask for one.
      this.counts.skipped++;
      this.askKey = true;
      return false;
    }
    try {
      if (key) this.configure(codec, f.width, f.height);
      const timestamp = this.timestamp;
      this.timestamp += TIMESTAMP_STEP_US;
      this.pending.set(timestamp, { meta, at: performance.now() });
      this.decoder.decode(new EncodedVideoChunk({ type: key ? "key" : "delta", timestamp, data: f.payload }));
    } catch (e) {
      this.fail(e);
      return false;
    }
    if (key) {
      this.needKey = this.askKey = false;
      this.counts.keyFrames++;
    }
    this.codec = codec.name;
    entry.decoded = true;
    return true;
  }

  /// A key frame of another codec (VP9's 4:4:4 counted as one) or size than the decoder's (the first one, one after a
  /// resize) configures it anew; decodes already queued finish first, in the configuration they were given.
  configure(codec, width, height) {
    const c = this.configured;
    if (this.decoder && c && c.codec === codec.codec && c.width === width && c.height === height) return;
    if (!this.decoder)
      this.decoder = new VideoDecoder({ output: (frame) => this.output(frame), error: (e) => this.fail(e) });
    // The server's frames are BT.601, limited range (PROTOCOL.md, Frame): said here so the browser need not guess.
    this.decoder.configure({
      codec: codec.codec,
      codedWidth: width,
      codedHeight: height,
      colorSpace: { primaries: "smpte170m", transfer: "smpte170m", matrix: "smpte170m", fullRange: false },
      optimizeForLatency: true,
    });
    this.configured = { codec: codec.codec, width, height };
  }

  output(frame) {
    const p = this.pending.get(frame.timestamp);
    // Chunks before this one that gave no output (the decoder dropped them) are forgotten with it.
    for (const t of this.pending.keys()) if (t <= frame.timestamp) this.pending.delete(t);
    if (!p) return frame.close();
    this.counts.decoded++;
    this.lastDecodeMs = performance.now() - p.at;
    this.hooks.output(frame, p.meta, this.lastDecodeMs);
  }

  /// The decoder failed: close it, skip delta frames until the next key frame, and ask the server for one.
  fail(e) {
    this.counts.errors++;
    this.closeDecoder();
    this.pending.clear();
    this.needKey = this.askKey = true;
    this.hooks.failed(e);
  }

  figures() {
    return {
      codec: this.codec,
      ...this.counts,
      lastDecodeMs: this.lastDecodeMs,
      bitrateKbps: this.bitrateKbps,
      scale: this.scale,
      scaledFor: this.scaledFor,
      needKey: this.needKey,
      askKey: this.askKey,
    };
  }
}
