// The viewer's scenes against the scene's schema, in Node (no browser, no packages): every key web/js/view.js
// claims to send (SCENE_KEYS) is a key of the schema `voxbrick scene --schema` prints; every scene buildScene makes,
// over views, datasets, phases and the server's features, carries only those keys, each with a value the schema
// allows, and the real parser (`voxbrick scene --scene FILE`) takes it; the page's named views and field of view are
// the scene's.

import assert from "node:assert/strict";
import { execFileSync, spawnSync } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { describe, test } from "node:test";
import {
  buildScene,
  defaultView,
  FOV_DEG,
  jpegQualityOf,
  MOTION_KEYS,
  NAMED_VIEWS,
  PRESETS,
  SCENE_KEYS,
} from "../../web/js/view.js";

const EXE = process.env.VOXBRICK_EXE;
if (!EXE) throw new Error("VOXBRICK_EXE must name the built voxbrick (ctest sets it)");

const schema = JSON.parse(execFileSync(EXE, ["scene", "--schema"], { encoding: "utf8" }));
const byKey = new Map(schema.keys.map((k) => [k.key, k]));

/// What is wrong with `v` as the value of schema entry `e`, or null: the schema's types, ranges and names.
function problem(e, v) {
  const inRange = (x) =>
    Number.isFinite(x) &&
    ((e.zero_too && x === 0) ||
      ((e.min === undefined || (e.min_open ? x > e.min : x >= e.min)) &&
        (e.max === undefined || x <= e.max) &&
        (!e.power_of_two || (Number.isInteger(x) && x >= 1 && (x & (x - 1)) === 0))));
  const isObject = (x) => x !== null && typeof x === "object" && !Array.isArray(x);
  let ok = false;
  switch (e.type) {
    case "object":
      ok = isObject(v);
      break;
    case "bool":
      ok = typeof v === "boolean";
      break;
    case "number":
      ok = typeof v === "number" && inRange(v);
      break;
    case "integer":
      ok = Number.isInteger(v) && inRange(v);
      break;
    case "name":
      ok = e.names.includes(v);
      break;
    case "text":
      ok = typeof v === "string";
      break;
    case "numbers":
      ok =
        (typeof v === "string" && (e.names || []).includes(v)) ||
        (Array.isArray(v) &&
          v.length >= e.count[0] &&
          v.length <= e.count[1] &&
          v.every(
            (x, i) =>
              typeof x === "number" &&
              inRange(x) &&
              (!e.integers || Number.isInteger(x)) &&
              (!e.increasing || i === 0 || x > v[i - 1]),
          ));
      break;
    case "transfer_function":
      ok = typeof v === "string" || (isObject(v) && Array.isArray(v.points));
      break;
    default:
      return `unknown type ${e.type}`;
  }
  return ok ? null : `${JSON.stringify(v)}: ${e.allowed}`;
}

/// The scene's keys, a group's members as "group.key" besides the group.
function keysOf(scene) {
  const out = [];
  for (const [k, v] of Object.entries(scene)) {
    out.push([k, v]);
    if (byKey.get(k)?.type === "object" && v && typeof v === "object")
      for (const [m, mv] of Object.entries(v)) out.push([`${k}.${m}`, mv]);
  }
  return out;
}

// What the page is shown: datasets of each kind, views a user makes, both phases and every mix of features.
const METAS = {
  grid: { kind: "grid", dims: [64, 48, 32], spacing: [1, 1, 2], value_range: [0, 255] },
  patient: {
    kind: "grid",
    dims: [40, 40, 20],
    spacing: [0.9, 0.9, 3],
    orientation: { axes: [[-1, 0, 0], [0, -1, 0], [0, 0, 1]], origin: [100, 120, -40], patient: true },
  },
  mesh: { kind: "tet-mesh", bounds: [[-1, -2, 0], [3, 2, 5]] },
};
const VIEWS = {
  default: {},
  named: { view: "left", az: 90, el: 0 },
  distance: { az: 45, el: -10, dist: 3 },
  panned: { pan: [0.2, -0.1], dist: 2 },
  preset: { tf: PRESETS[PRESETS.length - 1] },
  custom: { tf: "custom" },
  window: { window: [10, 200] },
  shading: { shading: true },
  quality: { quality: "psnr:40" },
};
const ALL = {
  interactive: true,
  time_budget_ms: true,
  provisional_encoding: true,
  progressive: true,
  keyframe: true,
  jpeg: true,
  video: "vp8",
  webp: "auto",
  accepts_webp: true,
  accepts_vp9_444: true,
};
const FEATURES = [
  ALL,
  { ...ALL, video: "vp9" },
  { ...ALL, video: "vp9", accepts_vp9_444: false },
  { ...ALL, webp: "always" },
  { ...ALL, accepts_webp: false },
  { ...ALL, video: null },
  { ...ALL, video: null, jpeg: false },
  { ...ALL, video: null, jpeg_quality: 35 },
  { ...ALL, jpeg_quality: 100 },
  ...MOTION_KEYS.map((k) => ({ ...ALL, [k]: false })),
  Object.fromEntries(Object.keys(ALL).map((k) => [k, false])),
];
// What a Render asks besides: nothing, or a key frame of the video stream (its decoder waits for one).
const ASKS = [{}, { keyframe: true }];
const SIZES = [
  [640, 480],
  [1, 1],
  [2048, 1024],
];

