// The voxbrick wire protocol (proto/PROTOCOL.md) in the browser: encoding requests and decoding replies, one
// message per WebSocket binary message. Little-endian throughout, strings UTF-8, the same checks as the C++ decoder:
// a field running past the body, bytes left over, an unknown enum value, bad UTF-8 or a count over its limit is
// refused with a ProtocolError naming the field.

export const MAGIC = 0x4b425856; // "VXBK" read as a little-endian u32
export const HEADER_BYTES = 16;
export const MIN_VERSION = 1;
export const MAX_VERSION = 9;

export const Type = Object.freeze({
  Hello: 1,
  Capabilities: 2,
  ListDatasets: 3,
  DatasetList: 4,
  OpenDataset: 5,
  DatasetInfo: 6,
  Render: 7,
  Frame: 8,
  Error: 9,
  GetStats: 10,
  Stats: 11,
  Goodbye: 12,
  FrameReceived: 13, // version 4 on, client to server: a Frame arrived (the server paces frames to the link)
});

export const Encoding = Object.freeze({ raw_rgba8: 0, png: 1, zstd_rgba8: 2, jpeg: 3, vp8: 4, vp9: 5, webp: 6 });
/// Encodings each version may carry (a version-1 session never sees jpeg, a version-3 one no video, a version-6 one
/// no webp). Versions 5 and 6 add messages the page never sends (Authenticate, Upload) and no encoding.
const ENCODINGS_BY_VERSION = {
  1: [0, 1, 2],
  2: [0, 1, 2, 3],
  3: [0, 1, 2, 3],
  4: [0, 1, 2, 3, 4, 5],
  5: [0, 1, 2, 3, 4, 5],
  6: [0, 1, 2, 3, 4, 5],
  7: [0, 1, 2, 3, 4, 5, 6],
  8: [0, 1, 2, 3, 4, 5, 6],
  9: [0, 1, 2, 3, 4, 5, 6],
};
/// The names the scene's `provisional_encoding` and the overlay give each encoding.
export const encodingName = (e) => ["raw", "png", "zstd", "jpeg", "vp8", "vp9", "webp"][e] || `encoding ${e}`;
export const isVideo = (e) => e === Encoding.vp8 || e === Encoding.vp9;

export const ErrorCode = Object.freeze({
  BadMagic: 1,
  UnsupportedVersion: 2,
  UnknownType: 3,
  TooLarge: 4,
  Malformed: 5,
  UnexpectedMessage: 6,
  UnknownDataset: 7,
  InvalidScene: 8,
  LimitExceeded: 9,
  Superseded: 10,
  Internal: 11,
  ShuttingDown: 12,
  Timeout: 13,
  Busy: 14, // version 3 on: the message ends with "; retry after N ms"
  Forbidden: 15, // version 5 on
  AlreadyExists: 16, // version 6 on
});
/// A Busy (or LimitExceeded) message without its "; retry after N ms" ending: what the server says is over capacity.
export const withoutRetryHint = (message) => (message || '').replace(/; retry after \d+ ms$/, '');
/// The retry hint of a Busy (or LimitExceeded) message, in ms: N of its "; retry after N ms" ending; null without.
export const retryAfterMs = (message) => {
  const m = /; retry after (\d{1,9}) ms$/.exec(message || "");
  return m ? Number(m[1]) : null;
};
export const errorName = (code) => Object.keys(ErrorCode).find((k) => ErrorCode[k] === code) || `code ${code}`;

export const Limits = Object.freeze({ maxString: 1 << 20, maxList: 4096, maxBody: 64 << 20 });

export class ProtocolError extends Error {}

const utf8Decoder = new TextDecoder("utf-8", { fatal: true });
const utf8Encoder = new TextEncoder();

