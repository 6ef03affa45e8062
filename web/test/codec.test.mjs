// The JS codec against the golden vectors shared with the Rust codec
// (proto/tests/golden/*.hex and frames.json) and the rejection cases of
// proto/tests/reject.rs.

import { test } from "node:test";
import assert from "node:assert/strict";
import { readFileSync, readdirSync } from "node:fs";
import { fileURLToPath } from "node:url";
import { dirname, join } from "node:path";

import {
  ErrorCode,
  FrameError,
  HEADER_BYTES,
  MAGIC,
  MAX_DELTA_IDS,
  MAX_FRAME_BYTES,
  NO_VALUE,
  PROTOCOL_VERSION,
  culledByFrustum,
  culledByOcclusion,
  decodeFrame,
  deriveStats,
  encodeFrame,
  encodePose,
  validateFrame,
} from "../src/codec.js";
import { VisibleSet, applyDelta } from "../src/visible.js";

const golden = join(dirname(fileURLToPath(import.meta.url)), "..", "..", "proto", "tests", "golden");
const manifest = JSON.parse(readFileSync(join(golden, "frames.json"), "utf8"));

function readHex(file) {
  const text = readFileSync(join(golden, file), "utf8");
  const lines = text.trim().split("\n");
  for (const line of lines) assert.match(line, /^[0-9a-f]{8}$/, `${file}: line ${JSON.stringify(line)}`);
  return Uint8Array.from(lines.join("").match(/../g), (h) => parseInt(h, 16));
}

/** The fields of a frames.json entry that a decoded frame must have. */
function expectedFrame(entry) {
  const common = { kind: entry.kind, seq: entry.seq, ack: entry.ack };
  switch (entry.kind) {
    case "hello":
      return { ...common, object_count: entry.object_count, info_json: entry.info_json };
    case "pose":
      return {
        ...common,
        want_full: entry.want_full,
        position: entry.position,
        rotation: entry.rotation,
        fov_y_deg: entry.fov_y_deg,
        viewport: entry.viewport,
        near: entry.near,
        far: entry.far,
        ...(entry.stereo ? { stereo: entry.stereo } : {}),
      };
    case "full":
      return { ...common, stats: entry.stats, ids: entry.ids };
    case "delta":
      return { ...common, stats: entry.stats, added: entry.added, removed: entry.removed };
    case "full_lod":
      return { ...common, stats: entry.stats, ids: entry.ids, levels: entry.levels };
    case "delta_lod":
      return {
        ...common,
        stats: entry.stats,
        added: entry.added,
        removed: entry.removed,
        changed: entry.changed,
        added_levels: entry.added_levels,
        changed_levels: entry.changed_levels,
      };
    case "error":
      return { ...common, code: entry.code, code_name: entry.code_name, message: entry.message };
    case "transforms":
      return { ...common, horizon_ms: entry.horizon_ms, objects: entry.objects };
    case "applied":
      return { ...common, version: entry.version, applied: entry.applied };
    case "region":
      return { ...common, centre: entry.centre, radius_m: entry.radius_m, axis: entry.axis, turn_deg: entry.turn_deg };
  }
  throw new Error(`unknown kind ${entry.kind}`);
}

test("every golden file is listed in frames.json", () => {
  const files = readdirSync(golden).filter((f) => f.endsWith(".hex")).sort();
  assert.deepEqual(manifest.frames.map((f) => f.file).sort(), files);
  assert.ok(files.length >= 7);
});

