#!/usr/bin/env bash
# Visibility from a region on every scene (`homcull report --sections regions`), and
# the delayed walks of region and point streams on munich. Run from the repository
# root (it builds what it runs); each part writes its raw output into its own folder.
#   bash results/2026-12-08-xeon-2core/run.sh [PART...]   (default: all parts)
set -euo pipefail
out=$(cd "$(dirname "$0")" && pwd)
parts=("$@"); [ ${#parts[@]} -gt 0 ] || parts=(regions walk)
bin=target/release/homcull
# Relative to the repository root: the report names its --out in its command line.
rel=${out#"$PWD"/}
machine="$(nproc)-core $(lscpu | sed -n 's/^Model name: *//p' | head -1) VM"
# cargo's "Compiling … (path)" lines would name this machine's checkout.
quiet() { grep -v '^ *Compiling ' || true; }
# Starts `homcull serve` on a free loopback port (its log in $1, the rest of the
# arguments `serve`'s own), sets $url and $pid and waits until it is ready.
start_server() {
  local log=$1; shift
  local port=$((20000 + RANDOM % 20000))
  "$bin" serve --backend cpu --addr "127.0.0.1:$port" "$@" > "$log" 2>&1 &
  pid=$!
  trap 'kill $pid 2>/dev/null || true' EXIT
  for _ in $(seq 1 240); do
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
    regions)
      cargo build --release 2>&1 | quiet
      "$bin" report --backend cpu --sections regions --out "$rel/regions" 2> "$out/regions/progress.txt" ;;
    regions-lavapipe)
      # The same on the wgpu backend (Mesa's lavapipe): region answers run on the CPU
      # on every backend; the point answers beside them on the adapter.
      cargo build --release 2>&1 | quiet
      "$bin" report --backend gpu --sections regions --out "$rel/regions-lavapipe" \
        2> "$out/regions-lavapipe/progress.txt" ;;
    walk)
      # The delayed walk on the demo street and on munich from its walk start.
      cargo build --release 2>&1 | quiet
      start_server "$out/walk/serve.log" --scene ../shared/scenes/munich.glb
      : > "$out/walk/walk.jsonl"
      for scene in demo munich; do
        "$bin" loadgen --url "$url" --scene "$scene" --mode walk --seconds 1 \
          --stream-query "?region_m=0.5&turn_deg=15" > /dev/null
        for delay in 0 50 100 200; do
          for query in "?region_m=0.5&turn_deg=15" "?region_m=1&turn_deg=15" "" "?lookahead_ms=150&hold_ms=300"; do
            "$bin" loadgen --url "$url" --scene "$scene" --mode walk --seconds 4 --delay-ms "$delay" \
              --stream-query "$query" >> "$out/walk/walk.jsonl"
          done
        done
      done
      stop_server ;;
    journal)
      # One writer's update latency with the journal (a flush per update) and in
      # memory, three rounds alternated, each on a fresh data dir under target/.
      cargo build --release 2>&1 | quiet
      : > "$out/journal/latency.jsonl"
      for round in 1 2 3; do
        for state in journal memory; do
          data=$(mktemp -d -p target)
          start_server "$out/journal/serve.log" --state "$state" --data-dir "$data"
          python3 "$out/transforms_latency.py" "$url" "$state" 500 >> "$out/journal/latency.jsonl"
          stop_server
          rm -rf "$data"
        done
      done
      df -T target | tail -1 | awk '{print "data dir file system: " $2}' >> "$out/journal/machine.txt" ;;
    *) echo "unknown part $part" >&2; exit 2 ;;
  esac
done