/// Reads the fields of one body in order; every read checks the bytes left.
class Reader {
  constructor(bytes, what) {
    this.view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    this.bytes = bytes;
    this.at = 0;
    this.what = what;
  }
  need(n, field) {
    if (n > this.bytes.byteLength - this.at)
      throw new ProtocolError(`${this.what}.${field}: ${n} bytes needed, ${this.bytes.byteLength - this.at} left`);
  }
  u8(field) {
    this.need(1, field);
    return this.view.getUint8(this.at++);
  }
  u16(field) {
    this.need(2, field);
    const v = this.view.getUint16(this.at, true);
    this.at += 2;
    return v;
  }
  u32(field) {
    this.need(4, field);
    const v = this.view.getUint32(this.at, true);
    this.at += 4;
    return v;
  }
  bytesField(field, limit = Infinity) {
    const n = this.u32(field);
    if (n > limit) throw new ProtocolError(`${this.what}.${field}: length ${n} exceeds limit ${limit}`);
    this.need(n, field);
    const out = this.bytes.subarray(this.at, this.at + n);
    this.at += n;
    return out;
  }
  string(field) {
    const raw = this.bytesField(field, Limits.maxString);
    try {
      return utf8Decoder.decode(raw);
    } catch {
      throw new ProtocolError(`${this.what}.${field}: not valid UTF-8`);
    }
  }
  list(field, itemBytes, readItem) {
    const n = this.u32(field);
    if (n > Limits.maxList)
      throw new ProtocolError(`${this.what}.${field}: count ${n} exceeds limit ${Limits.maxList}`);
    // Each item takes at least itemBytes: a count the rest of the body cannot hold is refused before any item.
    if (n * itemBytes > this.bytes.byteLength - this.at)
      throw new ProtocolError(`${this.what}.${field}: count ${n} exceeds what the body holds`);
    const out = [];
    for (let i = 0; i < n; ++i) out.push(readItem(`${field}[${i}]`));
    return out;
  }
  end() {
    if (this.at !== this.bytes.byteLength)
      throw new ProtocolError(`${this.what}: ${this.bytes.byteLength - this.at} bytes after the last field`);
  }
}

/// Appends fields; `finish` gives the whole message, header included.
class Writer {
  constructor() {
    this.parts = [];
    this.length = 0;
  }
  push(bytes) {
    this.parts.push(bytes);
    this.length += bytes.byteLength;
  }
  u8(v) {
    this.push(Uint8Array.of(v));
  }
  u16(v) {
    const b = new Uint8Array(2);
    new DataView(b.buffer).setUint16(0, v, true);
    this.push(b);
  }
  u32(v) {
    const b = new Uint8Array(4);
    new DataView(b.buffer).setUint32(0, v >>> 0, true);
    this.push(b);
  }
  string(s) {
    const b = utf8Encoder.encode(s);
    if (b.byteLength > Limits.maxString) throw new ProtocolError(`string of ${b.byteLength} bytes exceeds the limit`);
    this.u32(b.byteLength);
    this.push(b);
  }
  finish(version, type, requestId) {
    const out = new Uint8Array(HEADER_BYTES + this.length);
    const v = new DataView(out.buffer);
    v.setUint32(0, MAGIC, true);
    v.setUint16(4, version, true);
    v.setUint16(6, type, true);
    v.setUint32(8, requestId >>> 0, true);
    v.setUint32(12, this.length, true);
    let at = HEADER_BYTES;
    for (const p of this.parts) {
      out.set(p, at);
      at += p.byteLength;
    }
    return out;
  }
}

/// Encoders of the client's messages: each returns the bytes of one whole message.
export const encode = {
  hello: (id, client) => {
    const w = new Writer();
    w.u16(MIN_VERSION);
    w.u16(MAX_VERSION);
    w.string(client);
    return w.finish(MIN_VERSION, Type.Hello, id);
  },
  listDatasets: (version, id) => new Writer().finish(version, Type.ListDatasets, id),
  openDataset: (version, id, name) => {
    const w = new Writer();
    w.string(name);
    return w.finish(version, Type.OpenDataset, id);
  },
  render: (version, id, encoding, sceneJson) => {
    const w = new Writer();
    w.u8(encoding);
    w.string(sceneJson);
    return w.finish(version, Type.Render, id);
  },
  getStats: (version, id) => new Writer().finish(version, Type.GetStats, id),
  /// Reports the Frame of request `id` that arrived, `frameBytes` long with its header (version 4 on).
  frameReceived: (version, id, frameBytes) => {
    const w = new Writer();
    w.u32(frameBytes);
    return w.finish(version, Type.FrameReceived, id);
  },
  goodbye: (version, id) => new Writer().finish(version, Type.Goodbye, id),
};