for (const entry of manifest.frames) {
  test(`golden ${entry.file}: decodes to the listed fields`, () => {
    const bytes = readHex(entry.file);
    assert.equal(bytes.length, entry.byte_length);
    assert.equal(bytes.length / 4 - 4, entry.payload_words);
    const view = new DataView(bytes.buffer);
    assert.equal(view.getUint32(4, true), (manifest.protocol_version | (entry.kind_code << 16)) >>> 0);
    const frame = decodeFrame(bytes);
    const want = expectedFrame(entry);
    assert.deepEqual(frame, want);
    // Also from an ArrayBuffer and from a view into a larger buffer.
    assert.deepEqual(decodeFrame(bytes.slice().buffer), want);
    const padded = new Uint8Array(bytes.length + 8);
    padded.set(bytes, 4);
    assert.deepEqual(decodeFrame(padded.subarray(4, 4 + bytes.length)), want);
    for (const key of ["info_json", "message"]) {
      if (entry[`${key}_byte_length`] !== undefined) {
        assert.equal(new TextEncoder().encode(frame[key]).length, entry[`${key}_byte_length`]);
      }
    }
  });

  test(`golden ${entry.file}: encoding the fields gives the same bytes`, () => {
    const bytes = readHex(entry.file);
    const frame = decodeFrame(bytes);
    assert.deepEqual(encodeFrame(frame), bytes);
    validateFrame(frame);
    if (entry.kind === "pose") {
      const pose = {
        position: entry.position,
        rotation: entry.rotation,
        fov_y_deg: entry.fov_y_deg,
        viewport: entry.viewport,
        near: entry.near,
        far: entry.far,
        ...(entry.stereo ? { stereo: entry.stereo } : {}),
      };
      assert.deepEqual(encodePose(entry.seq, pose, entry.want_full), bytes);
    }
  });

  if (entry.derived !== undefined) {
    test(`golden ${entry.file}: derived stats`, () => {
      const frame = decodeFrame(readHex(entry.file));
      const visible = entry.ids !== undefined ? entry.ids.length : entry.visible_after.length;
      const { objects, culled_by_frustum, culled_by_occlusion } = entry.derived;
      assert.equal(culledByFrustum(frame.stats, objects), culled_by_frustum);
      assert.equal(culledByOcclusion(frame.stats, visible), culled_by_occlusion);
      assert.deepEqual(deriveStats(frame.stats, objects, visible), { ...entry.stats, ...entry.derived });
    });
  }

  if (entry.base !== undefined) {
    test(`golden ${entry.file}: applied to ${entry.base} gives visible_after`, () => {
      const base = decodeFrame(readHex(entry.base));
      const delta = decodeFrame(readHex(entry.file));
      assert.deepEqual(applyDelta(base.ids, delta.added, delta.removed), entry.visible_after);
      if (entry.levels_after !== undefined) {
        const set = new VisibleSet();
        set.replace(base.ids, base.levels);
        const change = set.apply(delta.added, delta.removed, delta);
        assert.deepEqual(set.ids, entry.visible_after);
        assert.deepEqual(set.ids.map((id) => set.level(id)), entry.levels_after);
        assert.deepEqual(change.changed, entry.changed);
      }
    });
  }
}

// --- rejection: the cases of proto/tests/reject.rs, with the same expected errors ---------

function bytes(words) {
  const out = new Uint8Array(words.length * 4);
  const v = new DataView(out.buffer);
  words.forEach((w, i) => v.setUint32(i * 4, w >>> 0, true));
  return out;
}

/** Header word 1: the version in the low 16 bits, the kind in the high 16 bits. */
const versionKind = (version, kind) => (version | (kind << 16)) >>> 0;

function frame(kind, seq, ack, payload) {
  return bytes([MAGIC, versionKind(PROTOCOL_VERSION, kind), seq, ack, ...payload]);
}

const stats = () => [9, 3, 0, 100, 200, 7];
const full = (ids) => frame(3, 1, 1, [...stats(), ids.length, ...ids]);
const delta = (added, removed) => frame(4, 1, 1, [...stats(), added.length | (removed.length << 16), ...added, ...removed]);
const fullLod = (ids, levelWords) => frame(6, 1, 1, [...stats(), ids.length, ...ids, ...levelWords]);
const deltaLod = (added, removed, changed, levelWords) =>
  frame(7, 1, 1, [...stats(), added.length | (removed.length << 16), changed.length, ...added, ...removed, ...changed, ...levelWords]);
const levelWord = (b) => (b[0] | (b[1] << 8) | (b[2] << 16) | (b[3] << 24)) >>> 0;

function textPayload(first, text, pad) {
  const b = [...(typeof text === "string" ? new TextEncoder().encode(text) : text)];
  const n = b.length;
  while (b.length % 4) b.push(pad);
  const words = [];
  for (let i = 0; i < b.length; i += 4) words.push((b[i] | (b[i + 1] << 8) | (b[i + 2] << 16) | (b[i + 3] << 24)) >>> 0);
  return [first, n, ...words];
}

const f32bits = (x) => {
  const v = new DataView(new ArrayBuffer(4));
  v.setFloat32(0, x, true);
  return v.getUint32(0, true);
};

