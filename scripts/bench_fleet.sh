#!/usr/bin/env bash
# Fleet throughput, end to end as a user runs it: N simulated 6-axis IMUs (1 h at 200 Hz, f64,
# a 2nd-order 50 Hz anti-alias filter, datasheet-like noise, one seed each) screened by
# `imunoise screen`; prints wall time, sensors per second and peak resident memory.
#
# Usage: cargo build --release && [BACKEND=cpu|gpu|auto] [THREADS=1] scripts/bench_fleet.sh [N=256] [WORK=/tmp/imunoise-fleet]
# BACKEND (default cpu) and THREADS (files analysed at once, default 1) are passed to screen.
# Needs about 40 MB of disk per sensor. Generation (on every core) is not timed.
set -euo pipefail
N="${1:-256}"
WORK="${2:-/tmp/imunoise-fleet}"
BACKEND="${BACKEND:-cpu}"
THREADS="${THREADS:-1}"
BIN="${BIN:-$(cd "$(dirname "$0")/.." && pwd)/target/release/imunoise}"
export BIN WORK N
mkdir -p "$WORK/in"
generate() {
  local i=$1 f
  f="$WORK/in/imu_$(printf %04d "$i").arrow"
  [ -f "$f" ] && return 0
  python3 - "$i" > "$WORK/spec_$i.json" <<'PY'
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
  mkdir -p "$WORK/tmp"
  "$BIN" simulate --spec "$WORK/spec_$i.json" -o "$WORK/tmp/${f##*/}" -q && mv "$WORK/tmp/${f##*/}" "$f"
  rm -f "$WORK/spec_$i.json"
}
export -f generate
seq 1 "$N" | xargs -P "$(nproc)" -I{} bash -c 'generate {}'
rm -rf "$WORK/out"
echo "screen of $N sensors (6 channels, 1 h at 200 Hz each) on $(nproc) cores, backend $BACKEND, $THREADS file(s) at once:"
# Timed by the parent (wait4), so that no GNU time is needed: wall, CPU and peak resident memory.
# Not --quiet: the screen's last lines give the time by stage (read, estimate, fit, write),
# printed below; its per-file lines go to $WORK/screen.log.
python3 - "$BIN" screen "$WORK/in" -o "$WORK/out" --backend "$BACKEND" --threads "$THREADS" <<'PY'
import os, subprocess, sys, time
n = int(os.environ["N"])
log = open(os.path.join(os.environ["WORK"], "screen.log"), "w")
t0 = time.perf_counter()
p = subprocess.Popen(sys.argv[1:], stderr=log)
_, status, ru = os.wait4(p.pid, 0)
wall = time.perf_counter() - t0
code = os.waitstatus_to_exitcode(status)
print(f"{wall:.2f} s wall, {ru.ru_utime:.1f} s user, {ru.ru_stime:.1f} s system, "
      f"{ru.ru_maxrss / 1024:.0f} MiB peak resident, exit status {code}")
print(f"{n / wall:.3f} sensors/s, {wall / n:.2f} s per sensor")
PY
grep -E "^(time of|imunoise: backend)" "$WORK/screen.log" || true
