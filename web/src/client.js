// homcull client library: a visibility stream over a WebSocket.
//
// Plain ES module, no dependencies besides ./codec.js and ./visible.js, usable without
// the viewer (in a browser, or in Node with any WebSocket implementation passed in).
// See web/README.md for the API.

import {
  ErrorCode,
  FrameError,
  PROTOCOL_VERSION,
  decodeFrame,
  deriveStats,
  encodePose,
  errorCodeName,
} from "./codec.js";
import { VisibleSet } from "./visible.js";

/** Connection states, in the order a healthy connection goes through them. */
export const State = Object.freeze({
  IDLE: "idle", // constructed, connect() not called yet
  CONNECTING: "connecting", // socket opening, or open and waiting for the server's Hello
  OPEN: "open", // Hello received: poses are sent and answered
  RECONNECTING: "reconnecting", // connection lost, waiting for the backoff timer
  CLOSED: "closed", // close() was called
  FAILED: "failed", // a fatal error (unknown scene, protocol mismatch): no more retries
});

/** Default reconnect backoff: delays 250 ms, 500 ms, 1 s, ... up to 8 s, ±25 % jitter. */
export const DEFAULT_BACKOFF = Object.freeze({ initialMs: 250, maxMs: 8000, factor: 2, jitter: 0.5 });

/**
 * Delay before reconnect attempt `attempt` (1 for the first retry): exponential in the
 * attempt, capped at `maxMs`, then scaled by a random factor in
 * [1 - jitter/2, 1 + jitter/2) so that many clients dropped at once do not come back in
 * lockstep. `random` returns a number in [0, 1).
 */
export function backoffDelay(attempt, backoff = DEFAULT_BACKOFF, random = Math.random) {
  const b = { ...DEFAULT_BACKOFF, ...backoff };
  const n = Math.max(1, attempt);
  const base = Math.min(b.maxMs, b.initialMs * b.factor ** (n - 1));
  return base * (1 - b.jitter / 2 + b.jitter * random());
}

/** The `p`-th percentile (0..100, nearest rank) of `values`; NaN if empty. */
export function percentile(values, p) {
  if (values.length === 0) return NaN;
  const sorted = Float64Array.from(values).sort();
  const rank = Math.ceil((p / 100) * sorted.length);
  return sorted[Math.min(sorted.length - 1, Math.max(0, rank - 1))];
}

const f32 = Math.fround;

/**
 * The pose as it travels: every float rounded to f32, defaults of the REST `Pose` filled
 * in. This is exactly what the server culls for.
 */
export function normalizePose(pose) {
  if (!pose || !Array.isArray(pose.position) || pose.position.length !== 3) {
    throw new TypeError("pose.position must be [x, y, z]");
  }
  if (pose.look_at !== undefined || pose.up !== undefined) {
    throw new TypeError("the stream carries quaternions only: give pose.rotation, not look_at/up");
  }
  const rotation = pose.rotation ?? [0, 0, 0, 1];
  if (!Array.isArray(rotation) || rotation.length !== 4) throw new TypeError("pose.rotation must be [x, y, z, w]");
  const viewport = pose.viewport ?? [960, 540];
  return {
    position: pose.position.map((v) => f32(v)),
    rotation: rotation.map((v) => f32(v)),
    fov_y_deg: f32(pose.fov_y_deg ?? 60),
    viewport: [Math.round(viewport[0]) >>> 0, Math.round(viewport[1]) >>> 0],
    near: f32(pose.near ?? 0.1),
    far: f32(pose.far ?? 5000),
    ...(pose.stereo
      ? {
          stereo: {
            ipd_m: f32(pose.stereo.ipd_m),
            ...(pose.stereo.convergence_m !== undefined ? { convergence_m: f32(pose.stereo.convergence_m) } : {}),
          },
        }
      : {}),
  };
}

