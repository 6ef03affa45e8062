// Binary WebSocket frames of the homcull protocol (version 4), encoder and decoder.
//
// This mirrors `proto/src/frame/` exactly (read its module docs for the layout): a
// frame is a sequence of little-endian u32 words, f32 travel as their IEEE-754 bits, a
// 4-word header (magic, version | kind << 16, seq, ack) and a payload per kind that
// runs to the end of the frame.
// The decoder accepts exactly what the Rust decoder accepts, checks in the same order and
// reports the first failure as a `FrameError` whose `variant` and `fields` match the Rust
// `FrameError` (the golden vectors in `proto/tests/golden/` and the rejection cases of
// `proto/tests/reject.rs` are run against this file by `test/codec.test.mjs`).
//
// Frames are plain objects with the field names of the Rust structs:
//   { kind: "hello", seq, ack: 0, object_count, info_json }
//   { kind: "pose",  seq, ack: 0, want_full, position: [x,y,z], rotation: [x,y,z,w],
//     fov_y_deg, viewport: [w,h], near, far, stereo? }  (stereo: {ipd_m, convergence_m?})
//   { kind: "full",  seq, ack, stats, ids }
//   { kind: "delta", seq, ack, stats, added, removed }
//   { kind: "error", seq, ack, code, code_name, message }
//   { kind: "full_lod",  seq, ack, stats, ids, levels }
//   { kind: "delta_lod", seq, ack, stats, added, removed, changed, added_levels, changed_levels }
//   { kind: "transforms", seq, ack: 0, horizon_ms, objects }  (horizon_ms null: keep;
//     objects: [{id, matrix: 12 numbers, velocity: [3], angular_velocity: [3], valid_ms}],
//     valid_ms null: until the next update)
//   { kind: "applied", seq, ack, version, applied }
// where stats = { candidates, occluders_used, dropped_poses, gpu_us, total_us,
// scene_version } (what is
// on the wire; `deriveStats` adds objects, culled_by_frustum and culled_by_occlusion from
// the Hello's object count and the visible set) and ID lists are plain arrays.

/** First word of every frame: bytes 48 4D 43 4C ("HMCL") read as a little-endian u32. */
export const MAGIC = 0x4c434d48;
/** Version of the wire protocol this client speaks. */
export const PROTOCOL_VERSION = 5;
/** Words in the frame header: magic, version | kind << 16, seq, ack. */
export const HEADER_WORDS = 4;
/** Bytes in the frame header. */
export const HEADER_BYTES = HEADER_WORDS * 4;
/** Largest frame the decoder accepts. */
export const MAX_FRAME_BYTES = 16 << 20;
/** Words in the stats block of Full and Delta frames. */
export const STATS_WORDS = 6;
/** Most IDs a Delta frame carries per list (both counts share one word, 16 bits each). */
export const MAX_DELTA_IDS = 0xffff;
/** Words in a Pose payload. */
export const POSE_PAYLOAD_WORDS = 13;
/** Bit of a Pose frame's flags asking for a full frame. */
export const POSE_FLAG_WANT_FULL = 1;
/** Bit of a Pose frame's flags making it a stereo pose: `ipd_m`, `convergence_m` follow. */
export const POSE_FLAG_STEREO = 2;
/** Largest level of detail a frame carries. */
export const MAX_LEVEL = 8;
/** The word an absent optional f32 travels as (a Transforms frame's horizon and validity). */
export const NO_VALUE = 0xffffffff;
/** Words per object of a Transforms frame. */
export const MOVED_OBJECT_WORDS = 20;
/** Words in a Region payload: centre xyz, radius_m, axis xyz, turn_deg. */
export const REGION_WORDS = 8;