function pose(flags) {
  return frame(2, 7, 0, [flags, ...[0, 1, 2, 0, 0, 0, 1, 60].map(f32bits), 960, 540, ...[0.1, 100].map(f32bits)]);
}

const U32_MAX = 0xffffffff;

/** A Transforms payload (horizon absent) moving objects `ids` to the identity, still. */
function movedObjects(ids) {
  const p = [NO_VALUE, ids.length];
  for (const id of ids) p.push(id, ...[1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0].map(f32bits), 0, 0, 0, 0, 0, 0, NO_VALUE);
  return p;
}

function cases() {
  const long = new Uint8Array(MAX_FRAME_BYTES + 4);
  long.set(bytes([MAGIC]));
  const unaligned = new Uint8Array([...full([1, 2]), 0]);
  const poseWithAck = pose(0);
  poseWithAck.set(bytes([3]), 12);
  return [
    ["empty", new Uint8Array(0), "TooShort", { len: 0 }],
    ["header minus a word", frame(3, 0, 0, []).slice(0, 12), "TooShort", { len: 12 }],
    ["over the limit, checked first", long, "TooLong", { len: MAX_FRAME_BYTES + 4 }],
    ["over the limit by a byte", new Uint8Array(MAX_FRAME_BYTES + 1).fill(0xff), "TooLong", { len: MAX_FRAME_BYTES + 1 }],
    ["a stray byte", unaligned, "NotWordAligned", { len: 53 }],
    ["big-endian magic", bytes([0x484d434c, versionKind(2, 3), 0, 0]), "BadMagic", { found: 0x484d434c }],
    ["zero magic", new Uint8Array(16), "BadMagic", { found: 0 }],
    [
      "a version 1 full frame (version word 1, kind in word 2, payload length in word 5)",
      bytes([MAGIC, 1, 3, 2, 42, 9, 1234, 10, 1224, 4, 2, 1, 850, 1200, 0]),
      "UnsupportedVersion",
      { found: 1, supported: PROTOCOL_VERSION },
    ],
    [
      "version 3 (before the scene version word and the writer's frames)",
      bytes([MAGIC, versionKind(3, 3), 0, 0]),
      "UnsupportedVersion",
      { found: 3, supported: PROTOCOL_VERSION },
    ],
    ["version 0", bytes([MAGIC, versionKind(0, 3), 0, 0]), "UnsupportedVersion", { found: 0, supported: PROTOCOL_VERSION }],
    ["version and kind swapped", bytes([MAGIC, versionKind(3, 4), 0, 0]), "UnsupportedVersion", { found: 3, supported: PROTOCOL_VERSION }],
    ["kind 0", frame(0, 0, 0, []), "UnknownKind", { kind: 0 }],
    ["kind 11", frame(11, 0, 0, []), "UnknownKind", { kind: 11 }],
    ["kind 0xffff", frame(0xffff, 0, 0, []), "UnknownKind", { kind: 0xffff }],
    ["hello with an ack", frame(1, 1, 9, textPayload(5, "{}", 0)), "NonZeroAck", { kind: "hello", ack: 9 }],
    ["pose with an ack", poseWithAck, "NonZeroAck", { kind: "pose", ack: 3 }],
    ["pose one word short", frame(2, 0, 0, new Array(12).fill(0)), "PayloadSize", { kind: "pose", expected: 13, actual: 12 }],
    ["pose one word long", frame(2, 0, 0, new Array(14).fill(0)), "PayloadSize", { kind: "pose", expected: 13, actual: 14 }],
    ["full without its count", frame(3, 0, 0, stats()), "PayloadSize", { kind: "full", expected: 7, actual: 6 }],
    ["full count larger than its ids", frame(3, 0, 0, [...stats(), 5, 1, 2, 3]), "PayloadSize", { kind: "full", expected: 12, actual: 10 }],
    [
      "full count u32::MAX (must not allocate it)",
      frame(3, 0, 0, [...stats(), U32_MAX, 1]),
      "PayloadSize",
      { kind: "full", expected: 7 + U32_MAX, actual: 8 },
    ],
    [
      "delta counts both 65535 (must not allocate them)",
      frame(4, 0, 0, [...stats(), U32_MAX, 1]),
      "PayloadSize",
      { kind: "delta", expected: 7 + 2 * 65535, actual: 8 },
    ],
    [
      "delta counts word: 1 added in the low half, 1 removed in the high half",
      frame(4, 0, 0, [...stats(), 0x00010001, 5]),
      "PayloadSize",
      { kind: "delta", expected: 9, actual: 8 },
    ],
    [
      "delta with its counts read as v1 (two words)",
      frame(4, 0, 0, [...stats(), 1, 1, 5, 6]),
      "PayloadSize",
      { kind: "delta", expected: 8, actual: 10 },
    ],
    ["delta without its counts", frame(4, 0, 0, new Array(6).fill(0)), "PayloadSize", { kind: "delta", expected: 7, actual: 6 }],
    [
      "hello JSON longer than the payload",
      frame(1, 0, 0, [3, U32_MAX, 0x20207b7b]),
      "PayloadSize",
      { kind: "hello", expected: 2 + Math.ceil(U32_MAX / 4), actual: 3 },
    ],
    ["hello with a trailing word", frame(1, 0, 0, [...textPayload(3, "{}", 0), 0]), "PayloadSize", { kind: "hello", expected: 3, actual: 4 }],
    ["hello without its length", frame(1, 0, 0, [3]), "PayloadSize", { kind: "hello", expected: 2, actual: 1 }],
    [
      "error message shorter than its length",
      frame(5, 0, 0, [1, 9, 0x61616161, 0x61616161]),
      "PayloadSize",
      { kind: "error", expected: 5, actual: 4 },
    ],
    ["full ids repeated", full([1, 4, 4]), "NotAscending", { list: "full", index: 2, prev: 4, id: 4 }],
    ["full ids descending", full([9, 2]), "NotAscending", { list: "full", index: 1, prev: 9, id: 2 }],
    ["delta added descending", delta([1, 7, 3], []), "NotAscending", { list: "added", index: 2, prev: 7, id: 3 }],
    ["delta removed repeated", delta([], [0, 0]), "NotAscending", { list: "removed", index: 1, prev: 0, id: 0 }],
    ["delta id in both lists", delta([1, 2, 8], [0, 8]), "IdInBothLists", { id: 8 }],
    ["pose flag bit 2", pose(4), "BadFlags", { flags: 4 }],
    ["stereo pose without its two words", pose(2), "PayloadSize", { kind: "pose", expected: 15, actual: 13 }],
    ["pose flag bit 31", pose(0x80000001), "BadFlags", { flags: 0x80000001 }],
    [
      "hello JSON not UTF-8",
      frame(1, 0, 0, textPayload(3, new Uint8Array([0x7b, 0x22, 0x61, 0x22, 0x3a, 0x22, 0xff, 0x22, 0x7d]), 0)),
      "InvalidUtf8",
      { field: "hello JSON" },
    ],
    [
      "error message with a truncated UTF-8 sequence",
      frame(5, 0, 0, textPayload(5, new Uint8Array([0x64, 0x65, 0x67, 0x20, 0xc2]), 0)),
      "InvalidUtf8",
      { field: "error message" },
    ],
    ["hello padding not zero", frame(1, 0, 0, textPayload(3, "{}", 0x20)), "NonZeroPadding", { field: "hello JSON" }],
    ["error padding not zero", frame(5, 0, 0, textPayload(4, "busy!", 1)), "NonZeroPadding", { field: "error message" }],
    ["error code 0", frame(5, 0, 0, textPayload(0, "x", 0)), "UnknownErrorCode", { code: 0 }],
    ["error code 9", frame(5, 0, 0, textPayload(9, "x", 0)), "UnknownErrorCode", { code: 9 }],
    ["transforms with an ack", frame(8, 1, 4, [NO_VALUE, 0]), "NonZeroAck", { kind: "transforms", ack: 4 }],
    ["transforms without its count", frame(8, 1, 0, [NO_VALUE]), "PayloadSize", { kind: "transforms", expected: 2, actual: 1 }],
    ["transforms one object word short", frame(8, 1, 0, [NO_VALUE, 1, 5, 0, 0, 0]), "PayloadSize", { kind: "transforms", expected: 22, actual: 6 }],
    ["transforms ids not ascending", frame(8, 1, 0, movedObjects([9, 3])), "NotAscending", { list: "transforms", index: 1, prev: 9, id: 3 }],
    ["applied without its count", frame(9, 1, 2, [3, 0]), "PayloadSize", { kind: "applied", expected: 3, actual: 2 }],
    [
      "delta removed repeated after a non-empty added list",
      delta([5], [6, 6]),
      "NotAscending",
      { list: "removed", index: 1, prev: 6, id: 6 },
    ],
    // lod_cases() of proto/tests/common/levels.rs: frames with levels of detail.
    ["full_lod without its level word", fullLod([1, 2], []), "PayloadSize", { kind: "full_lod", expected: 10, actual: 9 }],
    ["full_lod with level 9", fullLod([1, 2], [levelWord([0, 9, 0, 0])]), "BadLevel", { level: 9 }],
    ["full_lod padding not zero", fullLod([1, 2], [levelWord([0, 1, 0, 1])]), "NonZeroPadding", { field: "levels" }],
    ["full_lod ids not ascending", fullLod([2, 1], [0]), "NotAscending", { list: "full", index: 1, prev: 2, id: 1 }],
    ["delta_lod one level word short", deltaLod([4], [], [7], []), "PayloadSize", { kind: "delta_lod", expected: 11, actual: 10 }],
    ["delta_lod changed not ascending", deltaLod([], [], [7, 3], [0]), "NotAscending", { list: "changed", index: 1, prev: 7, id: 3 }],
    ["delta_lod changes an id it adds", deltaLod([3, 7], [], [7], [0]), "ChangedNotKept", { id: 7 }],
    ["delta_lod changes an id it removes", deltaLod([], [5], [5], [0]), "ChangedNotKept", { id: 5 }],
    ["delta_lod with level 255", deltaLod([3], [], [], [levelWord([255, 0, 0, 0])]), "BadLevel", { level: 255 }],
    // Beyond reject.rs: UTF-8 the Rust decoder also refuses.
    ["surrogate in UTF-8 (CESU)", frame(5, 0, 0, textPayload(1, new Uint8Array([0xed, 0xa0, 0x80]), 0)), "InvalidUtf8", { field: "error message" }],
    ["overlong UTF-8", frame(5, 0, 0, textPayload(1, new Uint8Array([0xc0, 0xaf]), 0)), "InvalidUtf8", { field: "error message" }],
  ];
}