function samePose(a, b) {
  if (!a || !b) return false;
  const eq = (x, y) => x.length === y.length && x.every((v, i) => Object.is(v, y[i]));
  return (
    eq(a.position, b.position) &&
    eq(a.rotation, b.rotation) &&
    eq(a.viewport, b.viewport) &&
    Object.is(a.fov_y_deg, b.fov_y_deg) &&
    Object.is(a.near, b.near) &&
    Object.is(a.far, b.far) &&
    Object.is(a.stereo?.ipd_m, b.stereo?.ipd_m) &&
    Object.is(a.stereo?.convergence_m, b.stereo?.convergence_m)
  );
}

function defaultBaseUrl() {
  return typeof location !== "undefined" && location.origin && location.origin !== "null"
    ? location.origin
    : "http://127.0.0.1:8080";
}

/**
 * A client of one scene's visibility stream.
 *
 * Events (an EventTarget; each event is a CustomEvent with `detail`):
 * - `state`   {state, previous, attempt, delayMs?}: the connection state changed.
 * - `hello`   {objectCount, info}: the server's Hello (info: parsed info_json).
 * - `visible` {ack, seq, full, ids, added, removed, changed, stats, rttMs, pose}: a new
 *             visible set (ids: strictly ascending array; added/removed: change since
 *             the last; changed: kept IDs whose level of detail changed, on a stream with
 *             `lod_px`, see `visible.level(id)`;
 *             stats: the frame's stats block plus `objects`, `culled_by_frustum` and
 *             `culled_by_occlusion`, derived from the Hello and the set, see `deriveStats`).
 * - `stats`   {ack, stats, rttMs, rtt: {p50, p95, count}}: after every visible event.
 * - `error`   {code, message, fatal, ack?}: something went wrong; `code` is the Error
 *             frame's name (`invalid_pose`, ...) or one of `connection`, `protocol`,
 *             `unknown_scene`, `bad_delta`.
 * - `pose`    {seq, pose, wantFull}: a pose frame was sent.
 */
export class HomcullClient extends EventTarget {
  /**
   * @param {object} opts
   * @param {string} [opts.url] base URL of the server (http/https; default: the page's origin)
   * @param {string} [opts.scene] scene id (default `demo`)
   * @param {object} [opts.params] stream query options: {method, threshold, deb,
   *   lookahead_ms, hold_ms, lod_px} (lookahead_ms and hold_ms make the stream a superset
   *   of the pose's cull; lod_px adds a level of detail per visible object)
   * @param {Function} [opts.WebSocket] WebSocket constructor (default: the global one)
   * @param {Function} [opts.requestAnimationFrame] frame scheduler (default: the global one, else a 16 ms timer)
   * @param {Function} [opts.fetch] used to explain a failed connection (default: the global one)
   * @param {object} [opts.backoff] {initialMs, maxMs, factor, jitter}
   * @param {boolean} [opts.reconnect] reconnect after a lost connection (default true)
   * @param {number} [opts.rttWindow] RTT samples kept for the percentiles (default 200)
   * @param {number} [opts.stallTimeoutMs] reconnect if a pose gets no frame back for this long (default 15000; 0: never)
   */
  constructor(opts = {}) {
    super();
    this.url = (opts.url ?? defaultBaseUrl()).replace(/\/+$/, "");
    this.scene = opts.scene ?? "demo";
    this.params = opts.params ?? {};
    this.backoff = { ...DEFAULT_BACKOFF, ...(opts.backoff ?? {}) };
    this.reconnect = opts.reconnect ?? true;
    this.rttWindow = opts.rttWindow ?? 200;
    this.stallTimeoutMs = opts.stallTimeoutMs ?? 15000;
    this._WebSocket = opts.WebSocket ?? globalThis.WebSocket;
    const raf = opts.requestAnimationFrame ?? globalThis.requestAnimationFrame?.bind(globalThis);
    this._raf = raf ?? ((cb) => setTimeout(() => cb(Date.now()), 16));
    this._fetch = opts.fetch ?? globalThis.fetch?.bind(globalThis);
    this._now = opts.now ?? (() => globalThis.performance?.now() ?? Date.now());
    this._random = opts.random ?? Math.random;
    this._setTimeout = opts.setTimeout ?? globalThis.setTimeout.bind(globalThis);
    this._clearTimeout = opts.clearTimeout ?? globalThis.clearTimeout.bind(globalThis);

    /** Current connection state (see `State`). */
    this.state = State.IDLE;
    /** The visible set (a `VisibleSet`). */
    this.visible = new VisibleSet();
    /** The server's Hello: {objectCount, info}, or null before the first one. */
    this.hello = null;
    /** The last pose sent: {seq, pose, wantFull, sentAt}, or null. */
    this.lastSent = null;
    /** The last Full/Delta applied: {ack, seq, full, stats, rttMs}, or null. */
    this.lastFrame = null;
    /** Reconnect attempts since the last successful Hello. */
    this.attempt = 0;

    this._ws = null;
    this._seq = 0;
    this._pose = null; // latest pose given to setPose (normalized)
    this._dirty = false; // _pose differs from what was last sent on this connection
    this._wantFull = false; // the next pose asks for a full frame
    this._gateClosed = false; // a pose was sent since the last animation frame
    this._inFlight = new Map(); // seq -> {sentAt, pose}
    this._rtts = [];
    this._haveBase = false; // a Full frame arrived on this connection
    this._timer = null;
    this._retryTimer = null;
    this._stallTimer = null;
    this._fatal = false;
  }

