// How the viewer pairs the camera it draws with the visible set it draws.
//
// A thin client gets the set for a pose one round trip after it sent the pose. It can
// either draw the latest set with the camera the controls have moved on to ("predict":
// what the motion revealed in between is late unless the guard band and the stream's
// smoothing cover it), or draw each set with the camera of the pose it answers
// ("lockstep"): the drawn set is then homcull's set for exactly the drawn view, which by
// the oracle tests never misses an object that view shows, so nothing can pop. The price
// of lockstep is that the view lags the controls by one round trip, which nobody notices
// when the round trip fits in a frame (a GPU server nearby: ~2 ms) and everybody
// notices at 100 ms. "auto" picks by the measured round trip: lockstep up to about two
// frames at 60 Hz, where a walk still feels direct.
//
// "region" (the default) asks the server for region streams instead: each set holds
// for every eye within a radius of a centre looking within a turn of an axis (the
// region frame that comes before it), so the current camera is drawn at once with the
// set held, and nothing it shows is missing while it stays inside that region, however
// late the frames. Outside it (a flick, a teleport, a walk faster than the next region
// arrives) the viewer draws the newest set and says "not guaranteed" until the next
// region holds the camera again.

export const DISPLAY_MODES = ["region", "auto", "lockstep", "predict"];

/**
 * The region streams the viewer asks for (`?region_m=`, `?turn_deg=` set others): 2 m
 * and 20°. The stream culls the next region when the camera leaves the inner half of
 * the last, so the other half is the time the next one has to arrive: 1 m at the
 * viewer's walking speed of 5 m/s is 200 ms, about two region answers on the native
 * CPU backend at 960×540, and 10° at the arrow keys' 92°/s is 110 ms (a wider turn
 * costs more: past 75° each side of a 16:9 view the server draws six cube faces).
 */
export const REGION = { region_m: 2, turn_deg: 20 };

/** "auto" enters lockstep when the round trip p50 is at most this (ms)… */
export const LOCKSTEP_ENTER_MS = 34;
/** …and leaves it when the p50 exceeds this (hysteresis: no flapping near the bound). */
export const LOCKSTEP_LEAVE_MS = 50;

/** The display mode named by `?display=` (anything else: "region"). */
export function parseDisplayMode(name) {
  return DISPLAY_MODES.includes(name) ? name : "region";
}

/**
 * Whether the next frame draws in lockstep, given the mode, whether this frame did, and
 * the round-trip p50 in ms (NaN while unmeasured: "auto" then stays as it is).
 */
export function useLockstep(mode, current, rttP50) {
  if (mode === "lockstep") return true;
  if (mode === "predict" || mode === "region") return false;
  if (!Number.isFinite(rttP50)) return current;
  return current ? rttP50 <= LOCKSTEP_LEAVE_MS : rttP50 <= LOCKSTEP_ENTER_MS;
}

/**
 * The views of the poses sent, by sequence number, until an answer claims them. A view
 * is the pose as sent (`position`, `rotation`, `fov_y_deg`, `viewport`, …) plus `exact`:
 * whether it is the drawn view itself (no guard band), the only kind lockstep draws.
 */
export class ViewLog {
  constructor(limit = 256) {
    this.limit = limit;
    this._views = new Map();
  }

  /** Remembers the view of pose `seq`. */
  record(seq, view) {
    this._views.set(seq, view);
    // Poses the server dropped as superseded are never answered: keep the log bounded.
    while (this._views.size > this.limit) this._views.delete(this._views.keys().next().value);
  }

  /**
   * The view of pose `ack`, or undefined. Answers come in pose order, so this view and
   * every older one are forgotten.
   */
  answer(ack) {
    const view = this._views.get(ack);
    for (const seq of [...this._views.keys()]) if (seq <= ack) this._views.delete(seq);
    return view;
  }

  get size() {
    return this._views.size;
  }
}

/**
 * Whether `region` (a region frame: `centre`, `radius_m`, unit `axis`, `turn_deg`)
 * holds an eye at `position` looking along unit `forward`: the server's test
 * (`RegionFrame::holds`), the frustum shape aside.
 */
export function regionHolds(region, position, forward) {
  if (!region) return false;
  const d2 = distance2(region.centre, position);
  const cos = region.axis.reduce((sum, a, k) => sum + a * forward[k], 0);
  const angle = (Math.acos(Math.max(-1, Math.min(1, cos))) * 180) / Math.PI;
  return d2 <= region.radius_m ** 2 && angle <= region.turn_deg;
}

/** Metres from `position` to the edge of `region`'s ball (negative outside). */
export function regionMargin(region, position) {
  return region.radius_m - Math.sqrt(distance2(region.centre, position));
}

/** Squared distance between two points `[x, y, z]`. */
function distance2(a, b) {
  return a.reduce((sum, c, k) => sum + (b[k] - c) ** 2, 0);
}

/** Events in the last second: `add(now)` each, `rate(now)` how many (ms clock). */
export class RateMeter {
  constructor(windowMs = 1000) {
    this.windowMs = windowMs;
    this._times = [];
  }

  add(now) {
    this._times.push(now);
    this._trim(now);
  }

  rate(now) {
    this._trim(now);
    return (this._times.length * 1000) / this.windowMs;
  }

  _trim(now) {
    while (this._times.length && this._times[0] <= now - this.windowMs) this._times.shift();
  }
}