/// Every scene the page makes over those, with what made it.
function scenes() {
  const out = [];
  for (const [metaName, meta] of Object.entries(METAS))
    for (const [viewName, change] of Object.entries(VIEWS))
      for (const phase of ["still", "drag"])
        for (const features of FEATURES)
          for (const size of SIZES)
            for (const ask of ASKS) {
              const view = { ...defaultView("d"), ...change };
              const scene = buildScene(view, meta, size, phase, features, ask);
              out.push({ scene, how: { metaName, viewName, phase, features, size, ask } });
            }
  return out;
}

describe("the viewer's scenes and the scene's schema", () => {
  test("every key the viewer claims to send is a key of the schema", () => {
    for (const key of SCENE_KEYS) assert.ok(byKey.has(key), `view.js SCENE_KEYS has '${key}', which the schema lacks`);
    for (const key of MOTION_KEYS) assert.ok(SCENE_KEYS.includes(key), `MOTION_KEYS' '${key}' is not in SCENE_KEYS`);
  });

  test("every scene buildScene makes carries only those keys, each with a value the schema allows", () => {
    const sent = new Set();
    for (const { scene, how } of scenes()) {
      // A key frame is asked of a video stream only (the server ignores it otherwise).
      if (scene.keyframe)
        assert.ok(["vp8", "vp9"].includes(scene.provisional_encoding), `keyframe without video: ${JSON.stringify(how)}`);
      // 4:4:4 is asked of a vp9 stream only.
      if (scene.accepts_vp9_444)
        assert.equal(scene.provisional_encoding, "vp9", `accepts_vp9_444 without vp9: ${JSON.stringify(how)}`);
      for (const [key, value] of keysOf(scene)) {
        const entry = byKey.get(key);
        assert.ok(entry, `buildScene sent '${key}', which the schema lacks (${JSON.stringify(how)})`);
        if (entry.type === "object") continue;
        assert.ok(SCENE_KEYS.includes(key), `buildScene sent '${key}', which SCENE_KEYS does not list`);
        assert.equal(problem(entry, value), null, `'${key}' (${JSON.stringify(how)})`);
        sent.add(key);
      }
    }
    // The list says no more than the page sends.
    for (const key of SCENE_KEYS) assert.ok(sent.has(key), `SCENE_KEYS lists '${key}', which no scene carried`);
  });

  test("voxbrick reads every scene the page makes", () => {
    const dir = fs.mkdtempSync(path.join(os.tmpdir(), "voxbrick-scene-keys-"));
    try {
      const distinct = new Map();
      for (const { scene, how } of scenes())
        if (how.metaName !== "mesh" && how.size[0] === 640) distinct.set(JSON.stringify(scene), how);
      assert.ok(distinct.size > 20, `only ${distinct.size} distinct scenes`);
      let i = 0;
      for (const [text, how] of distinct) {
        const file = path.join(dir, `scene${i++}.json`);
        fs.writeFileSync(file, text);
        const r = spawnSync(EXE, ["scene", "--scene", file], { encoding: "utf8" });
        assert.equal(r.status, 0, `${text} (${JSON.stringify(how)}): ${r.stderr}`);
        const read = JSON.parse(r.stdout);
        const sent = JSON.parse(text);
        // What the page asked for is what the scene holds.
        assert.deepEqual(read.size, sent.size);
        assert.equal(read.shading, sent.shading);
        if (sent.window) assert.deepEqual(read.window, sent.window);
        if (sent.quality) assert.equal(read.quality, sent.quality);
        if (sent.camera.orbit) assert.deepEqual(read.camera.orbit, sent.camera.orbit);
        if (sent.camera.eye) assert.deepEqual(read.camera.eye, sent.camera.eye);
        if (sent.time_budget_ms) assert.equal(read.time_budget_ms, sent.time_budget_ms);
        if (sent.provisional_encoding) assert.equal(read.provisional_encoding, sent.provisional_encoding);
        if (sent.keyframe) assert.equal(read.keyframe, true);
        if (sent.jpeg_quality) assert.equal(read.jpeg_quality, sent.jpeg_quality);
      }
    } finally {
      fs.rmSync(dir, { recursive: true, force: true });
    }
  });

  test("the address's jpeg_quality is asked of moving frames only, as a whole number from 1 to 100", () => {
    for (const [text, q] of [["50", 50], ["1", 1], ["100", 100], ["0", 0], ["101", 0], ["7.5", 0], ["-3", 0], ["x", 0],
      ["", 0], [null, 0]])
      assert.equal(jpegQualityOf(text), q, `jpeg_quality=${text}`);
    const view = defaultView("d");
    const features = { ...ALL, video: null, jpeg_quality: 35 };
    assert.equal(buildScene(view, METAS.grid, [64, 64], "drag", features).jpeg_quality, 35);
    assert.equal(buildScene(view, METAS.grid, [64, 64], "still", features).jpeg_quality, undefined,
      "the exact frame is lossless: no JPEG quality");
    assert.equal(buildScene(view, METAS.grid, [64, 64], "drag", { ...features, jpeg_quality: 0 }).jpeg_quality,
      undefined);
  });

  test("the page's named views and field of view are the scene's", () => {
    const view = byKey.get("camera.view");
    assert.deepEqual(Object.keys(NAMED_VIEWS).sort(), [...view.names].sort());
    for (const [name, orbit] of Object.entries(NAMED_VIEWS)) {
      const read = JSON.parse(execFileSync(EXE, ["scene", "--view", name], { encoding: "utf8" }));
      assert.deepEqual(read.camera.orbit, orbit, name);
      assert.equal(read.camera.up_axis, "+z", name);
    }
    assert.equal(FOV_DEG, byKey.get("camera.fov").default);
  });
});