  /** Stream URL (ws/wss) for the scene and options. */
  get streamUrl() {
    const u = new URL(`${this.url}/v1/scenes/${encodeURIComponent(this.scene)}/stream`);
    u.protocol = u.protocol === "https:" ? "wss:" : "ws:";
    for (const [k, v] of Object.entries(this.params)) if (v !== undefined && v !== null) u.searchParams.set(k, String(v));
    return u.toString();
  }

  /** Opens the connection (no-op if already connecting or open). Returns this. */
  connect() {
    if (this.state === State.CONNECTING || this.state === State.OPEN) return this;
    this._fatal = false;
    this._open();
    return this;
  }

  /** Closes the connection for good (no reconnect). */
  close() {
    this._cancelTimers();
    const ws = this._ws;
    this._ws = null;
    if (ws) {
      detach(ws);
      try {
        ws.close(1000, "client closed");
      } catch {
        /* already closed */
      }
    }
    this._setState(State.CLOSED);
  }

  /**
   * Sets the camera pose ({position, rotation, fov_y_deg, viewport, near, far}; missing
   * fields take the REST defaults). The latest pose wins: it is sent at once if no pose
   * was sent since the last animation frame, else on the next animation frame, and only
   * if it differs from the last pose sent. Returns the normalized (f32) pose.
   */
  setPose(pose) {
    const p = normalizePose(pose);
    this._pose = p;
    this._dirty = !samePose(p, this.lastSent?.pose);
    this._pump();
    return p;
  }

  /** Asks for a full frame with the next pose (sent even if the pose did not change). */
  requestFull() {
    this._wantFull = true;
    this._pump();
  }

  /** RTT percentiles over the last `rttWindow` answered poses, in ms. */
  rtt() {
    return { p50: percentile(this._rtts, 50), p95: percentile(this._rtts, 95), count: this._rtts.length };
  }

  // --- sending -------------------------------------------------------------------------

  /** Sends the latest pose if one is due and the per-frame gate is open. */
  _pump() {
    if (this.state !== State.OPEN || !this._ws || !this._pose) return;
    if (!this._dirty && !this._wantFull) return;
    if (this._gateClosed) return; // the animation-frame callback will pump again
    this._send();
  }

