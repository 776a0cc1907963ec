// The page's protocol module (web/js/protocol.js) on its own, in Node: the bytes it writes (PROTOCOL.md's example
// Hello), and the decoder's refusals, each naming the field, as the C++ decoder's.

import assert from "node:assert/strict";
import { describe, test } from "node:test";
import {
  decodeMessage,
  encode,
  encodingName,
  Encoding,
  ErrorCode,
  ProtocolError,
  retryAfterMs,
  Type,
} from "../../web/js/protocol.js";

const hex = (bytes) => Buffer.from(bytes).toString("hex");

/// A message from the server: header (version, type, id) and the body's bytes.
function message(type, body, { version = 1, id = 7, bodyBytes = body.length } = {}) {
  const b = Buffer.alloc(16 + body.length);
  b.writeUInt32LE(0x4b425856, 0);
  b.writeUInt16LE(version, 4);
  b.writeUInt16LE(type, 6);
  b.writeUInt32LE(id, 8);
  b.writeUInt32LE(bodyBytes, 12);
  Buffer.from(body).copy(b, 16);
  return new Uint8Array(b);
}
const u32 = (v) => {
  const b = Buffer.alloc(4);
  b.writeUInt32LE(v);
  return [...b];
};
const str = (s) => [...u32(Buffer.byteLength(s)), ...Buffer.from(s)];

