#!/usr/bin/env bash
# Peak memory of `imunoise screen` against the number of files: the same small recording
# (3 gyro axes, 3 min at 100 Hz, one seed per file) screened in batches of each size given,
# with the residual loop off (the loop's memory is per file; what could grow with the count is
# the batch's own bookkeeping: manifests, rows, the fleet step). Prints files, wall and peak RSS.
#
# Usage: cargo build --release && scripts/bench_memory_files.sh [COUNTS="50 500"] [WORK=/tmp/imunoise-files]
set -euo pipefail
COUNTS="${1:-50 500}"
WORK="${2:-/tmp/imunoise-files}"
BIN="$(cd "$(dirname "$0")/.." && pwd)/target/release/imunoise"
max=0
for c in $COUNTS; do [ "$c" -gt "$max" ] && max=$c; done
mkdir -p "$WORK/all"
for i in $(seq 1 "$max"); do
  f="$WORK/all/u_$(printf %04d "$i").arrow"
  [ -f "$f" ] || "$BIN" simulate -o "$f" --rate 100 --duration 180 --seed "$i" --axes 3 \
    --noise 'N=0.15deg/sqrt(h)' --noise 'B=3deg/h' -q
done
echo "| files | wall s | peak RSS MB |"
echo "|---|---|---|"
for c in $COUNTS; do
  rm -rf "$WORK/in" "$WORK/out"
  mkdir -p "$WORK/in"
  for i in $(seq 1 "$c"); do
    ln -s "$WORK/all/u_$(printf %04d "$i").arrow" "$WORK/in/"
  done
  /usr/bin/time -f "%e %M" "$BIN" screen "$WORK/in" -o "$WORK/out" --backend cpu --no-loop \
    --quiet 2> "$WORK/time.txt" || true
  read -r wall kb < <(tail -1 "$WORK/time.txt")
  echo "| $c | $wall | $((kb / 1024)) |"
done
