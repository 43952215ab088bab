#!/usr/bin/env bash
# Fleet throughput, end to end as a user runs it: N simulated 6-axis IMUs (1 h at 200 Hz, f64,
# a 2nd-order 50 Hz anti-alias filter, datasheet-like noise, one seed each) screened by
# `imunoise screen` on the CPU; prints wall time, sensors per second and peak resident memory.
#
# Usage: cargo build --release && scripts/bench_fleet.sh [N=256] [WORK=/tmp/imunoise-fleet]
# Needs about 40 MB of disk per sensor. Generation is not timed.
set -euo pipefail
N="${1:-256}"
WORK="${2:-/tmp/imunoise-fleet}"
BIN="$(cd "$(dirname "$0")/.." && pwd)/target/release/imunoise"
mkdir -p "$WORK/in"
for i in $(seq 1 "$N"); do
  f="$WORK/in/imu_$(printf %04d "$i").arrow"
  [ -f "$f" ] && continue
  python3 - "$i" > "$WORK/spec.json" <<'PY'
import json, math, sys
seed = int(sys.argv[1])
d = math.pi / 180
def ch(name, sensor, n, b, k):
    return {"name": name, "sensor": sensor, "noise": {"n": n, "b": b, "k": k},
            "lowpass": {"order": 2, "corner_hz": 50.0}}
gyro = [ch(f"gyro_{a}", "gyro", 0.15 * d / 60, 4 * d / 3600, 2 * d / 3600 / 60) for a in "xyz"]
accel = [ch(f"accel_{a}", "accel", 60e-6 * 9.81, 20e-6 * 9.81, 1e-6) for a in "xyz"]
print(json.dumps({"rate_hz": 200.0, "duration_s": 3600.0, "seed": seed, "channels": gyro + accel}))
PY
  "$BIN" simulate --spec "$WORK/spec.json" -o "$f" -q
done
rm -rf "$WORK/out"
echo "screen of $N sensors (6 channels, 1 h at 200 Hz each) on $(nproc) cores, CPU backend:"
/usr/bin/time -f "%e s wall, %U s user, %M KB peak resident" \
  "$BIN" screen "$WORK/in" -o "$WORK/out" --backend cpu --quiet 2> "$WORK/time.txt" || true
cat "$WORK/time.txt"
wall=$(grep -o '^[0-9.]* s wall' "$WORK/time.txt" | cut -d' ' -f1)
python3 -c "print(f'{$N / $wall:.3f} sensors/s, {$wall / $N:.2f} s per sensor')"
