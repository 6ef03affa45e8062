// The viewer's display modes: when "auto" draws in lockstep, and the log that pairs each
// answer with the view of the pose it answers.

import { test } from "node:test";
import assert from "node:assert/strict";

import {
  LOCKSTEP_ENTER_MS,
  LOCKSTEP_LEAVE_MS,
  RateMeter,
  ViewLog,
  parseDisplayMode,
  regionHolds,
  regionMargin,
  useLockstep,
} from "../src/display.js";

test("parseDisplayMode takes the four modes and defaults to region", () => {
  for (const m of ["region", "auto", "lockstep", "predict"]) assert.equal(parseDisplayMode(m), m);
  for (const m of [null, undefined, "", "LOCKSTEP", "exact"]) assert.equal(parseDisplayMode(m), "region");
});

test("a region holds the eyes within its radius looking within its turn", () => {
  const region = { centre: [1, 2, 3], radius_m: 2, axis: [0, 0, -1], turn_deg: 30 };
  assert.ok(regionHolds(region, [1, 2, 3], [0, 0, -1]));
  assert.ok(regionHolds(region, [2.9, 2, 3], [0, 0, -1]), "inside the ball");
  assert.ok(!regionHolds(region, [3.1, 2, 3], [0, 0, -1]), "beyond the radius");
  const turned = (deg) => [Math.sin((deg * Math.PI) / 180), 0, -Math.cos((deg * Math.PI) / 180)];
  assert.ok(regionHolds(region, [1, 2, 3], turned(29)));
  assert.ok(!regionHolds(region, [1, 2, 3], turned(31)), "turned too far");
  assert.ok(!regionHolds(null, [1, 2, 3], [0, 0, -1]), "no region holds nothing");
  assert.equal(regionMargin(region, [1, 2, 4.5]), 0.5);
  assert.equal(regionMargin(region, [1, 2, 6]), -1);
});

test("the rate meter counts the last second", () => {
  const m = new RateMeter();
  for (const t of [0, 100, 900, 1500]) m.add(t);
  assert.equal(m.rate(1500), 2, "900 and 1500");
  assert.equal(m.rate(3000), 0);
});

test("fixed modes ignore the round trip", () => {
  for (const rtt of [0.5, 100, NaN]) {
    for (const current of [true, false]) {
      assert.equal(useLockstep("lockstep", current, rtt), true);
      assert.equal(useLockstep("predict", current, rtt), false);
      assert.equal(useLockstep("region", current, rtt), false, "region draws the current camera");
    }
  }
});

test("auto enters lockstep on a fast round trip and leaves it on a slow one, with hysteresis", () => {
  assert.ok(LOCKSTEP_ENTER_MS < LOCKSTEP_LEAVE_MS);
  assert.equal(useLockstep("auto", false, NaN), false, "unmeasured: stays");
  assert.equal(useLockstep("auto", true, NaN), true, "unmeasured: stays");
  assert.equal(useLockstep("auto", false, 2), true);
  assert.equal(useLockstep("auto", false, LOCKSTEP_ENTER_MS), true);
  const between = (LOCKSTEP_ENTER_MS + LOCKSTEP_LEAVE_MS) / 2;
  assert.equal(useLockstep("auto", false, between), false, "not entered between the bounds");
  assert.equal(useLockstep("auto", true, between), true, "not left between the bounds");
  assert.equal(useLockstep("auto", true, LOCKSTEP_LEAVE_MS + 1), false);
  assert.equal(useLockstep("auto", true, 100), false);
});

test("ViewLog pairs an answer with its pose's view and forgets older poses", () => {
  const log = new ViewLog();
  for (let seq = 1; seq <= 5; seq++) log.record(seq, { position: [seq, 1.7, 0], exact: true });
  // Poses 2 and 3 were superseded: the server answers 1, then 4.
  assert.deepEqual(log.answer(1).position, [1, 1.7, 0]);
  assert.equal(log.size, 4);
  assert.deepEqual(log.answer(4).position, [4, 1.7, 0]);
  assert.equal(log.size, 1, "2, 3 and 4 are gone");
  assert.equal(log.answer(3), undefined, "an answer to a forgotten pose has no view");
  assert.deepEqual(log.answer(5).position, [5, 1.7, 0]);
  assert.equal(log.size, 0);
});

test("ViewLog stays bounded when answers never come", () => {
  const log = new ViewLog(8);
  for (let seq = 1; seq <= 100; seq++) log.record(seq, { seq });
  assert.equal(log.size, 8);
  assert.equal(log.answer(92), undefined, "evicted");
  assert.deepEqual(log.answer(93), { seq: 93 });
});
