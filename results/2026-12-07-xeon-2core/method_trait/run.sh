#!/usr/bin/env bash
# The bench binary of the head before "one type per culling method" ("old",
# b89e2ba) and of the head with it ("new"), alternated, ROUNDS rounds (default 5),
# each pinned to one core. Build each with `cargo bench --bench native --no-run`
# at its head and copy the executable to $OLD / $NEW; run from the repository root.
set -euo pipefail
: "${OLD:?path of the old bench binary}" "${NEW:?path of the new bench binary}"
for round in $(seq 1 "${ROUNDS:-5}"); do
  for which in old new; do
    bin=OLD; [ "$which" = new ] && bin=NEW
    echo "== round $round $which"
    taskset -c 1 "${!bin}" --bench pose_hom_refined pose_stereo_refined --sample-count 25 2>&1 | grep -v 'item/s'
  done
done
