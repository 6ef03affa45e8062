#!/usr/bin/env bash
# Vulkan calls per pose of homcull's GPU batches, counted by a layer of our own
# (vkcount.c: render passes, dispatches, pipeline barriers, buffers created, command
# buffers begun, draws, descriptor-set updates, queue submissions).
#
# `homcull eval --backend gpu --methods hom` (HOM as served, and the exact oracle eval
# always runs) is counted twice, with BATCH and with 2 × BATCH poses at batch BATCH;
# the difference is one more batch of each method, so set-up (pipelines, scene
# buffers, the warm-up) cancels and what is left is divided by BATCH.
#
#   BIN=target/release/homcull bash benches/vkcount/run.sh        # --demo, batch 64
#   SCENE="--scene ../shared/scenes/munich.glb" BATCH=16 bash benches/vkcount/run.sh
#
# Needs a C compiler and the Vulkan headers (Debian: libvulkan-dev).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
BIN=${BIN:-target/release/homcull}
BATCH=${BATCH:-64}
# METHODS: what eval compares with the oracle (default hom; frustum leaves the oracle alone)
read -r -a scene <<< "${SCENE:---demo}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cc -O2 -shared -fPIC -fvisibility=hidden -o "$work/libvkcount.so" "$here/vkcount.c"
cp "$here/VkLayer_homcull_count.json" "$work/"
count() {
    VK_LAYER_PATH="$work" VK_INSTANCE_LAYERS=VK_LAYER_HOMCULL_count VKCOUNT_OUT="$work/$1.json" \
        WGPU_BACKEND=vulkan "$BIN" eval --backend gpu "${scene[@]}" --random "$1" --batch "$BATCH" \
        --methods "${METHODS:-hom}" --json > /dev/null 2> "$work/$1.log" || { cat "$work/$1.log" >&2; exit 1; }
}
count "$BATCH"
count $((2 * BATCH))
python3 - "$work/$BATCH.json" "$work/$((2 * BATCH)).json" "$BATCH" <<'PY'
import json, sys
one, two, n = json.load(open(sys.argv[1])), json.load(open(sys.argv[2])), int(sys.argv[3])
print(f"per pose at batch {n} (HOM and the exact oracle together):")
for k in one:
    print(f"  {k:24s} {(two[k] - one[k]) / n:8.3f}")
PY
