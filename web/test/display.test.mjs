// The viewer's display modes: when "auto" draws in lockstep, and the log that pairs each
// answer with the view of the pose it answers.

import { test } from "node:test";
import assert from "node:assert/strict";

import { LOCKSTEP_ENTER_MS, LOCKSTEP_LEAVE_MS, ViewLog, parseDisplayMode, useLockstep } from "../src/display.js";

test("parseDisplayMode takes the three modes and defaults to auto", () => {
  for (const m of ["auto", "lockstep", "predict"]) assert.equal(parseDisplayMode(m), m);
  for (const m of [null, undefined, "", "LOCKSTEP", "exact"]) assert.equal(parseDisplayMode(m), "auto");
});

test("fixed modes ignore the round trip", () => {
  for (const rtt of [0.5, 100, NaN]) {
    for (const current of [true, false]) {
      assert.equal(useLockstep("lockstep", current, rtt), true);
      assert.equal(useLockstep("predict", current, rtt), false);
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
