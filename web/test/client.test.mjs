// The client library against a fake WebSocket, fake animation frames, fake timers and a
// fake clock: latest pose wins, at most one pose per animation frame, RTT by ack, delta
// application, reconnect with backoff and jitter, resync with a full frame, fatal errors.

import { test } from "node:test";
import assert from "node:assert/strict";

import { PROTOCOL_VERSION, decodeFrame, encodeFrame } from "../src/codec.js";
import { HomcullClient, State, backoffDelay, normalizePose, percentile } from "../src/client.js";

// The stats block of a frame as it travels, and as the client reports it for a visible set
// of 3 in a scene of 10 objects (the hello's object count), with what it derives.
const STATS = { candidates: 6, occluders_used: 2, dropped_poses: 0, gpu_us: 50, total_us: 90, scene_version: 0 };
const DERIVED = { objects: 10, ...STATS, culled_by_frustum: 4, culled_by_occlusion: 3 };

function harness({ fetchImpl, random = () => 0.5 } = {}) {
  const sockets = [];
  class FakeWebSocket {
    constructor(url) {
      this.url = url;
      this.sent = [];
      this.closed = null;
      sockets.push(this);
    }
    send(bytes) {
      this.sent.push(decodeFrame(bytes));
    }
    close(code, reason) {
      this.closed = { code, reason };
    }
    // Test side.
    receive(frame) {
      const bytes = encodeFrame(frame);
      this.onmessage?.({ data: bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength) });
    }
    receiveBytes(bytes) {
      this.onmessage?.({ data: bytes.buffer });
    }
    hello(info = { protocol_version: PROTOCOL_VERSION, adapter: "fake" }, objectCount = 10) {
      this.receive({ kind: "hello", seq: 0, ack: 0, object_count: objectCount, info_json: JSON.stringify(info) });
    }
    drop(code = 1006, reason = "") {
      this.onclose?.({ code, reason });
    }
  }
  let frames = [];
  const raf = (cb) => frames.push(cb);
  const tick = () => {
    const run = frames;
    frames = [];
    for (const cb of run) cb(0);
  };
  let timers = [];
  const setTimeout_ = (fn, ms) => {
    const t = { fn, ms };
    timers.push(t);
    return t;
  };
  const clearTimeout_ = (t) => {
    timers = timers.filter((x) => x !== t);
  };
  const runTimers = () => {
    const run = timers;
    timers = [];
    for (const t of run) t.fn();
    return run.map((t) => t.ms);
  };
  let clock = 1000;
  const events = [];
  const client = new HomcullClient({
    url: "http://127.0.0.1:9/",
    scene: "demo",
    params: { method: "hom" },
    WebSocket: FakeWebSocket,
    requestAnimationFrame: raf,
    setTimeout: setTimeout_,
    clearTimeout: clearTimeout_,
    now: () => clock,
    random,
    fetch: fetchImpl ?? (async () => ({ status: 200, ok: true, json: async () => ({ id: "demo" }) })),
  });
  for (const type of ["state", "hello", "visible", "stats", "error", "pose", "placements", "region"]) {
    client.addEventListener(type, (e) => events.push({ type, ...e.detail }));
  }
  return {
    client,
    sockets,
    tick,
    runTimers,
    events,
    pendingTimers: () => timers.map((t) => t.ms),
    advance: (ms) => (clock += ms),
    of: (type) => events.filter((e) => e.type === type),
    last: () => sockets[sockets.length - 1],
  };
}

const pose = (x, extra = {}) => ({ position: [x, 1.7, 0], rotation: [0, 0, 0, 1], viewport: [960, 540], fov_y_deg: 60, near: 0.1, far: 5000, ...extra });
const settle = () => new Promise((r) => setImmediate(r));

test("backoff grows exponentially, is capped and jittered", () => {
  const b = { initialMs: 100, maxMs: 1000, factor: 2, jitter: 0.5 };
  const mid = (n) => backoffDelay(n, b, () => 0.5);
  assert.deepEqual([1, 2, 3, 4, 5, 6, 20].map(mid), [100, 200, 400, 800, 1000, 1000, 1000]);
  assert.equal(backoffDelay(1, b, () => 0), 75);
  assert.ok(backoffDelay(1, b, () => 0.999999) < 125);
  assert.equal(backoffDelay(0, b, () => 0.5), 100, "attempt 0 counts as the first");
  const none = { ...b, jitter: 0 };
  assert.equal(backoffDelay(3, none, Math.random), 400);
});

