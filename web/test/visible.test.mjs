// Delta application and the visible set: the same cases as apply_delta in
// proto/tests/reject.rs, plus randomized agreement of diff and applyDelta.

import { test } from "node:test";
import assert from "node:assert/strict";

import { FrameError } from "../src/codec.js";
import { VisibleSet, applyDelta, diff } from "../src/visible.js";

test("applyDelta merges added and removed ids in order", () => {
  assert.deepEqual(applyDelta([3, 17, 256, 1000, 1001, 1233], [5, 700], [1233]), [3, 5, 17, 256, 700, 1000, 1001]);
  assert.deepEqual(applyDelta([], [1, 2], []), [1, 2]);
  assert.deepEqual(applyDelta([1, 2], [], [1, 2]), []);
  assert.deepEqual(applyDelta([5], [0, 9], [5]), [0, 9]);
  assert.deepEqual(applyDelta([2, 3, 9], [4], [2]), [3, 4, 9]);
});

const cases = [
  ["removed id absent", [1, 5, 9], [], [4], "RemovedAbsent", { id: 4 }],
  ["removed id past the end", [1, 5, 9], [2], [9, 12], "RemovedAbsent", { id: 12 }],
  ["removed from the empty set", [], [], [0], "RemovedAbsent", { id: 0 }],
  ["added id present", [1, 5, 9], [0, 5], [], "AddedPresent", { id: 5 }],
  ["set not ascending", [3, 1], [], [], "NotAscending", { list: "set", index: 1, prev: 3, id: 1 }],
  ["added not ascending", [], [2, 2], [], "NotAscending", { list: "added", index: 1, prev: 2, id: 2 }],
  ["removed not ascending", [1, 2], [], [2, 1], "NotAscending", { list: "removed", index: 1, prev: 2, id: 1 }],
  ["id in both lists", [4], [4], [4], "IdInBothLists", { id: 4 }],
];

test("applyDelta rejects what the Rust apply_delta rejects and leaves the set alone", () => {
  for (const [what, set, added, removed, variant, fields] of cases) {
    const before = set.slice();
    assert.throws(
      () => applyDelta(set, added, removed),
      (e) => e instanceof FrameError && e.variant === variant && assert.deepEqual(e.fields, fields) === undefined,
      what,
    );
    assert.deepEqual(set, before, `${what}: set changed`);
  }
});

test("VisibleSet keeps ids and membership in step; a failed delta changes nothing", () => {
  const v = new VisibleSet();
  assert.equal(v.size, 0);
  let change = v.replace([3, 17, 256]);
  assert.deepEqual(change, { added: [3, 17, 256], removed: [], changed: [] });
  assert.ok(v.has(17) && !v.has(5));
  change = v.apply([5], [17]);
  assert.deepEqual(change, { added: [5], removed: [17], changed: [] });
  assert.deepEqual(v.ids, [3, 5, 256]);
  assert.ok(v.has(5) && !v.has(17));
  const ids = v.ids;
  assert.throws(() => v.apply([3], []), { variant: "AddedPresent" });
  assert.throws(() => v.apply([], [17]), { variant: "RemovedAbsent" });
  assert.equal(v.ids, ids);
  assert.ok(v.has(3) && v.has(5) && v.has(256) && !v.has(17));
  assert.throws(() => v.replace([2, 1]), { variant: "NotAscending" });
  assert.deepEqual(v.ids, [3, 5, 256]);
  change = v.replace([5, 6]);
  assert.deepEqual(change, { added: [6], removed: [3, 256], changed: [] });
  v.clear();
  assert.equal(v.size, 0);
  assert.ok(!v.has(5));
});

test("VisibleSet keeps each id's level of detail; bad level updates change nothing", () => {
  const v = new VisibleSet();
  v.replace([1, 2, 3], [0, 1, 2]);
  assert.deepEqual([1, 2, 3].map((id) => v.level(id)), [0, 1, 2]);
  const change = v.apply([4], [1], { added_levels: [3], changed: [2], changed_levels: [0] });
  assert.deepEqual(change, { added: [4], removed: [1], changed: [2] });
  assert.deepEqual(v.ids, [2, 3, 4]);
  assert.deepEqual(v.ids.map((id) => v.level(id)), [0, 2, 3]);
  assert.equal(v.level(1), undefined);
  const bad = [
    [[5], [], { added_levels: [], changed: [], changed_levels: [] }, "LevelCount"],
    [[5], [], { added_levels: [9], changed: [], changed_levels: [] }, "BadLevel"],
    [[], [], { added_levels: [], changed: [7], changed_levels: [1] }, "ChangedNotKept"],
    [[], [3], { added_levels: [], changed: [3], changed_levels: [1] }, "ChangedNotKept"],
    [[], [], { added_levels: [], changed: [4, 2], changed_levels: [1, 1] }, "NotAscending"],
  ];
  for (const [added, removed, lod, variant] of bad) {
    assert.throws(() => v.apply(added, removed, lod), { variant }, variant);
    assert.deepEqual(v.ids, [2, 3, 4]);
    assert.deepEqual(v.ids.map((id) => v.level(id)), [0, 2, 3]);
  }
  // A full frame with levels reports the kept ids whose level changed.
  assert.deepEqual(v.replace([3, 4], [2, 1]), { added: [], removed: [2], changed: [4] });
  // Without levels, a delta with levels does not apply.
  const plain = new VisibleSet([1]);
  assert.throws(() => plain.apply([2], [], { added_levels: [0], changed: [], changed_levels: [] }), { variant: "LevelCount" });
});

test("diff and applyDelta agree on random sets", () => {
  let seed = 42;
  const rand = () => ((seed = (seed * 1103515245 + 12345) >>> 0) / 2 ** 32);
  const randomSet = () => Array.from({ length: 200 }, (_, i) => i).filter(() => rand() < 0.3);
  for (let i = 0; i < 200; i++) {
    const a = randomSet();
    const b = randomSet();
    const { added, removed } = diff(a, b);
    assert.deepEqual(applyDelta(a, added, removed), b);
    for (const id of added) assert.ok(!a.includes(id) && b.includes(id));
    for (const id of removed) assert.ok(a.includes(id) && !b.includes(id));
  }
});