function readEncoding(r, field, version) {
  const e = r.u8(field);
  if (!(ENCODINGS_BY_VERSION[version] || ENCODINGS_BY_VERSION[MAX_VERSION]).includes(e))
    throw new ProtocolError(`${r.what}.${field}: unknown encoding ${e}`);
  return e;
}

const decoders = {
  [Type.Capabilities]: (r) => {
    const version = r.u16("version");
    return {
      version,
      server: r.string("server"),
      maxMessageBytes: r.u32("max_message_bytes"),
      maxImageSide: r.u32("max_image_side"),
      maxQueuedPerSession: r.u32("max_queued_per_session"),
      encodings: r.list("encodings", 1, (f) => readEncoding(r, f, version)),
    };
  },
  [Type.DatasetList]: (r) => ({ names: r.list("names", 4, (f) => r.string(f)) }),
  [Type.DatasetInfo]: (r) => ({ name: r.string("name"), metaJson: r.string("meta_json") }),
  [Type.Frame]: (r, version) => ({
    width: r.u32("width"),
    height: r.u32("height"),
    encoding: readEncoding(r, "encoding", version),
    statsJson: r.string("stats_json"),
    payload: r.bytesField("payload"),
  }),
  [Type.Error]: (r) => {
    const code = r.u16("code");
    if (!Object.values(ErrorCode).includes(code)) throw new ProtocolError(`Error.code: unknown error code ${code}`);
    return { code, name: errorName(code), message: r.string("message") };
  },
  [Type.Stats]: (r) => ({ json: r.string("json") }),
  [Type.Goodbye]: () => ({}),
};

const typeName = (t) => Object.keys(Type).find((k) => Type[k] === t) || `type ${t}`;

/// Decodes one whole message (header and body) received from the server. `version` is the session's version once
/// Capabilities came (0 before: then any version from 1 to MAX_VERSION is taken, as Capabilities and Error keep
/// version 1's layout). Returns {type, typeName, version, requestId, body}.
export function decodeMessage(buffer, version = 0) {
  const bytes = buffer instanceof Uint8Array ? buffer : new Uint8Array(buffer);
  if (bytes.byteLength < HEADER_BYTES) throw new ProtocolError(`header: ${bytes.byteLength} bytes, 16 needed`);
  const v = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (v.getUint32(0, true) !== MAGIC) throw new ProtocolError("header.magic: not VXBK");
  const headerVersion = v.getUint16(4, true);
  if (headerVersion < MIN_VERSION || headerVersion > MAX_VERSION || (version && headerVersion !== version))
    throw new ProtocolError(`header.version: ${headerVersion} is not spoken`);
  const type = v.getUint16(6, true);
  const requestId = v.getUint32(8, true);
  const bodyBytes = v.getUint32(12, true);
  if (bodyBytes > Limits.maxBody) throw new ProtocolError(`header.body_bytes: ${bodyBytes} exceeds the limit`);
  if (bodyBytes !== bytes.byteLength - HEADER_BYTES)
    throw new ProtocolError(`header.body_bytes: ${bodyBytes}, but the message holds ${bytes.byteLength - 16}`);
  const decoder = decoders[type];
  if (!decoder) throw new ProtocolError(`header.type: ${type} is not a message a server sends`);
  const r = new Reader(bytes.subarray(HEADER_BYTES), typeName(type));
  const body = decoder(r, headerVersion);
  r.end();
  return { type, typeName: typeName(type), version: headerVersion, requestId, body };
}