test("percentile is nearest-rank", () => {
  assert.ok(Number.isNaN(percentile([], 50)));
  assert.equal(percentile([5], 95), 5);
  const v = Array.from({ length: 100 }, (_, i) => 100 - i);
  assert.equal(percentile(v, 50), 50);
  assert.equal(percentile(v, 95), 95);
  assert.equal(percentile(v, 100), 100);
});

test("normalizePose rounds to f32 and fills in REST defaults", () => {
  const p = normalizePose({ position: [0.1, 1.7, 1e-9] });
  assert.deepEqual(p, {
    position: [Math.fround(0.1), Math.fround(1.7), Math.fround(1e-9)],
    rotation: [0, 0, 0, 1],
    fov_y_deg: 60,
    viewport: [960, 540],
    near: Math.fround(0.1),
    far: 5000,
  });
  assert.throws(() => normalizePose({ position: [0, 0] }), TypeError);
  assert.throws(() => normalizePose({ position: [0, 0, 0], look_at: [1, 0, 0] }), TypeError);
});

test("connects to the stream URL and sends nothing before the hello", () => {
  const h = harness();
  h.client.connect();
  assert.equal(h.client.state, State.CONNECTING);
  assert.equal(h.last().url, "ws://127.0.0.1:9/v1/scenes/demo/stream?method=hom");
  h.client.setPose(pose(1));
  h.tick();
  assert.equal(h.last().sent.length, 0);
  h.last().hello();
  assert.equal(h.client.state, State.OPEN);
  assert.equal(h.client.hello.objectCount, 10);
  assert.equal(h.client.hello.info.adapter, "fake");
  // The pose set before the hello goes out at once, asking for a full frame.
  assert.equal(h.last().sent.length, 1);
  assert.equal(h.last().sent[0].want_full, true);
  assert.deepEqual(h.of("state").map((e) => e.state), ["connecting", "open"]);
});

test("a placements text message is surfaced with its version; other text is a protocol error", () => {
  const h = harness();
  h.client.connect();
  h.last().hello();
  const m = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 2, 0.5, 0, 1];
  h.last().onmessage?.({ data: JSON.stringify({ placements: { version: 3, objects: [{ id: 4, matrix: m }] } }) });
  assert.deepEqual(h.of("placements"), [{ type: "placements", version: 3, objects: [{ id: 4, matrix: m }] }]);
  assert.equal(h.client.sceneVersion, 3);
  h.last().onmessage?.({ data: "{\"something\": 1}" });
  h.last().onmessage?.({ data: "not json" });
  const errors = h.of("error");
  assert.equal(errors.length, 2);
  assert.ok(errors.every((e) => e.code === "protocol" && !e.fatal));
  assert.equal(h.client.state, State.OPEN);
});

test("latest pose wins: at most one pose per animation frame, unchanged poses not resent", () => {
  const h = harness();
  h.client.connect();
  h.last().hello();
  const ws = h.last();
  h.client.setPose(pose(1)); // gate open: sent at once
  assert.equal(ws.sent.length, 1);
  assert.equal(ws.sent[0].seq, 1);
  assert.equal(ws.sent[0].want_full, true, "first pose after hello resyncs");
  h.client.setPose(pose(2));
  h.client.setPose(pose(3));
  h.client.setPose(pose(4));
  assert.equal(ws.sent.length, 1, "the gate is closed until the next animation frame");
  h.tick();
  assert.equal(ws.sent.length, 2);
  assert.equal(ws.sent[1].seq, 2);
  assert.deepEqual(ws.sent[1].position, [4, Math.fround(1.7), 0], "only the latest pose is sent");
  assert.equal(ws.sent[1].want_full, false);
  h.tick();
  h.tick();
  assert.equal(ws.sent.length, 2, "nothing new to send");
  h.client.setPose(pose(4));
  h.tick();
  assert.equal(ws.sent.length, 2, "an unchanged pose is not resent");
  // A pose changed and changed back before the frame is not sent either.
  h.client.setPose(pose(5));
  assert.equal(ws.sent.length, 3);
  h.client.setPose(pose(6));
  h.client.setPose(pose(5));
  h.tick();
  assert.equal(ws.sent.length, 3);
  // requestFull resends the current pose with the flag, once.
  h.client.requestFull();
  h.tick();
  assert.equal(ws.sent.length, 4);
  assert.equal(ws.sent[3].want_full, true);
  assert.deepEqual(ws.sent[3].position, ws.sent[2].position);
  h.tick();
  assert.equal(ws.sent.length, 4);
  // Viewport, fov, near and far are part of the pose.
  h.client.setPose(pose(5, { viewport: [800, 600] }));
  h.tick();
  assert.equal(ws.sent.length, 5);
  assert.deepEqual(ws.sent[4].viewport, [800, 600]);
  assert.deepEqual(h.of("pose").map((e) => e.seq), [1, 2, 3, 4, 5]);
});