/** Frame kinds (the high 16 bits of header word 1). */
export const FrameKind = Object.freeze({
  HELLO: 1,
  POSE: 2,
  FULL: 3,
  DELTA: 4,
  ERROR: 5,
  FULL_LOD: 6,
  DELTA_LOD: 7,
  TRANSFORMS: 8,
  APPLIED: 9,
  REGION: 10,
});
const KIND_NAMES = ["", "hello", "pose", "full", "delta", "error", "full_lod", "delta_lod", "transforms", "applied", "region"];

/** Error codes carried by Error frames. */
export const ErrorCode = Object.freeze({
  MALFORMED_FRAME: 1,
  UNSUPPORTED_VERSION: 2,
  INVALID_POSE: 3,
  OVERLOADED: 4,
  INTERNAL: 5,
  UNKNOWN_SCENE: 6,
  INVALID_TRANSFORM: 7,
  UNAUTHORIZED: 8,
});
const ERROR_CODE_NAMES = [
  "",
  "malformed_frame",
  "unsupported_version",
  "invalid_pose",
  "overloaded",
  "internal",
  "unknown_scene",
  "invalid_transform",
  "unauthorized",
];

/** Stats words in wire order. */
export const STATS_FIELDS = Object.freeze(["candidates", "occluders_used", "dropped_poses", "gpu_us", "total_us", "scene_version"]);

/**
 * Objects removed by the frustum test: `objects - stats.candidates`, where `objects` is the
 * scene's object count (the Hello's `object_count`); 0 for inconsistent input. Mirrors
 * `FrameStats::culled_by_frustum`.
 */
export function culledByFrustum(stats, objects) {
  return Math.max(0, objects - stats.candidates);
}

/**
 * In-frustum objects removed by the occlusion test: `stats.candidates - visible`, where
 * `visible` is the size of the visible set the frame describes (a Full frame's
 * `ids.length`, or the set once a Delta is applied); 0 for inconsistent input. Mirrors
 * `FrameStats::culled_by_occlusion`.
 */
export function culledByOcclusion(stats, visible) {
  return Math.max(0, stats.candidates - visible);
}

/**
 * The stats of a Full/Delta frame with what version 1 of the protocol also sent and a
 * client now derives: `{objects, candidates, culled_by_frustum, culled_by_occlusion,
 * occluders_used, dropped_poses, gpu_us, total_us}`, from the scene's object count (the
 * Hello's `object_count`) and the size of the visible set once the frame is applied.
 */
export function deriveStats(stats, objects, visible) {
  return {
    objects,
    ...stats,
    culled_by_frustum: culledByFrustum(stats, objects),
    culled_by_occlusion: culledByOcclusion(stats, visible),
  };
}

/** The lowercase name of a frame kind code (`hello`, ...), or undefined. */
export function kindName(code) {
  return KIND_NAMES[code] || undefined;
}

/** The snake_case name of an error code (`malformed_frame`, ...), or undefined. */
export function errorCodeName(code) {
  return ERROR_CODE_NAMES[code] || undefined;
}

const hex = (n) => "0x" + (n >>> 0).toString(16).padStart(8, "0");

