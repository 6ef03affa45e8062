// The visible set a client keeps: the IDs of the last Full frame with every Delta since
// applied. Mirrors `apply_delta` and `diff` of `proto/src/frame/`.

import { FrameError, checkAscending, checkDisjoint } from "./codec.js";

/**
 * `set` (strictly ascending) with `added` inserted and `removed` taken out, as a new
 * strictly ascending array. Throws `FrameError` (RemovedAbsent, AddedPresent,
 * NotAscending, IdInBothLists) like the Rust `apply_delta`; `set` is never modified.
 */
export function applyDelta(set, added, removed) {
  checkAscending("set", set);
  checkAscending("added", added);
  checkAscending("removed", removed);
  checkDisjoint(added, removed);
  const out = [];
  let a = 0;
  let r = 0;
  for (const id of set) {
    while (a < added.length && added[a] <= id) {
      if (added[a] === id) throw new FrameError("AddedPresent", { id });
      out.push(added[a++]);
    }
    if (r < removed.length && removed[r] < id) throw new FrameError("RemovedAbsent", { id: removed[r] });
    if (r < removed.length && removed[r] === id) r++;
    else out.push(id);
  }
  if (r < removed.length) throw new FrameError("RemovedAbsent", { id: removed[r] });
  while (a < added.length) out.push(added[a++]);
  return out;
}

/** `{added, removed}` taking strictly ascending `oldIds` to strictly ascending `newIds`. */
export function diff(oldIds, newIds) {
  const added = [];
  const removed = [];
  let i = 0;
  let j = 0;
  while (i < oldIds.length || j < newIds.length) {
    if (j >= newIds.length || (i < oldIds.length && oldIds[i] < newIds[j])) removed.push(oldIds[i++]);
    else if (i >= oldIds.length || newIds[j] < oldIds[i]) added.push(newIds[j++]);
    else {
      i++;
      j++;
    }
  }
  return { added, removed };
}

/**
 * A visible set that Full and Delta frames update. `ids` is the strictly ascending array
 * of visible IDs, `has(id)` a constant-time membership test. A failed update leaves the
 * set as it was.
 */
export class VisibleSet {
  constructor(ids = []) {
    this.ids = [];
    this._members = new Set();
    this.replace(ids);
  }

  /** Number of visible IDs. */
  get size() {
    return this.ids.length;
  }

  /** Whether `id` is visible. */
  has(id) {
    return this._members.has(id);
  }

  /** Replaces the set with `ids` (a Full frame); returns `{added, removed}`. */
  replace(ids) {
    checkAscending("full", ids);
    const change = diff(this.ids, ids);
    this.ids = ids.slice();
    this._members = new Set(this.ids);
    return change;
  }

  /** Applies a Delta frame's lists; returns `{added, removed}`. */
  apply(added, removed) {
    this.ids = applyDelta(this.ids, added, removed);
    for (const id of removed) this._members.delete(id);
    for (const id of added) this._members.add(id);
    return { added: added.slice(), removed: removed.slice() };
  }

  /** Empties the set. */
  clear() {
    this.ids = [];
    this._members = new Set();
  }
}
