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

export const DISPLAY_MODES = ["auto", "lockstep", "predict"];

/** "auto" enters lockstep when the round trip p50 is at most this (ms)… */
export const LOCKSTEP_ENTER_MS = 34;
/** …and leaves it when the p50 exceeds this (hysteresis: no flapping near the bound). */
export const LOCKSTEP_LEAVE_MS = 50;

/** The display mode named by `?display=` (anything else: "auto"). */
export function parseDisplayMode(name) {
  return DISPLAY_MODES.includes(name) ? name : "auto";
}

/**
 * Whether the next frame draws in lockstep, given the mode, whether this frame did, and
 * the round-trip p50 in ms (NaN while unmeasured: "auto" then stays as it is).
 */
export function useLockstep(mode, current, rttP50) {
  if (mode === "lockstep") return true;
  if (mode === "predict") return false;
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