const MESSAGES = {
  TooShort: (f) => `frame too short: ${f.len} bytes, the header alone is ${HEADER_BYTES} bytes`,
  TooLong: (f) => `frame too long: ${f.len} bytes, the limit is ${MAX_FRAME_BYTES} bytes`,
  NotWordAligned: (f) => `frame length ${f.len} bytes is not a multiple of 4`,
  BadMagic: (f) =>
    `bad magic ${hex(f.found)}, expected ${hex(MAGIC)} (bytes 48 4d 43 4c, "HMCL")`,
  UnsupportedVersion: (f) =>
    `unsupported protocol version ${f.found}, this build supports version ${f.supported}`,
  UnknownKind: (f) => `unknown frame kind ${f.kind} (expected 1 to 9)`,
  NonZeroAck: (f) => `${f.kind} frame has ack ${f.ack}, it must be 0`,
  PayloadSize: (f) => `${f.kind} payload has ${f.actual} words, its fields need ${f.expected}`,
  NotAscending: (f) =>
    `${f.list} ids not strictly ascending: ${f.id} at index ${f.index} follows ${f.prev}`,
  IdInBothLists: (f) => `id ${f.id} is both in the added and in the removed list of a delta`,
  BadFlags: (f) => `pose flags 0x${f.flags.toString(16)} set bits other than bit 0 (want_full) and bit 1 (stereo)`,
  InvalidUtf8: (f) => `${f.field} is not valid UTF-8`,
  NonZeroPadding: (f) => `padding after ${f.field} is not zero`,
  UnknownErrorCode: (f) => `unknown error code ${f.code} (expected 1 to 8)`,
  RemovedAbsent: (f) => `delta removes id ${f.id}, which is not in the visible set`,
  AddedPresent: (f) => `delta adds id ${f.id}, which is already in the visible set`,
  BadLevel: (f) => `level of detail ${f.level} is above the largest, ${MAX_LEVEL}`,
  ChangedNotKept: (f) => `delta changes the level of id ${f.id}, which it also adds or removes`,
  LevelCount: (f) => `${f.ids} ids but ${f.levels} levels of detail`,
  DeltaTooLarge: (f) =>
    `delta lists too long: ${f.added} added and ${f.removed} removed ids, a delta frame carries at most ${MAX_DELTA_IDS} per list (send a full frame)`,
};

/**
 * Why a frame did not decode (or a delta did not apply). `variant` is the name of the
 * Rust `FrameError` variant, `fields` its fields (kinds as their lowercase names).
 */
export class FrameError extends Error {
  constructor(variant, fields = {}) {
    const msg = MESSAGES[variant];
    super(msg ? msg(fields) : variant);
    this.name = "FrameError";
    this.variant = variant;
    this.fields = fields;
  }

  /** The error code a server answers this error with. */
  get code() {
    return this.variant === "UnsupportedVersion"
      ? ErrorCode.UNSUPPORTED_VERSION
      : ErrorCode.MALFORMED_FRAME;
  }
}

const utf8Decoder = new TextDecoder("utf-8", { fatal: true, ignoreBOM: true });
const utf8Encoder = new TextEncoder();

function asBytes(input) {
  if (input instanceof Uint8Array) return input;
  if (input instanceof ArrayBuffer) return new Uint8Array(input);
  if (ArrayBuffer.isView(input)) return new Uint8Array(input.buffer, input.byteOffset, input.byteLength);
  throw new TypeError("decodeFrame expects an ArrayBuffer or a typed array");
}

/**
 * Parses one frame from an ArrayBuffer or typed array. Never reads past the input and
 * never allocates more than the input's size justifies; throws `FrameError`.
 */