test("a region frame is surfaced and held until the next one; the set follows it", () => {
  const h = harness();
  h.client.connect();
  const ws = h.last();
  ws.hello();
  h.client.setPose(pose(1));
  const region = { centre: [1, Math.fround(1.7), 0], radius_m: 0.5, axis: [0, 0, -1], turn_deg: 15 };
  ws.receive({ kind: "region", seq: 1, ack: 1, ...region });
  ws.receive({ kind: "full", seq: 2, ack: 1, stats: STATS, ids: [1, 4, 7] });
  assert.deepEqual(h.of("region"), [{ type: "region", ...region, ack: 1 }]);
  assert.deepEqual(h.client.region, { ...region, ack: 1 });
  assert.deepEqual(h.client.visible.ids, [1, 4, 7]);
  assert.equal(h.of("error").length, 0, "a region frame is no protocol error");
});

test("full and delta frames update the visible set; RTT is measured per pose by ack", () => {
  const h = harness();
  h.client.connect();
  const ws = h.last();
  ws.hello();
  h.client.setPose(pose(1)); // seq 1 at t=1000
  h.advance(30);
  ws.receive({ kind: "full", seq: 1, ack: 1, stats: STATS, ids: [1, 4, 7] });
  let v = h.of("visible").at(-1);
  assert.deepEqual(v.ids, [1, 4, 7]);
  assert.deepEqual(v.added, [1, 4, 7]);
  assert.equal(v.full, true);
  assert.equal(v.rttMs, 30);
  assert.deepEqual(v.stats, DERIVED, "stats with objects and the culled counts derived");
  assert.deepEqual(v.pose.position, [1, Math.fround(1.7), 0]);
  assert.ok(h.client.visible.has(4));

  h.tick();
  h.client.setPose(pose(2)); // seq 2 at 1030
  h.tick();
  h.advance(5);
  h.client.setPose(pose(3)); // seq 3 at 1035
  h.advance(15);
  // The server dropped seq 2 (superseded) and answers seq 3 with a delta.
  ws.receive({ kind: "delta", seq: 2, ack: 3, stats: { ...STATS, dropped_poses: 1 }, added: [2], removed: [4] });
  v = h.of("visible").at(-1);
  assert.deepEqual(v.ids, [1, 2, 7]);
  assert.deepEqual(v.added, [2]);
  assert.deepEqual(v.removed, [4]);
  assert.equal(v.full, false);
  assert.equal(v.rttMs, 15);
  assert.equal(v.ack, 3);
  assert.deepEqual(v.stats, { ...DERIVED, dropped_poses: 1 });
  assert.equal(h.client._inFlight.size, 0, "answered and superseded poses are forgotten");
  const s = h.of("stats").at(-1);
  assert.equal(s.rtt.count, 2);
  assert.equal(s.rtt.p50, 15);
  assert.equal(s.rtt.p95, 30);
  assert.deepEqual(s.stats, { ...DERIVED, dropped_poses: 1 });
  assert.deepEqual(h.client.lastFrame, { ack: 3, seq: 2, full: false, stats: { ...DERIVED, dropped_poses: 1 }, rttMs: 15 });
});

test("a delta that does not apply is reported and triggers a full resync", () => {
  const h = harness();
  h.client.connect();
  const ws = h.last();
  ws.hello();
  h.client.setPose(pose(1));
  ws.receive({ kind: "full", seq: 1, ack: 1, stats: STATS, ids: [1, 4] });
  h.tick();
  ws.receive({ kind: "delta", seq: 2, ack: 1, stats: STATS, added: [], removed: [9] });
  assert.equal(h.of("error").at(-1).code, "bad_delta");
  assert.deepEqual(h.client.visible.ids, [1, 4], "a failed delta leaves the set alone");
  assert.equal(ws.sent.at(-1).want_full, true);
  assert.equal(ws.sent.length, 2);
  // Deltas before the resyncing full frame are not applied.
  ws.receive({ kind: "delta", seq: 3, ack: 1, stats: STATS, added: [2], removed: [] });
  assert.deepEqual(h.client.visible.ids, [1, 4]);
  ws.receive({ kind: "full", seq: 4, ack: 2, stats: STATS, ids: [2, 3] });
  assert.deepEqual(h.client.visible.ids, [2, 3]);
});

