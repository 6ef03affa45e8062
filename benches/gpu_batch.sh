#!/usr/bin/env bash
# The GPU batch at batch sizes 1, 16, 64 and 256: ms per pose (refined HOM and the
# exact oracle, from `homcull eval --json`) and the host's share per pose (recording,
# and finish + submit, from the `homcull::timing` log), on the adapter the environment
# picks (WGPU_BACKEND, WGPU_ADAPTER_NAME). Short enough for a few minutes of a lent GPU:
#
#   BIN=target/release/homcull OUT=results/<device>/batch bash benches/gpu_batch.sh
#
# SCENES lists `demo` and/or glTF paths (default: the demo and munich if present).
set -euo pipefail
BIN=${BIN:-target/release/homcull}
OUT=${OUT:-gpu_batch_out}
SCENES=${SCENES:-"demo ../shared/scenes/munich.glb"}
mkdir -p "$OUT"
printf 'scene\tbatch\tposes\thom-refine ms/pose p50\texact ms/pose p50\thost us/pose (record + submit)\n' \
    | tee "$OUT/summary.tsv"
for scene in $SCENES; do
    if [ "$scene" = demo ]; then
        name=demo; source=(--demo)
    elif [ -f "$scene" ]; then
        name=$(basename "$scene" .glb); source=(--scene "$scene")
    else
        echo "skipping $scene: not found" >&2; continue
    fi
    for batch in 1 16 64 256; do
        poses=$(( batch < 64 ? 64 : batch ))
        base="$OUT/$name-b$batch"
        RUST_LOG=homcull::timing=debug "$BIN" eval --backend gpu "${source[@]}" \
            --random "$poses" --batch "$batch" --methods hom-refine --json \
            > "$base.json" 2> "$base.log"
        # Host time per pose (recording, finish + submit) of every batch of either
        # method, the first (warm-up) left out: each "recorded a batch" line and the
        # submission line after it.
        host=$(awk '
            /recorded a batch/ {
                n = $0; sub(/.*poses=/, "", n); sub(/ .*/, "", n)
                r = $0; sub(/.*record_ms=/, "", r); sub(/ .*/, "", r); open = 1; next }
            /GPU submission/ && open {
                s = $0; sub(/.*submit_ms=/, "", s); sub(/ .*/, "", s)
                if (seen++) { ms += r + s; p += n }
                open = 0 }
            END { if (p) printf "%.0f", ms * 1000 / p; else printf "-" }' "$base.log")
        p50() { tr -d ' \n' < "$base.json" | grep -o "\"$1\":{[^}]*}" \
            | grep -o '"p50":[0-9.e-]*' | cut -d: -f2; }
        printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$batch" "$poses" \
            "$(p50 hom-refine)" "$(p50 exact)" "$host" | tee -a "$OUT/summary.tsv"
    done
done