describe("protocol.js", () => {
  test("Hello is the bytes of PROTOCOL.md's example, with versions 1 to 9", () => {
    // The document's example says max_version 1; the page speaks up to 9 (the fourth body byte).
    assert.equal(
      hex(encode.hello(1, "example")),
      "5658424b" +
        "0100" +
        "0100" +
        "01000000" +
        "0f000000" +
        "0100" +
        "0900" +
        "07000000" +
        hex(Buffer.from("example")),
    );
  });

  test("Render and OpenDataset carry the session's version, the id and UTF-8", () => {
    const r = encode.render(2, 42, Encoding.png, '{"a":"é"}');
    assert.equal(hex(r.subarray(4, 8)), "0200" + "0700");
    assert.equal(new DataView(r.buffer).getUint32(8, true), 42);
    assert.equal(r[16], 1);
    assert.equal(new DataView(r.buffer).getUint32(17, true), 10); // é is two bytes
    assert.equal(hex(encode.openDataset(1, 3, "mri").subarray(16)), "03000000" + hex(Buffer.from("mri")));
  });

  test("Capabilities, DatasetList, Frame and Error decode", () => {
    const caps = decodeMessage(
      message(
        Type.Capabilities,
        [2, 0, ...str("voxbrick"), ...u32(1 << 20), ...u32(4096), ...u32(1), ...u32(4), 0, 1, 2, 3],
        {
          version: 2,
        },
      ),
    );
    assert.deepEqual(caps.body.encodings, [0, 1, 2, 3]);
    assert.equal(caps.body.version, 2);
    const list = decodeMessage(message(Type.DatasetList, [...u32(2), ...str("a"), ...str("bé")]), 1);
    assert.deepEqual(list.body.names, ["a", "bé"]);
    const frame = decodeMessage(message(Type.Frame, [...u32(2), ...u32(1), 1, ...str("{}"), ...u32(3), 9, 8, 7]), 1);
    assert.deepEqual([...frame.body.payload], [9, 8, 7]);
    assert.equal(frame.requestId, 7);
    const err = decodeMessage(message(Type.Error, [ErrorCode.Superseded, 0, ...str("replaced")]), 1);
    assert.equal(err.body.name, "Superseded");
    const busy = decodeMessage(
      message(Type.Error, [ErrorCode.Busy, 0, ...str("batch work waits; retry after 1500 ms")], { version: 3 }),
      3,
    );
    assert.equal(busy.body.name, "Busy");
    assert.equal(retryAfterMs(busy.body.message), 1500);
    assert.equal(retryAfterMs("no hint"), null);
  });

  test("version 4: video Frames decode, FrameReceived carries the Frame's id and bytes", () => {
    const frame = (encoding) => [...u32(2), ...u32(1), encoding, ...str("{}"), ...u32(1), 5];
    assert.equal(decodeMessage(message(Type.Frame, frame(4), { version: 4 }), 4).body.encoding, Encoding.vp8);
    assert.equal(decodeMessage(message(Type.Frame, frame(5), { version: 4 }), 4).body.encoding, Encoding.vp9);
    const limits = [...u32(1 << 20), ...u32(4096), ...u32(1)];
    const caps = decodeMessage(
      message(Type.Capabilities, [4, 0, ...str("v"), ...limits, ...u32(6), 0, 1, 2, 3, 4, 5], { version: 4 }),
    );
    assert.deepEqual(caps.body.encodings, [0, 1, 2, 3, 4, 5]);
    // Header (version 4, type 13, the Frame's request id, a 4-byte body), then frame_bytes.
    assert.equal(
      hex(encode.frameReceived(4, 0x01020304, 70000)),
      "5658424b" + "0400" + "0d00" + "04030201" + "04000000" + "70110100",
    );
  });

  test("version 7: a webp Frame decodes; in a version-6 session it is an unknown encoding", () => {
    const frame = [...u32(2), ...u32(1), 6, ...str("{}"), ...u32(1), 5];
    assert.equal(decodeMessage(message(Type.Frame, frame, { version: 7 }), 7).body.encoding, Encoding.webp);
    assert.throws(() => decodeMessage(message(Type.Frame, frame, { version: 6 }), 6), /unknown encoding 6/);
    const limits = [...u32(1 << 20), ...u32(4096), ...u32(1)];
    const caps = decodeMessage(
      message(Type.Capabilities, [7, 0, ...str("v"), ...limits, ...u32(7), 0, 1, 2, 3, 4, 5, 6], { version: 7 }),
    );
    assert.deepEqual(caps.body.encodings, [0, 1, 2, 3, 4, 5, 6]);
    assert.equal(encodingName(Encoding.webp), "webp");
  });

  test("the decoder refuses what the C++ decoder refuses, naming the field", () => {
    const refused = (bytes, pattern, version = 1) =>
      assert.throws(
        () => decodeMessage(bytes, version),
        (e) => {
          assert.ok(e instanceof ProtocolError);
          assert.match(e.message, pattern);
          return true;
        },
      );
    refused(message(Type.DatasetList, [...u32(1), ...u32(5), 0x61]), /DatasetList\.names\[0\]: 5 bytes needed/);
    refused(message(Type.DatasetList, [...u32(0), 0]), /1 bytes after the last field/);
    refused(message(Type.DatasetList, [...u32(5000)]), /names: count 5000 exceeds limit 4096/);
    refused(message(Type.DatasetList, [...u32(1000)]), /names: count 1000 exceeds what the body holds/);
    refused(message(Type.DatasetList, [...u32(1), ...u32(2), 0xc0, 0xaf]), /names\[0\]: not valid UTF-8/);
    refused(message(Type.DatasetList, [...u32(1), ...u32(3), 0xed, 0xa0, 0x80]), /not valid UTF-8/); // a surrogate
    refused(
      message(Type.Frame, [...u32(1), ...u32(1), 3, ...str(""), ...u32(0)]),
      /Frame\.encoding: unknown encoding 3/,
    );
    // A video encoding in a version-3 session, and an encoding no version has.
    refused(
      message(Type.Frame, [...u32(1), ...u32(1), 4, ...str(""), ...u32(0)], { version: 3 }),
      /Frame\.encoding: unknown encoding 4/,
      3,
    );
    refused(
      message(Type.Frame, [...u32(1), ...u32(1), 6, ...str(""), ...u32(0)], { version: 4 }),
      /Frame\.encoding: unknown encoding 6/,
      4,
    );
    refused(
      message(Type.Frame, [...u32(1), ...u32(1), 7, ...str(""), ...u32(0)], { version: 7 }),
      /Frame\.encoding: unknown encoding 7/,
      7,
    );
    refused(message(Type.Error, [99, 0, ...str("")]), /unknown error code 99/);
    refused(message(Type.DatasetList, [...u32(0)], { version: 3 }), /header\.version: 3/);
    refused(message(Type.DatasetList, [...u32(0)], { version: 2 }), /header\.version: 2/, 1);
    refused(message(Type.DatasetList, [...u32(0)], { bodyBytes: 9 }), /header\.body_bytes: 9/);
    refused(message(Type.Hello, [0, 0, 0, 0, ...u32(0)]), /header\.type: 1 is not a message a server sends/);
    const bad = message(Type.DatasetList, [...u32(0)]);
    bad[0] = 0;
    refused(bad, /header\.magic/);
  });
});