test("lost connection: reconnect with backoff and jitter, then resync with a full frame", async () => {
  const rolls = [0, 1 - 1e-9, 0.5];
  const h = harness({ random: () => rolls.shift() ?? 0.5 });
  h.client.connect();
  h.last().hello();
  h.client.setPose(pose(1));
  h.last().receive({ kind: "full", seq: 1, ack: 1, stats: STATS, ids: [1, 2] });
  h.last().drop(1006);
  assert.equal(h.client.state, State.RECONNECTING);
  assert.equal(h.of("error").at(-1).code, "connection");
  assert.deepEqual(h.pendingTimers(), [250 * 0.75], "first retry after 250 ms minus the jitter");
  h.runTimers();
  assert.equal(h.sockets.length, 2);
  assert.equal(h.client.state, State.CONNECTING);
  // The retry fails before a hello: the client asks the REST API why, then backs off more.
  h.last().drop(1006);
  await settle();
  assert.equal(h.client.state, State.RECONNECTING);
  assert.deepEqual(h.pendingTimers(), [500 * (1 - 0.25 + 0.5 * (1 - 1e-9))]);
  h.runTimers();
  h.last().drop(1006);
  await settle();
  assert.deepEqual(h.pendingTimers(), [1000]);
  assert.equal(h.client.attempt, 3);
  h.runTimers();
  const ws = h.last();
  assert.equal(h.sockets.length, 4);
  h.tick();
  assert.equal(ws.sent.length, 0);
  ws.hello();
  assert.equal(h.client.attempt, 0, "a hello resets the backoff");
  assert.equal(ws.sent.length, 1, "the latest pose is resent at once");
  assert.equal(ws.sent[0].want_full, true, "asking for a full frame");
  assert.deepEqual(ws.sent[0].position, [1, Math.fround(1.7), 0]);
  // The old set stays until the new full frame replaces it.
  assert.deepEqual(h.client.visible.ids, [1, 2]);
  ws.receive({ kind: "full", seq: 1, ack: ws.sent[0].seq, stats: STATS, ids: [2, 5] });
  const v = h.of("visible").at(-1);
  assert.deepEqual(v.ids, [2, 5]);
  assert.deepEqual(v.added, [5]);
  assert.deepEqual(v.removed, [1]);
  assert.deepEqual(
    h.of("state").map((e) => e.state),
    ["connecting", "open", "reconnecting", "connecting", "reconnecting", "connecting", "reconnecting", "connecting", "open"],
  );
  // The unreachable-server diagnosis was reported.
  assert.ok(h.of("error").some((e) => /refused or dropped/.test(e.message)));
  h.client.close();
  assert.equal(h.client.state, State.CLOSED);
  assert.deepEqual(ws.closed, { code: 1000, reason: "client closed" });
  assert.deepEqual(h.pendingTimers(), []);
});

test("server unreachable is reported and retried; unknown scene is fatal", async () => {
  const down = harness({
    fetchImpl: async () => {
      throw new TypeError("fetch failed");
    },
  });
  down.client.connect();
  down.last().drop(1006);
  await settle();
  const err = down.of("error").at(-1);
  assert.equal(err.code, "connection");
  assert.equal(err.fatal, false);
  assert.match(err.message, /server unreachable at http:\/\/127\.0\.0\.1:9/);
  assert.equal(down.client.state, State.RECONNECTING);

  const unknown = harness({
    fetchImpl: async () => ({
      status: 404,
      ok: false,
      json: async () => ({ error: { code: "unknown_scene", message: "no scene with id `demo`" } }),
    }),
  });
  unknown.client.connect();
  unknown.last().drop(1006);
  await settle();
  const e = unknown.of("error").at(-1);
  assert.deepEqual([e.code, e.fatal, e.message], ["unknown_scene", true, "no scene with id `demo`"]);
  assert.equal(unknown.client.state, State.FAILED);
  assert.deepEqual(unknown.pendingTimers(), [], "no retry after a fatal error");
});

