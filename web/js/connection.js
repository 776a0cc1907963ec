// One WebSocket session with the server: Hello, requests matched to replies by id, and the reason the socket closed.
// The page makes a new Connection to reconnect; this class never retries by itself.

import { decodeMessage, encode, errorName, ProtocolError, Type } from "./protocol.js";

export class Connection {
  /// `url`: the ws:// or wss:// address of /ws (token included). Callbacks: onReady(capabilities),
  /// onReply(message) for replies no promise waits for (Frames and Errors of Renders, errors with id 0),
  /// onClose({reason, opened, refusedBy}) once.
  constructor(url, callbacks) {
    this.callbacks = callbacks;
    this.nextId = 1;
    this.waiting = new Map(); // request id -> {resolve, reject}
    this.version = 0;
    this.opened = false;
    this.closed = false;
    this.lastError = null; // the last Error with id 0, which tells why the server closed
    this.socket = new WebSocket(url);
    this.socket.binaryType = "arraybuffer";
    this.socket.onopen = () => {
      this.opened = true;
      this.socket.send(encode.hello(this.id(), "voxbrick viewer"));
    };
    this.socket.onmessage = (e) => this.receive(e.data);
    this.socket.onclose = (e) => this.finish(e.code, e.reason);
    this.socket.onerror = () => {}; // onclose follows with the code
  }

  id() {
    const id = this.nextId;
    this.nextId = this.nextId >= 0xfffffff0 ? 1 : this.nextId + 1;
    return id;
  }

  receive(data) {
    if (typeof data === "string") return this.fail("the server sent a text message");
    let m;
    try {
      m = decodeMessage(data, this.version);
    } catch (e) {
      return this.fail(e instanceof ProtocolError ? `cannot decode a reply: ${e.message}` : String(e));
    }
    // Version 4: every Frame is reported as it arrives, before the page decodes it, so that the server keeps at most
    // two Frames on their way and measures the link (its video stream's bitrate follows it).
    if (m.type === Type.Frame && this.version >= 4)
      this.send(encode.frameReceived(this.version, m.requestId, data.byteLength));
    if (m.type === Type.Capabilities) {
      this.version = m.body.version;
      this.waiting.delete(m.requestId);
      return this.callbacks.onReady(m.body);
    }
    if (m.type === Type.Error && m.requestId === 0) this.lastError = m.body;
    const w = this.waiting.get(m.requestId);
    if (w) {
      this.waiting.delete(m.requestId);
      return m.type === Type.Error ? w.reject(Object.assign(new Error(m.body.message), m.body)) : w.resolve(m);
    }
    this.callbacks.onReply(m);
  }

  /// Sends a request that expects one reply and returns a promise of it (rejected with the Error's code and
  /// message, or when the session ends).
  call(encoder, ...args) {
    return new Promise((resolve, reject) => {
      const id = this.id();
      this.waiting.set(id, { resolve, reject });
      this.send(encoder(this.version, id, ...args));
    });
  }
  listDatasets() {
    return this.call(encode.listDatasets).then((m) => m.body.names);
  }
  openDataset(name) {
    return this.call(encode.openDataset, name).then((m) => m.body);
  }
  getStats() {
    return this.call(encode.getStats).then((m) => JSON.parse(m.body.json));
  }
  /// Sends a Render; its replies come to onReply. Returns the request id.
  render(encoding, scene) {
    const id = this.id();
    this.send(encode.render(this.version, id, encoding, JSON.stringify(scene)));
    return id;
  }

  send(bytes) {
    if (this.socket.readyState === WebSocket.OPEN) this.socket.send(bytes);
  }

  /// Says Goodbye and closes.
  close() {
    if (this.socket.readyState === WebSocket.OPEN && this.version) this.send(encode.goodbye(this.version, 0));
    this.fail("closed by the page");
  }

  fail(reason) {
    this.failure = this.failure || reason;
    try {
      this.socket.close();
    } catch {
      /* already closing */
    }
    this.finish(1000, "");
  }

  finish(code, wsReason) {
    if (this.closed) return;
    this.closed = true;
    let reason = this.failure;
    if (!reason && this.lastError) reason = `${this.lastError.name}: ${this.lastError.message}`;
    if (!reason && wsReason) reason = wsReason;
    if (!reason) reason = this.opened ? `the connection closed (code ${code})` : "the server cannot be reached";
    for (const w of this.waiting.values()) w.reject(Object.assign(new Error(reason), { code: 0, name: "Closed" }));
    this.waiting.clear();
    this.callbacks.onClose({ reason, opened: this.opened, greeted: this.version > 0, code });
  }
}

export { errorName };