test("every crafted input is rejected as the Rust decoder rejects it", () => {
  const seen = new Set();
  for (const [what, input, variant, fields] of cases()) {
    assert.throws(
      () => decodeFrame(input),
      (e) => {
        assert.ok(e instanceof FrameError, `${what}: ${e}`);
        assert.equal(e.variant, variant, `${what}: ${e.message}`);
        assert.deepEqual(e.fields, fields, what);
        assert.ok(e.message.length > 0);
        assert.equal(e.code, variant === "UnsupportedVersion" ? ErrorCode.UNSUPPORTED_VERSION : ErrorCode.MALFORMED_FRAME);
        return true;
      },
      what,
    );
    seen.add(variant);
  }
  // Every decoder error variant is exercised (RemovedAbsent/AddedPresent: visible.test.mjs;
  // DeltaTooLarge and LevelCount come from validateFrame, below).
  assert.equal(seen.size, 16);
});

test("error messages read like the Rust ones", () => {
  assert.match(new FrameError("BadMagic", { found: 0xdeadbeef }).message, /0xdeadbeef.*0x4c434d48/);
  assert.match(new FrameError("TooLong", { len: 1 << 30 }).message, new RegExp(String(MAX_FRAME_BYTES)));
  assert.match(new FrameError("TooShort", { len: 3 }).message, new RegExp(String(HEADER_BYTES)));
  assert.equal(
    new FrameError("BadFlags", { flags: 0x80000001 }).message,
    "pose flags 0x80000001 set bits other than bit 0 (want_full) and bit 1 (stereo)",
  );
  assert.equal(
    new FrameError("UnsupportedVersion", { found: 7, supported: 3 }).message,
    "unsupported protocol version 7, this build supports version 3",
  );
  assert.equal(
    new FrameError("DeltaTooLarge", { added: 65536, removed: 0 }).message,
    "delta lists too long: 65536 added and 0 removed ids, a delta frame carries at most 65535 per list (send a full frame)",
  );
});

