// The visible set a client keeps: the IDs of the last Full frame with every Delta since
// applied, and on a stream with levels of detail each ID's level. Mirrors `apply_delta`,
// `apply_delta_with_levels` and `diff` of `proto/src/frame/`.

import { FrameError, checkAscending, checkChanged, checkDisjoint, checkLevels } from "./codec.js";

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
    /** Level of detail by ID (a Map) on a stream with levels, else null. */
    this.levels = null;
    this.replace(ids);
  }

  /** The level of detail of visible `id` (undefined without levels or when not visible). */
  level(id) {
    return this.levels?.get(id);
  }

  /** Number of visible IDs. */
  get size() {
    return this.ids.length;
  }

  /** Whether `id` is visible. */
  has(id) {
    return this._members.has(id);
  }

  /**
   * Replaces the set with `ids` (a Full frame) and, when given, their `levels` (one per
   * ID); returns `{added, removed, changed}` (`changed`: kept IDs whose level changed).
   */
  replace(ids, levels = null) {
    checkAscending("full", ids);
    if (levels !== null) checkLevels(ids.length, levels);
    const change = diff(this.ids, ids);
    const old = this.levels;
    this.ids = ids.slice();
    this._members = new Set(this.ids);
    this.levels = levels === null ? null : new Map(ids.map((id, k) => [id, levels[k]]));
    change.changed = [];
    if (old !== null && this.levels !== null) {
      for (const [id, level] of this.levels) {
        if (old.has(id) && old.get(id) !== level) change.changed.push(id);
      }
    }
    return change;
  }

  /**
   * Applies a Delta frame's lists and, on a stream with levels, its `lod` ({added_levels,
   * changed, changed_levels}); returns `{added, removed, changed}`. Throws `FrameError`
   * like the Rust `apply_delta_with_levels`, leaving the set as it was.
   */
  apply(added, removed, lod = null) {
    if (this.levels !== null || lod !== null) {
      const l = lod ?? { added_levels: [], changed: [], changed_levels: [] };
      if (this.levels === null) throw new FrameError("LevelCount", { ids: this.ids.length, levels: 0 });
      checkLevels(added.length, l.added_levels);
      checkLevels(l.changed.length, l.changed_levels);
      checkAscending("changed", l.changed);
      checkChanged(l.changed, added, removed);
      for (const id of l.changed) {
        if (!this._members.has(id)) throw new FrameError("ChangedNotKept", { id });
      }
    }
    this.ids = applyDelta(this.ids, added, removed);
    for (const id of removed) this._members.delete(id);
    for (const id of added) this._members.add(id);
    if (this.levels !== null) {
      for (const id of removed) this.levels.delete(id);
      added.forEach((id, k) => this.levels.set(id, lod.added_levels[k]));
      lod?.changed.forEach((id, k) => this.levels.set(id, lod.changed_levels[k]));
    }
    return { added: added.slice(), removed: removed.slice(), changed: lod ? lod.changed.slice() : [] };
  }

  /** Empties the set. */
  clear() {
    this.ids = [];
    this._members = new Set();
    this.levels = null;
  }
}