export function decodeFrame(input) {
  const bytes = asBytes(input);
  const len = bytes.byteLength;
  if (len > MAX_FRAME_BYTES) throw new FrameError("TooLong", { len });
  if (len < HEADER_BYTES) throw new FrameError("TooShort", { len });
  if (len % 4 !== 0) throw new FrameError("NotWordAligned", { len });
  const view = new DataView(bytes.buffer, bytes.byteOffset, len);
  const word = (i) => view.getUint32(i * 4, true);
  const magic = word(0);
  const version = word(1) & 0xffff;
  const kindCode = word(1) >>> 16;
  const seq = word(2);
  const ack = word(3);
  if (magic !== MAGIC) throw new FrameError("BadMagic", { found: magic });
  if (version !== PROTOCOL_VERSION) {
    throw new FrameError("UnsupportedVersion", { found: version, supported: PROTOCOL_VERSION });
  }
  const kind = kindName(kindCode);
  if (kind === undefined) throw new FrameError("UnknownKind", { kind: kindCode });
  if ((kind === "hello" || kind === "pose" || kind === "transforms") && ack !== 0) {
    throw new FrameError("NonZeroAck", { kind, ack });
  }
  // The payload: the rest of the frame, consumed front to back (`pos` counts payload
  // words consumed).
  const words = len / 4 - HEADER_WORDS;
  let pos = 0;
  const sizeError = (more) => new FrameError("PayloadSize", { kind, expected: pos + more, actual: words });
  const fixed = (n) => {
    if (words - pos < n) throw sizeError(n);
    const out = new Array(n);
    for (let i = 0; i < n; i++) out[i] = word(HEADER_WORDS + pos + i);
    pos += n;
    return out;
  };
  // All remaining words, which must be exactly n; returns the word index where they start.
  const tail = (n) => {
    if (words - pos !== n) throw sizeError(n);
    const start = HEADER_WORDS + pos;
    pos = words;
    return start;
  };
  const text = (field, byteLen) => {
    const start = tail(Math.ceil(byteLen / 4)) * 4;
    for (let i = start + byteLen; i < len; i++) {
      if (bytes[i] !== 0) throw new FrameError("NonZeroPadding", { field });
    }
    try {
      return utf8Decoder.decode(bytes.subarray(start, start + byteLen));
    } catch {
      throw new FrameError("InvalidUtf8", { field });
    }
  };
  const ids = (list, start, count) => {
    const out = new Array(count);
    for (let i = 0; i < count; i++) {
      const id = word(start + i);
      if (i > 0 && id <= out[i - 1]) {
        throw new FrameError("NotAscending", { list, index: i, prev: out[i - 1], id });
      }
      out[i] = id;
    }
    return out;
  };
  // `count` level bytes at byte offset `at`, then zero padding to the frame's end.
  const levels = (at, count) => {
    for (let i = at + count; i < len; i++) {
      if (bytes[i] !== 0) throw new FrameError("NonZeroPadding", { field: "levels" });
    }
    const out = Array.from(bytes.subarray(at, at + count));
    checkLevels(count, out);
    return out;
  };
  const stats = () => {
    const w = fixed(STATS_WORDS);
    const s = {};
    STATS_FIELDS.forEach((name, i) => (s[name] = w[i]));
    return s;
  };

  switch (kind) {
    case "hello": {
      const [object_count, byteLen] = fixed(2);
      const info_json = text("hello JSON", byteLen);
      return { kind, seq, ack, object_count, info_json };
    }
    case "pose": {
      const w = fixed(POSE_PAYLOAD_WORDS);
      const stereo = (w[0] & POSE_FLAG_STEREO) !== 0 ? fixed(2) : null;
      tail(0);
      const flags = w[0];
      if ((flags & ~(POSE_FLAG_WANT_FULL | POSE_FLAG_STEREO)) !== 0) throw new FrameError("BadFlags", { flags: flags >>> 0 });
      const f = (i) => view.getFloat32((HEADER_WORDS + i) * 4, true);
      const out = {
        kind,
        seq,
        ack,
        want_full: (flags & POSE_FLAG_WANT_FULL) !== 0,
        position: [f(1), f(2), f(3)],
        rotation: [f(4), f(5), f(6), f(7)],
        fov_y_deg: f(8),
        viewport: [w[9], w[10]],
        near: f(11),
        far: f(12),
      };
      if (stereo) {
        out.stereo = { ipd_m: f(13) };
        // The word 0 is "no convergence".
        if (stereo[1] !== 0) out.stereo.convergence_m = f(14);
      }
      return out;
    }
    case "full":
    case "full_lod": {
      const s = stats();
      const [count] = fixed(1);
      const lod = kind === "full_lod";
      const start = tail(count + (lod ? Math.ceil(count / 4) : 0));
      const out = { kind, seq, ack, stats: s, ids: ids("full", start, count) };
      if (lod) out.levels = levels((start + count) * 4, count);
      return out;
    }
    case "delta":
    case "delta_lod": {
      const s = stats();
      const [counts] = fixed(1);
      const lod = kind === "delta_lod";
      const changedCount = lod ? fixed(1)[0] : 0;
      const addedCount = counts & 0xffff;
      const removedCount = counts >>> 16;
      const levelWords = lod ? Math.ceil((addedCount + changedCount) / 4) : 0;
      const start = tail(addedCount + removedCount + changedCount + levelWords);
      const added = ids("added", start, addedCount);
      const removed = ids("removed", start + addedCount, removedCount);
      checkDisjoint(added, removed);
      if (!lod) return { kind, seq, ack, stats: s, added, removed };
      const changed = ids("changed", start + addedCount + removedCount, changedCount);
      checkChanged(changed, added, removed);
      const all = levels((start + addedCount + removedCount + changedCount) * 4, addedCount + changedCount);
      return {
        kind,
        seq,
        ack,
        stats: s,
        added,
        removed,
        changed,
        added_levels: all.slice(0, addedCount),
        changed_levels: all.slice(addedCount),
      };
    }
    case "transforms": {
      const [horizon, count] = fixed(2);
      const start = tail(count * MOVED_OBJECT_WORDS);
      const f = (i) => view.getFloat32(i * 4, true);
      const optional = (i) => (word(i) === NO_VALUE ? null : f(i));
      const objects = [];
      for (let k = 0; k < count; k++) {
        const at = start + k * MOVED_OBJECT_WORDS;
        const id = word(at);
        if (k > 0 && id <= objects[k - 1].id) {
          throw new FrameError("NotAscending", { list: "transforms", index: k, prev: objects[k - 1].id, id });
        }
        const floats = (from, n) => Array.from({ length: n }, (_, i) => f(at + from + i));
        objects.push({
          id,
          matrix: floats(1, 12),
          velocity: floats(13, 3),
          angular_velocity: floats(16, 3),
          valid_ms: optional(at + 19),
        });
      }
      return { kind, seq, ack, horizon_ms: optional(HEADER_WORDS), objects };
    }
    case "applied": {
      const [lo, hi, applied] = fixed(3);
      tail(0);
      return { kind, seq, ack, version: lo + hi * 2 ** 32, applied };
    }
    case "region": {
      fixed(REGION_WORDS);
      tail(0);
      const f = (i) => view.getFloat32((HEADER_WORDS + i) * 4, true);
      return { kind, seq, ack, centre: [f(0), f(1), f(2)], radius_m: f(3), axis: [f(4), f(5), f(6)], turn_deg: f(7) };
    }
    case "error": {
      const [code, byteLen] = fixed(2);
      const name = errorCodeName(code);
      if (name === undefined) throw new FrameError("UnknownErrorCode", { code });
      const message = text("error message", byteLen);
      return { kind, seq, ack, code, code_name: name, message };
    }
  }
  /* c8 ignore next */
  throw new Error("unreachable");
}