test("truncations of valid frames are rejected", () => {
  const valid = [
    full([1, 2, 3]),
    delta([1, 4], [2]),
    pose(1),
    frame(1, 1, 0, textPayload(3, '{"é":1}', 0)),
    frame(5, 1, 0, textPayload(4, "overloaded", 0)),
    ...manifest.frames.map((f) => readHex(f.file)),
  ];
  for (const f of valid) {
    decodeFrame(f);
    for (let cut = 0; cut < f.length; cut++) {
      assert.throws(() => decodeFrame(f.subarray(0, cut)), FrameError, `cut at ${cut}`);
    }
  }
});

test("encode then decode round-trips, and validate agrees with decode", () => {
  const frames = [
    { kind: "hello", seq: 0, ack: 0, object_count: 3, info_json: '{"a":"ü€😀"}' },
    { kind: "full", seq: 5, ack: 4, stats: { candidates: 2, occluders_used: 1, dropped_poses: 0, gpu_us: 7, total_us: 9, scene_version: 0 }, ids: [0, 2, 0xffffffff] },
    { kind: "delta", seq: 6, ack: 9, stats: { candidates: 0, occluders_used: 0, dropped_poses: 2, gpu_us: 0, total_us: 1, scene_version: 0 }, added: [], removed: [0, 2] },
    { kind: "delta", seq: 7, ack: 10, stats: { candidates: 9, occluders_used: 1, dropped_poses: 0, gpu_us: 3, total_us: 4, scene_version: 0 }, added: [1, 5, 7], removed: [2, 3] },
    { kind: "error", seq: 7, ack: 0, code: 4, code_name: "overloaded", message: "busy" },
    { kind: "error", seq: 8, ack: 3, code: 7, code_name: "invalid_transform", message: "object 9 does not exist" },
    {
      kind: "transforms",
      seq: 3,
      ack: 0,
      horizon_ms: 250,
      objects: [
        { id: 2, matrix: [1, 0, 0, 0, 1, 0, 0, 0, 1, 4.5, 0, -2], velocity: [1, 0, 0], angular_velocity: [0, 0.5, 0], valid_ms: null },
        { id: 9, matrix: [2, 0, 0, 0, 2, 0, 0, 0, 2, 0, 0, 0], velocity: [0, 0, 0], angular_velocity: [0, 0, 0], valid_ms: 40 },
      ],
    },
    { kind: "transforms", seq: 4, ack: 0, horizon_ms: null, objects: [] },
    { kind: "applied", seq: 9, ack: 3, version: 2 ** 40 + 17, applied: 2 },
    { kind: "pose", seq: 1, ack: 0, want_full: false, position: [1.5, -0, 3], rotation: [0, 0, 0, 1], fov_y_deg: 75, viewport: [1, 8192], near: 0.5, far: 100 },
    { kind: "full_lod", seq: 8, ack: 11, stats: { candidates: 3, occluders_used: 1, dropped_poses: 0, gpu_us: 2, total_us: 3, scene_version: 5 }, ids: [1, 2, 9, 10, 11], levels: [8, 0, 1, 2, 3] },
    { kind: "delta_lod", seq: 9, ack: 12, stats: { candidates: 3, occluders_used: 1, dropped_poses: 0, gpu_us: 2, total_us: 3, scene_version: 5 }, added: [4], removed: [1], changed: [2, 10], added_levels: [5], changed_levels: [1, 0] },
  ];
  for (const f of frames) {
    validateFrame(f);
    const bytes = encodeFrame(f);
    assert.deepEqual(decodeFrame(bytes), f);
    assert.deepEqual(encodeFrame(decodeFrame(bytes)), bytes);
  }
  const badFull = { kind: "full", seq: 0, ack: 0, stats: {}, ids: [2, 1] };
  assert.throws(() => validateFrame(badFull), { variant: "NotAscending" });
  assert.throws(() => decodeFrame(encodeFrame(badFull)), { variant: "NotAscending" });
  const badDelta = { kind: "delta", seq: 0, ack: 0, stats: {}, added: [3], removed: [3] };
  assert.throws(() => validateFrame(badDelta), { variant: "IdInBothLists", fields: { id: 3 } });
  assert.throws(() => decodeFrame(encodeFrame(badDelta)), { variant: "IdInBothLists" });
  const fewLevels = { kind: "full_lod", seq: 0, ack: 0, stats: {}, ids: [1, 2, 3], levels: [0, 1] };
  assert.throws(() => validateFrame(fewLevels), { variant: "LevelCount", fields: { ids: 3, levels: 2 } });
  assert.equal(new FrameError("LevelCount", { ids: 3, levels: 2 }).message, "3 ids but 2 levels of detail");
  assert.throws(() => encodeFrame(fewLevels), TypeError);
  const changedAdded = { kind: "delta_lod", seq: 0, ack: 0, stats: {}, added: [4], removed: [], changed: [4], added_levels: [0], changed_levels: [1] };
  assert.throws(() => validateFrame(changedAdded), { variant: "ChangedNotKept", fields: { id: 4 } });
  const unordered = { kind: "transforms", seq: 0, ack: 0, horizon_ms: null, objects: [5, 5].map((id) => ({ id, matrix: new Array(12).fill(0), velocity: [0, 0, 0], angular_velocity: [0, 0, 0], valid_ms: null })) };
  assert.throws(() => validateFrame(unordered), { variant: "NotAscending", fields: { list: "transforms", index: 1, prev: 5, id: 5 } });
  assert.throws(() => decodeFrame(encodeFrame(unordered)), { variant: "NotAscending" });
  const huge = { kind: "full", seq: 0, ack: 0, stats: {}, ids: Array.from({ length: MAX_FRAME_BYTES / 4 }, (_, i) => i) };
  assert.throws(() => validateFrame(huge), { variant: "TooLong" });
});

