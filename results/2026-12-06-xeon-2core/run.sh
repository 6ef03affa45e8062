#!/usr/bin/env bash
# The native CPU backend on one thread: every method against the exact oracle on the
# shared scenes and the demo city, 200 random street-level poses each at 960x540.
# Writes eval/SCENE.json (raw `homcull eval --json`), eval/SCENE.err and run.json.
# Run from the repository root after `cargo build --release`:
#   bash results/2026-12-06-xeon-2core/run.sh
set -euo pipefail
out=$(dirname "$0")
bin=${HOMCULL_BIN:-target/release/homcull}
scenes_dir=${SCENES_DIR:-../shared/scenes}
scenes=(munich etoile oa_shouse oa_dm1 fzk_haus godot_room demo)
args=(eval --backend cpu --threads 1 --random 200 --seed 1 --viewport 960x540 --batch 16
      --methods hom,hom-raster,hzb,frustum --json)
mkdir -p "$out/eval"
for s in "${scenes[@]}"; do
  if [ "$s" = demo ]; then src=(--demo); else src=(--scene "$scenes_dir/$s.glb"); fi
  echo "run: $s" >&2
  "$bin" "${args[@]}" "${src[@]}" > "$out/eval/$s.json" 2> "$out/eval/$s.err"
done
backend=$(grep -m1 '^backend:' "$out/eval/munich.err" | sed 's/^backend: [a-z]* (\(.*\))$/\1/')
machine="$(nproc)-core $(lscpu | sed -n 's/^Model name: *//p' | head -1) VM"
python3 - "$out/run.json" "$backend" "$machine" "${scenes[@]}" <<'PY'
import json, sys
path, backend, machine, *scenes = sys.argv[1:]
json.dump({
    "command": "homcull eval --backend cpu --threads 1 --random 200 --seed 1 --viewport 960x540 "
               "--batch 16 --methods hom,hom-raster,hzb,frustum --json",
    "backend": backend,
    "machine": machine,
    "poses": 200,
    "viewport": "960×540",
    "scenes": scenes,
}, open(path, "w"), indent=2, ensure_ascii=False)
open(path, "a").write("\n")
PY
