#!/usr/bin/env bash
# The figures docs/ quotes beside the main eval run: the per-update cost of moving
# objects, stream deltas along the demo street, memory, the masked map against the
# served one, stereo against mono, and the server under load on the native backend.
# Run from the repository root (it builds what it runs); each part writes its raw
# output into its own folder here.
#   bash results/2026-12-07-xeon-2core/run.sh [PART...]   (default: all parts)
set -euo pipefail
out=$(cd "$(dirname "$0")" && pwd)
parts=("$@"); [ ${#parts[@]} -gt 0 ] || parts=(dynamic street_deltas memory masked server)
bin=target/release/homcull
machine="$(nproc)-core $(lscpu | sed -n 's/^Model name: *//p' | head -1) VM"
# cargo's "Compiling … (path)" lines would name this machine's checkout.
quiet() { grep -v '^ *Compiling ' || true; }
for part in "${parts[@]}"; do
  mkdir -p "$out/$part"
  echo "$machine" > "$out/$part/machine.txt"
  echo "part: $part" >&2
  case $part in
    dynamic)
      cargo bench --bench dynamic 2>&1 | grep -v 'item/s' | quiet > "$out/dynamic/bench.txt" ;;
    street_deltas)
      cargo run --release --example street_deltas 2>&1 | quiet > "$out/street_deltas/out.txt" ;;
    memory)
      HOMCULL_REQUIRE_GPU=1 cargo test --release --test memory -- --nocapture --test-threads 1 2>&1 | quiet \
        > "$out/memory/out.txt" ;;
    masked)
      cargo run --release --features experimental --example masked_vs_per_pixel 2>&1 | quiet \
        > "$out/masked/out.txt" ;;
    server)
      cargo build --release
      port=$((20000 + RANDOM % 20000))
      "$bin" serve --backend cpu --addr "127.0.0.1:$port" > "$out/server/serve.log" 2>&1 &
      pid=$!
      trap 'kill $pid 2>/dev/null || true' EXIT
      for _ in $(seq 1 120); do
        curl -sf "http://127.0.0.1:$port/readyz" > "$out/server/readyz.json" && break
        sleep 0.5
      done
      url="http://127.0.0.1:$port"
      "$bin" loadgen --url "$url" --mode ws --clients 32 --seconds 8 --json > "$out/server/ws32.json"
      "$bin" loadgen --url "$url" --mode batch --clients 4 --batch 64 --seconds 8 --json > "$out/server/batch64x4.json"
      "$bin" loadgen --url "$url" --mode ws --clients 32 --seconds 8 --transforms-per-s 10000 --json \
        > "$out/server/ws32_transforms10k.json"
      kill "$pid"; wait "$pid" || true; trap - EXIT ;;
    *) echo "unknown part: $part" >&2; exit 2 ;;
  esac
done