test("protocol mismatch and fatal error frames stop the client; other errors do not", () => {
  const h = harness();
  h.client.connect();
  const bytes = encodeFrame({ kind: "hello", seq: 0, ack: 0, object_count: 1, info_json: "{}" });
  // Header word 1 of a version 1 frame is its version alone (the kind had its own word).
  new DataView(bytes.buffer).setUint32(4, 1, true);
  h.last().receiveBytes(bytes);
  const e = h.of("error").at(-1);
  assert.equal(e.fatal, true);
  assert.match(e.message, new RegExp(`protocol mismatch: the server speaks version 1, this client version ${PROTOCOL_VERSION}`));
  assert.equal(h.client.state, State.FAILED);
  assert.equal(h.last().closed.code, 1000);

  const j = harness();
  j.client.connect();
  j.last().hello({ protocol_version: 7 });
  assert.equal(j.client.state, State.FAILED);
  assert.match(j.of("error").at(-1).message, /version 7/);

  const k = harness();
  k.client.connect();
  const ws = k.last();
  ws.hello();
  k.client.setPose(pose(1));
  ws.receive({ kind: "error", seq: 1, ack: 1, code: 3, message: "fov_y_deg must be in (0, 179], got 200" });
  assert.deepEqual(
    (({ code, fatal, ack }) => ({ code, fatal, ack }))(k.of("error").at(-1)),
    { code: "invalid_pose", fatal: false, ack: 1 },
  );
  assert.equal(k.client.state, State.OPEN);
  // Overloaded: the latest pose is tried again after a pause.
  k.tick();
  ws.receive({ kind: "error", seq: 2, ack: 1, code: 4, message: "busy" });
  assert.deepEqual(k.pendingTimers(), [250]);
  k.runTimers();
  assert.equal(ws.sent.length, 2);
  assert.deepEqual(ws.sent[1].position, ws.sent[0].position);
  // Garbage from the server is reported, not fatal.
  ws.receiveBytes(new Uint8Array(8));
  assert.equal(k.of("error").at(-1).code, "protocol");
  assert.equal(k.client.state, State.OPEN);
  ws.onmessage({ data: "text" });
  assert.equal(k.of("error").at(-1).code, "protocol");
  // unknown_scene from the server is fatal.
  ws.receive({ kind: "error", seq: 3, ack: 0, code: 6, message: "scene deleted" });
  assert.equal(k.client.state, State.FAILED);
  assert.equal(k.of("error").at(-1).code, "unknown_scene");
});

test("close() stops everything and no reconnect follows", () => {
  const h = harness();
  h.client.connect();
  h.last().hello();
  const ws = h.last();
  h.client.close();
  ws.drop(1000);
  assert.equal(h.client.state, State.CLOSED);
  assert.deepEqual(h.pendingTimers(), []);
  assert.equal(h.sockets.length, 1);
  h.client.setPose(pose(3));
  h.tick();
  assert.equal(ws.sent.length, 0);
  // connect() again opens a new connection.
  h.client.connect();
  assert.equal(h.sockets.length, 2);
});

test("a pose left unanswered for stallTimeoutMs drops the connection and reconnects", () => {
  const h = harness();
  h.client.connect();
  const ws = h.last();
  ws.hello();
  h.client.setPose(pose(1));
  assert.deepEqual(h.pendingTimers(), [15000], "the watchdog is armed by the send");
  ws.receive({ kind: "full", seq: 1, ack: 1, stats: STATS, ids: [1] });
  assert.deepEqual(h.pendingTimers(), [], "and disarmed by any frame");
  h.tick();
  h.client.setPose(pose(2));
  assert.deepEqual(h.pendingTimers(), [15000]);
  h.runTimers(); // 15 s without an answer
  assert.equal(ws.closed.code, 4000);
  assert.match(h.of("error").at(-1).message, /no answer from the server for 15\.0 s/);
  assert.equal(h.client.state, State.RECONNECTING);
  assert.deepEqual(h.pendingTimers(), [250], "reconnects after the first backoff step");
  h.runTimers();
  h.last().hello();
  h.tick(); // the pose sent just before the stall closed this animation frame's gate
  assert.equal(h.last().sent.length, 1);
  assert.equal(h.last().sent[0].want_full, true);
  assert.deepEqual(h.last().sent[0].position, [2, Math.fround(1.7), 0]);
});