test("a delta carries at most 65535 ids per list", () => {
  const range = (from, n) => Array.from({ length: n }, (_, i) => from + i);
  assert.equal(MAX_DELTA_IDS, 65535);
  // Both lists full: the counts word is all ones.
  const max = { kind: "delta", seq: 1, ack: 1, stats: {}, added: range(0, MAX_DELTA_IDS), removed: range(MAX_DELTA_IDS, MAX_DELTA_IDS) };
  validateFrame(max);
  const bytes = encodeFrame(max);
  assert.equal(bytes.length, 16 + 4 * (6 + 1 + 2 * MAX_DELTA_IDS));
  assert.equal(new DataView(bytes.buffer).getUint32(40, true), 0xffffffff);
  const back = decodeFrame(bytes);
  assert.equal(back.added.length, MAX_DELTA_IDS);
  assert.deepEqual(back.removed, max.removed);
  // One more in either list does not fit: validate reports it, encode refuses it.
  for (const [added, removed] of [
    [range(0, MAX_DELTA_IDS + 1), []],
    [[0, 1, 2], range(3, MAX_DELTA_IDS + 1)],
  ]) {
    const f = { kind: "delta", seq: 1, ack: 1, stats: {}, added, removed };
    assert.throws(() => validateFrame(f), { variant: "DeltaTooLarge", fields: { added: added.length, removed: removed.length } });
    assert.throws(() => encodeFrame(f), TypeError);
  }
});