  _send() {
    const pose = this._pose;
    const wantFull = this._wantFull;
    this._seq = this._seq >= 0xffffffff ? 1 : this._seq + 1;
    const seq = this._seq;
    const bytes = encodePose(seq, pose, wantFull);
    try {
      this._ws.send(bytes);
    } catch (e) {
      this._emit("error", { code: "connection", message: `send failed: ${e?.message ?? e}`, fatal: false });
      return;
    }
    const sentAt = this._now();
    this._inFlight.set(seq, { sentAt, pose });
    // Poses never answered (dropped as superseded) must not pile up.
    if (this._inFlight.size > 1024) this._inFlight.delete(this._inFlight.keys().next().value);
    this.lastSent = { seq, pose, wantFull, sentAt };
    this._dirty = false;
    this._wantFull = false;
    this._gateClosed = true;
    if (this._stallTimer === null && this.stallTimeoutMs > 0) {
      this._stallTimer = this._setTimeout(() => this._onStall(), this.stallTimeoutMs);
    }
    this._raf(() => {
      this._gateClosed = false;
      this._pump();
    });
    this._emit("pose", { seq, pose, wantFull });
  }

  // --- connection ----------------------------------------------------------------------

  _open() {
    this._cancelTimers();
    this._setState(State.CONNECTING);
    let ws;
    try {
      ws = new this._WebSocket(this.streamUrl);
    } catch (e) {
      this._emit("error", { code: "connection", message: `cannot open ${this.streamUrl}: ${e?.message ?? e}`, fatal: false });
      this._lost(false);
      return;
    }
    ws.binaryType = "arraybuffer";
    this._ws = ws;
    this._haveBase = false;
    this._gotHello = false;
    ws.onmessage = (ev) => this._onMessage(ev.data);
    ws.onclose = (ev) => {
      if (this._ws !== ws) return;
      this._ws = null;
      detach(ws);
      this._onClose(ev);
    };
    ws.onerror = () => {
      /* a close event follows */
    };
  }

  _onClose(ev) {
    if (this._fatal) {
      this._setState(State.FAILED);
      return;
    }
    const hadHello = this._gotHello;
    if (hadHello) {
      const why = ev?.reason ? `: ${ev.reason}` : "";
      this._emit("error", {
        code: "connection",
        message: `connection to the server lost (code ${ev?.code ?? "?"}${why}); reconnecting`,
        fatal: false,
      });
      this._lost(true);
    } else {
      this._diagnose().then((d) => {
        if (this._ws || this.state === State.CLOSED) return; // reconnected or closed meanwhile
        this._emit("error", d);
        if (d.fatal) {
          this._fatal = true;
          this._setState(State.FAILED);
        } else this._lost(false);
      });
    }
  }

  /** Explains why a connection never got a Hello, asking the REST API about the scene. */
  async _diagnose() {
    const what = `cannot connect to the visibility stream at ${this.streamUrl}`;
    if (!this._fetch) return { code: "connection", message: what, fatal: false };
    try {
      const r = await this._fetch(`${this.url}/v1/scenes/${encodeURIComponent(this.scene)}`);
      let body = null;
      try {
        body = await r.json();
      } catch {
        /* not JSON */
      }
      const msg = body?.error?.message;
      if (r.status === 404 && (body?.error?.code === "unknown_scene" || !body?.error)) {
        return { code: "unknown_scene", message: msg ?? `unknown scene ${this.scene}`, fatal: true };
      }
      if (!r.ok) return { code: "connection", message: `${what}: HTTP ${r.status}${msg ? ` (${msg})` : ""}`, fatal: false };
      return { code: "connection", message: `${what} (the scene exists; the server refused or dropped the stream)`, fatal: false };
    } catch (e) {
      return { code: "connection", message: `server unreachable at ${this.url} (${e?.message ?? e})`, fatal: false };
    }
  }

  /** A pose went unanswered for `stallTimeoutMs`: drop the connection and start over. */
  _onStall() {
    this._stallTimer = null;
    const ws = this._ws;
    if (!ws || this.state !== State.OPEN) return;
    this._ws = null;
    detach(ws);
    try {
      ws.close(4000, "no answer");
    } catch {
      /* ignore */
    }
    const secs = (this.stallTimeoutMs / 1000).toFixed(1);
    this._emit("error", { code: "connection", message: `no answer from the server for ${secs} s; reconnecting`, fatal: false });
    this._lost(true);
  }