/** Throws IdInBothLists for the first ID common to two ascending lists. */
export function checkDisjoint(a, b) {
  let i = 0;
  let j = 0;
  while (i < a.length && j < b.length) {
    if (a[i] === b[j]) throw new FrameError("IdInBothLists", { id: a[i] });
    if (a[i] < b[j]) i++;
    else j++;
  }
}

/** Throws LevelCount unless there is one level per ID, BadLevel for one above MAX_LEVEL. */
export function checkLevels(ids, levels) {
  if (levels.length !== ids) throw new FrameError("LevelCount", { ids, levels: levels.length });
  for (const level of levels) {
    if (!Number.isInteger(level) || level < 0 || level > MAX_LEVEL) throw new FrameError("BadLevel", { level });
  }
}

/** Throws ChangedNotKept for the first changed ID that is also added or removed. */
export function checkChanged(changed, added, removed) {
  for (const list of [added, removed]) {
    try {
      checkDisjoint(changed, list);
    } catch (e) {
      if (e.variant === "IdInBothLists") throw new FrameError("ChangedNotKept", { id: e.fields.id });
      throw e;
    }
  }
}

/** Throws NotAscending if `ids` is not strictly ascending. */
export function checkAscending(list, ids) {
  for (let i = 1; i < ids.length; i++) {
    if (ids[i] <= ids[i - 1]) {
      throw new FrameError("NotAscending", { list, index: i, prev: ids[i - 1], id: ids[i] });
    }
  }
}