test("derived stats", () => {
  const s = { candidates: 10, occluders_used: 2, dropped_poses: 1, gpu_us: 850, total_us: 1200 };
  assert.equal(culledByFrustum(s, 1234), 1224);
  assert.equal(culledByOcclusion(s, 6), 4);
  // Inconsistent input does not go negative.
  assert.equal(culledByFrustum(s, 3), 0);
  assert.equal(culledByOcclusion(s, 11), 0);
  assert.deepEqual(deriveStats(s, 1234, 6), {
    objects: 1234,
    candidates: 10,
    occluders_used: 2,
    dropped_poses: 1,
    gpu_us: 850,
    total_us: 1200,
    culled_by_frustum: 1224,
    culled_by_occlusion: 4,
  });
});

test("encoder refuses fields it cannot write", () => {
  assert.throws(() => encodeFrame({ kind: "nope", seq: 0 }), TypeError);
  assert.throws(() => encodeFrame({ kind: "full", seq: -1, ack: 0, stats: {}, ids: [] }), TypeError);
  assert.throws(() => encodeFrame({ kind: "full", seq: 0, ack: 0, stats: {}, ids: [1.5] }), TypeError);
  assert.throws(() => encodeFrame({ kind: "error", seq: 0, ack: 0, code: 2 ** 32, message: "" }), TypeError);
  assert.throws(() => encodePose(1, { position: [0, 0, 0], look_at: [1, 0, 0] }), TypeError);
  // Defaults of the REST Pose.
  const f = decodeFrame(encodePose(3, { position: [1, 2, 3] }));
  assert.deepEqual(f, {
    kind: "pose",
    seq: 3,
    ack: 0,
    want_full: false,
    position: [1, 2, 3],
    rotation: [0, 0, 0, 1],
    fov_y_deg: 60,
    viewport: [960, 540],
    near: Math.fround(0.1),
    far: 5000,
  });
});