  /** The connection is gone: schedule a reconnect (or stop). */
  _lost(wasOpen) {
    this._clearStall();
    this._inFlight.clear();
    this._haveBase = false;
    if (!this.reconnect || this.state === State.CLOSED) {
      this._setState(State.CLOSED);
      return;
    }
    if (wasOpen) this.attempt = 0;
    this.attempt += 1;
    const delayMs = backoffDelay(this.attempt, this.backoff, this._random);
    this._setState(State.RECONNECTING, { delayMs });
    this._retryTimer = this._setTimeout(() => {
      this._retryTimer = null;
      this._open();
    }, delayMs);
  }

  _fail(code, message) {
    this._fatal = true;
    this._emit("error", { code, message, fatal: true });
    const ws = this._ws;
    this._ws = null;
    if (ws) {
      detach(ws);
      try {
        ws.close(1000, "client gave up");
      } catch {
        /* ignore */
      }
    }
    this._cancelTimers();
    this._setState(State.FAILED);
  }

  // --- receiving -----------------------------------------------------------------------

  _onMessage(data) {
    this._clearStall();
    if (typeof data === "string") {
      // The one text message a server sends: where moved objects are (`?placements=true`).
      let msg = null;
      try {
        msg = JSON.parse(data);
      } catch {
        /* reported below */
      }
      const p = msg?.placements;
      if (p && Number.isFinite(p.version) && Array.isArray(p.objects)) {
        this.sceneVersion = p.version;
        this._emit("placements", { version: p.version, objects: p.objects });
      } else {
        this._emit("error", { code: "protocol", message: "unexpected text message from the server", fatal: false });
      }
      return;
    }
    let frame;
    try {
      frame = decodeFrame(data);
    } catch (e) {
      if (e instanceof FrameError && e.variant === "UnsupportedVersion") {
        this._fail(
          "protocol",
          `protocol mismatch: the server speaks version ${e.fields.found}, this client version ${PROTOCOL_VERSION}; reload the page or update the client`,
        );
      } else {
        this._emit("error", { code: "protocol", message: `bad frame from the server: ${e.message}`, fatal: false });
        this._haveBase = false;
        this.requestFull();
      }
      return;
    }
    if (!this._gotHello && frame.kind !== "hello") {
      this._emit("error", { code: "protocol", message: `expected a hello frame first, got ${frame.kind}`, fatal: false });
      return;
    }
    switch (frame.kind) {
      case "hello":
        return this._onHello(frame);
      case "full":
      case "delta":
      case "full_lod":
      case "delta_lod":
        return this._onVisible(frame);
      case "error":
        return this._onError(frame);
      case "region":
        // A region stream (`?region_m=`): the next set holds for this region.
        this.region = { centre: frame.centre, radius_m: frame.radius_m, axis: frame.axis, turn_deg: frame.turn_deg, ack: frame.ack };
        return this._emit("region", this.region);
      default:
        this._emit("error", { code: "protocol", message: `unexpected ${frame.kind} frame from the server`, fatal: false });
    }
  }

  _onHello(frame) {
    let info = {};
    try {
      info = JSON.parse(frame.info_json);
    } catch {
      this._emit("error", { code: "protocol", message: "hello info is not JSON", fatal: false });
    }
    if (info.protocol_version !== undefined && info.protocol_version !== PROTOCOL_VERSION) {
      this._fail(
        "protocol",
        `protocol mismatch: the server speaks version ${info.protocol_version}, this client version ${PROTOCOL_VERSION}`,
      );
      return;
    }
    this._gotHello = true;
    this.hello = { objectCount: frame.object_count, info };
    this.attempt = 0;
    this._inFlight.clear();
    this._haveBase = false;
    // Resynchronise: the next pose (the current one, even if unchanged) asks for a full frame.
    this._wantFull = true;
    this._setState(State.OPEN);
    this._emit("hello", { objectCount: frame.object_count, info });
    this._pump();
  }