function u32(name, v) {
  if (!Number.isInteger(v) || v < 0 || v > 0xffffffff) {
    throw new TypeError(`${name} must be an integer in [0, 2^32), got ${v}`);
  }
  return v;
}

function kindCodeOf(kind) {
  const code = KIND_NAMES.indexOf(kind);
  if (code < 1) throw new TypeError(`unknown frame kind ${JSON.stringify(kind)}`);
  return code;
}

/**
 * The bytes of a frame (a Uint8Array). Like the Rust encoder it writes the fields as
 * they are: ID lists that are not strictly ascending give a frame that `decodeFrame`
 * rejects (see `validateFrame`). Throws TypeError for fields that are not numbers of
 * the right range or strings.
 */
export function encodeFrame(frame) {
  const kindCode = kindCodeOf(frame.kind);
  const words = [];
  let textBytes = null;
  switch (frame.kind) {
    case "hello":
      textBytes = utf8Encoder.encode(String(frame.info_json));
      words.push(u32("object_count", frame.object_count), textBytes.length);
      break;
    case "pose":
      words.push((frame.want_full ? POSE_FLAG_WANT_FULL : 0) | (frame.stereo ? POSE_FLAG_STEREO : 0));
      // The floats are written below through a DataView; reserve their words.
      for (let i = 0; i < 8; i++) words.push(0);
      words.push(u32("viewport[0]", frame.viewport[0]), u32("viewport[1]", frame.viewport[1]));
      words.push(0, 0);
      if (frame.stereo) words.push(0, 0);
      break;
    case "full":
      pushStats(words, frame.stats);
      words.push(frame.ids.length);
      for (const id of frame.ids) words.push(u32("id", id));
      break;
    case "full_lod":
      pushStats(words, frame.stats);
      words.push(frame.ids.length);
      for (const id of frame.ids) words.push(u32("id", id));
      if (frame.levels.length !== frame.ids.length) throw new TypeError("one level per visible id");
      pushLevels(words, frame.levels);
      break;
    case "delta":
    case "delta_lod": {
      if (frame.added.length > MAX_DELTA_IDS || frame.removed.length > MAX_DELTA_IDS) {
        throw new TypeError(
          `a delta frame carries at most ${MAX_DELTA_IDS} ids per list, got ${frame.added.length} added and ${frame.removed.length} removed: send a full frame`,
        );
      }
      const lod = frame.kind === "delta_lod";
      pushStats(words, frame.stats);
      words.push((frame.added.length | (frame.removed.length << 16)) >>> 0);
      if (lod) words.push(frame.changed.length);
      for (const id of frame.added) words.push(u32("id", id));
      for (const id of frame.removed) words.push(u32("id", id));
      if (lod) {
        if (frame.added_levels.length !== frame.added.length || frame.changed_levels.length !== frame.changed.length) {
          throw new TypeError("one level per added and per changed id");
        }
        for (const id of frame.changed) words.push(u32("id", id));
        pushLevels(words, [...frame.added_levels, ...frame.changed_levels]);
      }
      break;
    }
    case "error":
      textBytes = utf8Encoder.encode(String(frame.message));
      words.push(u32("code", frame.code), textBytes.length);
      break;
    case "transforms":
      words.push(optionalBits("horizon_ms", frame.horizon_ms), frame.objects.length);
      for (const o of frame.objects) {
        if (o.matrix.length !== 12 || o.velocity.length !== 3 || o.angular_velocity.length !== 3) {
          throw new TypeError("a moved object needs 12 matrix numbers, 3 of velocity and 3 of angular velocity");
        }
        words.push(u32("id", o.id));
        for (const v of [...o.matrix, ...o.velocity, ...o.angular_velocity]) words.push(f32Bits("transform field", v));
        words.push(optionalBits("valid_ms", o.valid_ms));
      }
      break;
    case "applied": {
      const version = frame.version;
      if (!Number.isSafeInteger(version) || version < 0) throw new TypeError(`version must be a safe integer, got ${version}`);
      words.push(version % 2 ** 32, Math.floor(version / 2 ** 32), u32("applied", frame.applied));
      break;
    }
    case "region":
      for (const v of [...frame.centre, frame.radius_m, ...frame.axis, frame.turn_deg]) words.push(f32Bits("region field", v));
      break;
  }
  const textWords = textBytes ? Math.ceil(textBytes.length / 4) : 0;
  const payloadWords = words.length + textWords;
  const out = new Uint8Array((HEADER_WORDS + payloadWords) * 4);
  const view = new DataView(out.buffer);
  const ack = frame.kind === "hello" || frame.kind === "pose" || frame.kind === "transforms" ? 0 : u32("ack", frame.ack ?? 0);
  const header = [MAGIC, (PROTOCOL_VERSION | (kindCode << 16)) >>> 0, u32("seq", frame.seq), ack];
  header.forEach((w, i) => view.setUint32(i * 4, w, true));
  words.forEach((w, i) => view.setUint32((HEADER_WORDS + i) * 4, w, true));
  if (frame.kind === "pose") {
    const floats = [...frame.position, ...frame.rotation, frame.fov_y_deg];
    if (frame.position.length !== 3 || frame.rotation.length !== 4) {
      throw new TypeError("pose position needs 3 numbers and rotation 4");
    }
    floats.forEach((v, i) => view.setFloat32((HEADER_WORDS + 1 + i) * 4, num("pose field", v), true));
    view.setFloat32((HEADER_WORDS + 11) * 4, num("near", frame.near), true);
    view.setFloat32((HEADER_WORDS + 12) * 4, num("far", frame.far), true);
    if (frame.stereo) {
      view.setFloat32((HEADER_WORDS + 13) * 4, num("stereo.ipd_m", frame.stereo.ipd_m), true);
      view.setFloat32((HEADER_WORDS + 14) * 4, num("stereo.convergence_m", frame.stereo.convergence_m ?? 0), true);
    }
  }
  if (textBytes) out.set(textBytes, (HEADER_WORDS + words.length) * 4);
  return out;
}

