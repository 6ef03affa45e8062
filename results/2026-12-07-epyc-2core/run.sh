#!/usr/bin/env bash
# Region answers (the region bench) and region streams against point streams (the
# delayed walk). Run from the repository root (it builds what it runs); each part
# writes its raw output into its own folder here.
#   bash results/2026-12-07-epyc-2core/run.sh [PART...]   (default: all parts)
set -euo pipefail
out=$(cd "$(dirname "$0")" && pwd)
parts=("$@"); [ ${#parts[@]} -gt 0 ] || parts=(region walk)
bin=target/release/homcull
machine="$(nproc)-core $(lscpu | sed -n 's/^Model name: *//p' | head -1) VM"
# cargo's "Compiling … (path)" lines would name this machine's checkout.
quiet() { grep -v '^ *Compiling ' || true; }
for part in "${parts[@]}"; do
  mkdir -p "$out/$part"
  echo "$machine" > "$out/$part/machine.txt"
  echo "part: $part" >&2
  case $part in
    region)
      cargo bench --bench region 2>&1 | grep -v 'item/s' | quiet > "$out/region/bench.txt" ;;
    walk)
      cargo build --release
      port=$((20000 + RANDOM % 20000))
      "$bin" serve --backend cpu --addr "127.0.0.1:$port" > "$out/walk/serve.log" 2>&1 &
      pid=$!
      trap 'kill $pid 2>/dev/null || true' EXIT
      for _ in $(seq 1 120); do
        curl -sf "http://127.0.0.1:$port/readyz" > /dev/null && break
        sleep 0.5
      done
      url="http://127.0.0.1:$port"
      "$bin" loadgen --url "$url" --mode walk --seconds 1 --stream-query "?region_m=0.5&turn_deg=15" > /dev/null
      : > "$out/walk/walk.jsonl"
      for delay in 0 50 100; do
        for query in "?region_m=0.5&turn_deg=15" "?region_m=1&turn_deg=15" "" "?lookahead_ms=150&hold_ms=300"; do
          "$bin" loadgen --url "$url" --mode walk --seconds 4 --delay-ms "$delay" --stream-query "$query" \
            >> "$out/walk/walk.jsonl"
        done
      done
      kill "$pid"; wait "$pid" || true; trap - EXIT ;;
    walkers)
      # The server on one core with one culling thread, the walkers on the other.
      cargo build --release
      port=$((20000 + RANDOM % 20000))
      taskset -c 0 "$bin" serve --backend cpu --threads 1 --addr "127.0.0.1:$port" \
        --max-connections-per-address 1000 > "$out/walkers/serve.log" 2>&1 &
      pid=$!
      trap 'kill $pid 2>/dev/null || true' EXIT
      for _ in $(seq 1 120); do
        curl -sf "http://127.0.0.1:$port/readyz" > /dev/null && break
        sleep 0.5
      done
      url="http://127.0.0.1:$port"
      taskset -c 1 "$bin" loadgen --url "$url" --mode walkers --clients 4 --seconds 1 > /dev/null
      : > "$out/walkers/walkers.jsonl"
      for clients in ${WALKERS_POINT:-5 10 15 20 30}; do
        taskset -c 1 "$bin" loadgen --url "$url" --mode walkers --clients "$clients" --seconds 5 \
          --json >> "$out/walkers/walkers.jsonl"
      done
      for clients in ${WALKERS_REGION:-1 2 3 5 10 20 40}; do
        taskset -c 1 "$bin" loadgen --url "$url" --mode walkers --clients "$clients" --seconds 5 \
          --stream-query "?region_m=0.5&turn_deg=15" --json >> "$out/walkers/walkers.jsonl"
      done
      kill "$pid"; wait "$pid" || true; trap - EXIT ;;
    *) echo "unknown part: $part" >&2; exit 2 ;;
  esac
done