  _onVisible(frame) {
    let change;
    const full = frame.kind === "full" || frame.kind === "full_lod";
    if (full) {
      change = this.visible.replace(frame.ids, frame.levels ?? null);
      this._haveBase = true;
    } else {
      if (!this._haveBase) {
        this.requestFull();
        return;
      }
      try {
        const lod =
          frame.kind === "delta_lod"
            ? { added_levels: frame.added_levels, changed: frame.changed, changed_levels: frame.changed_levels }
            : null;
        change = this.visible.apply(frame.added, frame.removed, lod);
      } catch (e) {
        this._haveBase = false;
        this._emit("error", { code: "bad_delta", message: `delta does not apply: ${e.message}; resynchronising`, fatal: false });
        this.requestFull();
        return;
      }
    }
    const sent = this._inFlight.get(frame.ack);
    const rttMs = sent ? this._now() - sent.sentAt : null;
    this._settle(frame.ack);
    if (rttMs !== null) {
      this._rtts.push(rttMs);
      if (this._rtts.length > this.rttWindow) this._rtts.splice(0, this._rtts.length - this.rttWindow);
    }
    const stats = deriveStats(frame.stats, this.hello.objectCount, this.visible.size);
    this.lastFrame = { ack: frame.ack, seq: frame.seq, full, stats, rttMs };
    this._emit("visible", {
      ack: frame.ack,
      seq: frame.seq,
      full,
      ids: this.visible.ids,
      added: change.added,
      removed: change.removed,
      changed: change.changed,
      stats,
      rttMs,
      pose: sent?.pose ?? null,
    });
    this._emit("stats", { ack: frame.ack, stats, rttMs, rtt: this.rtt() });
  }

  _onError(frame) {
    const fatal = frame.code === ErrorCode.UNKNOWN_SCENE || frame.code === ErrorCode.UNSUPPORTED_VERSION;
    const code = errorCodeName(frame.code);
    if (frame.ack) this._settle(frame.ack);
    if (fatal) {
      this._fail(code, frame.message);
      return;
    }
    this._emit("error", { code, message: frame.message, fatal: false, ack: frame.ack });
    // A pose the server could not cull right now: try the latest pose again shortly.
    if ((frame.code === ErrorCode.OVERLOADED || frame.code === ErrorCode.INTERNAL) && frame.ack === this.lastSent?.seq) {
      this._timer = this._setTimeout(() => {
        this._timer = null;
        this._dirty = true;
        this._pump();
      }, 250);
    }
  }

  /** Forgets in-flight poses up to `ack` (the server answered it; older ones were dropped). */
  _settle(ack) {
    for (const seq of this._inFlight.keys()) {
      if (seq <= ack) this._inFlight.delete(seq);
    }
  }

  // --- helpers -------------------------------------------------------------------------

  _clearStall() {
    if (this._stallTimer !== null) this._clearTimeout(this._stallTimer);
    this._stallTimer = null;
  }

  _cancelTimers() {
    if (this._retryTimer !== null) this._clearTimeout(this._retryTimer);
    if (this._timer !== null) this._clearTimeout(this._timer);
    this._retryTimer = null;
    this._timer = null;
    this._clearStall();
  }

  _setState(state, extra = {}) {
    const previous = this.state;
    if (previous === state && state !== State.RECONNECTING) return;
    this.state = state;
    this._emit("state", { state, previous, attempt: this.attempt, ...extra });
  }

  _emit(type, detail) {
    this.dispatchEvent(new CustomEvent(type, { detail }));
  }
}

function detach(ws) {
  ws.onmessage = null;
  ws.onclose = null;
  ws.onerror = null;
  ws.onopen = null;
}