const f32View = new DataView(new ArrayBuffer(4));

/** The IEEE-754 bits of `v` as an f32. */
function f32Bits(name, v) {
  f32View.setFloat32(0, num(name, v), true);
  return f32View.getUint32(0, true);
}

/** An optional f32: its bits, or NO_VALUE for null/undefined. */
function optionalBits(name, v) {
  return v === null || v === undefined ? NO_VALUE : f32Bits(name, v);
}

function num(name, v) {
  if (typeof v !== "number") throw new TypeError(`${name} must be a number, got ${typeof v}`);
  return v;
}

// Level bytes, four to a little-endian word, the last zero-padded.
function pushLevels(words, levels) {
  for (let i = 0; i < levels.length; i += 4) {
    let w = 0;
    for (let k = 0; k < 4 && i + k < levels.length; k++) w |= (levels[i + k] & 0xff) << (8 * k);
    words.push(w >>> 0);
  }
}

function pushStats(words, stats = {}) {
  for (const name of STATS_FIELDS) words.push(u32(`stats.${name}`, stats[name] ?? 0));
}

/**
 * Checks what `encodeFrame` does not: strictly ascending (and, for a delta, disjoint)
 * ID lists and the size limit; also that a delta's lists fit (at most `MAX_DELTA_IDS`
 * each, else DeltaTooLarge, which `encodeFrame` refuses with a TypeError). Throws the
 * `FrameError` that decoding would give.
 */
