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
# Builds and starts `homcull serve` on a free loopback port (its log in $1, the rest
# of the arguments before `serve`'s own: e.g. `taskset -c 0`), sets $url and $pid and
# waits until it is ready; `stop_server` stops it.
start_server() {
  local log=$1; shift
  cargo build --release
  local port=$((20000 + RANDOM % 20000))
  "$@" "$bin" serve --backend cpu --addr "127.0.0.1:$port" "${serve_args[@]}" > "$log" 2>&1 &
  pid=$!
  trap 'kill $pid 2>/dev/null || true' EXIT
  for _ in $(seq 1 120); do
    curl -sf "http://127.0.0.1:$port/readyz" > /dev/null && break
    sleep 0.5
  done
  url="http://127.0.0.1:$port"
}
stop_server() { kill "$pid"; wait "$pid" || true; trap - EXIT; }
for part in "${parts[@]}"; do
  mkdir -p "$out/$part"
  echo "$machine" > "$out/$part/machine.txt"
  echo "part: $part" >&2
  case $part in
    region)
      cargo bench --bench region 2>&1 | grep -v 'item/s' | quiet > "$out/region/bench.txt" ;;
    walk)
      serve_args=()
      start_server "$out/walk/serve.log"
      "$bin" loadgen --url "$url" --mode walk --seconds 1 --stream-query "?region_m=0.5&turn_deg=15" > /dev/null
      : > "$out/walk/walk.jsonl"
      for delay in 0 50 100; do
        for query in "?region_m=0.5&turn_deg=15" "?region_m=1&turn_deg=15" "" "?lookahead_ms=150&hold_ms=300"; do
          "$bin" loadgen --url "$url" --mode walk --seconds 4 --delay-ms "$delay" --stream-query "$query" \
            >> "$out/walk/walk.jsonl"
        done
      done
      stop_server ;;
    walkers)
      # The server on one core with one culling thread, the walkers on the other.
      serve_args=(--threads 1 --max-connections-per-address 1000)
      start_server "$out/walkers/serve.log" taskset -c 0
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
      stop_server ;;
    *) echo "unknown part: $part" >&2; exit 2 ;;
  esac
done