export function validateFrame(frame) {
  let payload;
  switch (frame.kind) {
    case "hello":
      payload = 2 + Math.ceil(utf8Encoder.encode(frame.info_json).length / 4);
      break;
    case "pose":
      payload = POSE_PAYLOAD_WORDS + (frame.stereo ? 2 : 0);
      break;
    case "full":
      payload = STATS_WORDS + 1 + frame.ids.length;
      break;
    case "full_lod":
      payload = STATS_WORDS + 1 + frame.ids.length + Math.ceil(frame.levels.length / 4);
      break;
    case "delta":
    case "delta_lod":
      if (frame.added.length > MAX_DELTA_IDS || frame.removed.length > MAX_DELTA_IDS) {
        throw new FrameError("DeltaTooLarge", { added: frame.added.length, removed: frame.removed.length });
      }
      payload = STATS_WORDS + 1 + frame.added.length + frame.removed.length;
      if (frame.kind === "delta_lod") {
        payload += 1 + frame.changed.length + Math.ceil((frame.added.length + frame.changed.length) / 4);
      }
      break;
    case "error":
      payload = 2 + Math.ceil(utf8Encoder.encode(frame.message).length / 4);
      break;
    case "transforms":
      payload = 2 + MOVED_OBJECT_WORDS * frame.objects.length;
      break;
    case "applied":
      payload = 3;
      break;
    case "region":
      payload = REGION_WORDS;
      break;
    default:
      kindCodeOf(frame.kind);
  }
  const len = (HEADER_WORDS + payload) * 4;
  if (len > MAX_FRAME_BYTES) throw new FrameError("TooLong", { len });
  if (frame.kind === "full_lod") checkLevels(frame.ids.length, frame.levels);
  if (frame.kind === "full" || frame.kind === "full_lod") checkAscending("full", frame.ids);
  if (frame.kind === "delta_lod") {
    checkLevels(frame.added.length, frame.added_levels);
    checkLevels(frame.changed.length, frame.changed_levels);
  }
  if (frame.kind === "delta" || frame.kind === "delta_lod") {
    checkAscending("added", frame.added);
    checkAscending("removed", frame.removed);
    checkDisjoint(frame.added, frame.removed);
  }
  if (frame.kind === "delta_lod") {
    checkAscending("changed", frame.changed);
    checkChanged(frame.changed, frame.added, frame.removed);
  }
  if (frame.kind === "transforms") checkAscending("transforms", frame.objects.map((o) => o.id));
}

/**
 * A Pose frame's bytes for `pose` ({position, rotation, fov_y_deg, viewport, near, far},
 * the defaults of the REST `Pose` filling in what is missing). The binary frame carries
 * only quaternions: a pose with `look_at` or `up` throws (like `PoseFrame::from_pose`).
 */
export function encodePose(seq, pose, wantFull = false) {
  return encodeFrame(poseFrame(seq, pose, wantFull));
}

/** The Pose frame object for `pose` (see `encodePose`). */
export function poseFrame(seq, pose, wantFull = false) {
  if (pose.look_at !== undefined || pose.up !== undefined) {
    throw new TypeError("binary pose frames carry only quaternions: convert look_at to a rotation");
  }
  return {
    kind: "pose",
    seq,
    ack: 0,
    want_full: Boolean(wantFull),
    position: pose.position,
    rotation: pose.rotation ?? [0, 0, 0, 1],
    fov_y_deg: pose.fov_y_deg ?? 60,
    viewport: pose.viewport ?? [960, 540],
    near: pose.near ?? 0.1,
    far: pose.far ?? 5000,
    ...(pose.stereo ? { stereo: pose.stereo } : {}),
  };
}
