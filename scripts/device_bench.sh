#!/usr/bin/env bash
# One call on a machine with a hardware GPU: the GPU tests, the in-memory CPU/GPU comparison with
# kernel time and bandwidth, the end-to-end comparison against scipy and allantools on both
# backends, `analyze` of the sample on each backend, the fleet of 256 sensors on each backend,
# the GPU's fixed cost (driver, device, pipelines, close) and the three backends end to end at
# 10⁷ and 10⁸ samples. Prints a log meant to be kept in benches/results/.
#
# Usage: [STAGES="tests throughput peers analyze fleet startup e2e"] [OLD_BIN=path]
#        scripts/device_bench.sh BINDIR [FLEET_N=256]
# BINDIR holds release builds made elsewhere: imunoise, gpu_throughput and gpu_startup (the
# examples) and integration (the integration-test executable, `cargo test --release --no-run`).
# The tests were compiled with this checkout at /work/main, so that path is linked here when it is
# missing. OLD_BIN, if given, is an earlier imunoise run beside the current one in `e2e`.
# Needs python3 with numpy, pyarrow and scipy; allantools where it is installed (else no peers).
set -uo pipefail
BINDIR="$(cd "$1" && pwd)"
FLEET_N="${2:-256}"
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
if [ ! -e /work/main ]; then mkdir -p /work && ln -s "$ROOT" /work/main; fi
mkdir -p target/release && cp "$BINDIR/imunoise" target/release/imunoise
nvidia-smi --query-gpu=name,memory.total,clocks.max.memory,clocks.max.sm,driver_version --format=csv 2>/dev/null
echo "cores $(nproc), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
date
section() { echo "== $*"; }
STAGES="${STAGES:-tests throughput peers analyze fleet}"
stage() { [[ " $STAGES " == *" $1 "* ]]; }

if stage tests; then
section "GPU tests and the CLI's --backend gpu test (IMUNOISE_REQUIRE_GPU=1)"
IMUNOISE_REQUIRE_GPU=1 "$BINDIR/integration" gpu:: 2>&1 | grep -E "test result|FAILED|panicked" | head -20
IMUNOISE_REQUIRE_GPU=1 "$BINDIR/integration" backend_gpu_agrees_with_cpu 2>&1 | grep -E "test result|FAILED|panicked" | head -5
fi

if stage throughput; then
section "gpu_throughput 2e7 6 4800 (one backend call on data in memory, fastest of three)"
"$BINDIR/gpu_throughput" 2e7 6 4800 2>&1 | tail -8
fi

if stage peers; then
section "end to end against the peers, 1e7 samples (REPEATS=3)"
if python3 -c "import allantools" 2>/dev/null; then PEERS=""; else PEERS="--no-peers"; fi
IMUNOISE_BIN="$BINDIR/imunoise" REPEATS=3 python3 scripts/compare_peers.py --backends cpu,gpu $PEERS 2>&1 | tail -30
fi

if stage analyze; then
section "analyze data/sample_imu.arrow, cpu then gpu (end to end)"
for b in cpu gpu; do
  /usr/bin/env python3 - "$BINDIR/imunoise" analyze data/sample_imu.arrow -o "/tmp/sample_$b" -q --backend "$b" <<'PY'
import os, subprocess, sys, time
t0 = time.perf_counter(); p = subprocess.Popen(sys.argv[1:]); _, st, ru = os.wait4(p.pid, 0)
print(f"{sys.argv[-1]}: {time.perf_counter() - t0:.2f} s wall, {ru.ru_maxrss // 1024} MiB peak, exit {os.waitstatus_to_exitcode(st)}")
PY
done
fi

if stage fleet; then
section "fleet of $FLEET_N sensors, cpu then gpu, 16 files at once"
date
BIN="$BINDIR/imunoise" BACKEND=cpu THREADS=16 scripts/bench_fleet.sh "$FLEET_N" /tmp/fleet
date
BIN="$BINDIR/imunoise" BACKEND=gpu THREADS=16 scripts/bench_fleet.sh "$FLEET_N" /tmp/fleet
fi

if stage startup; then
section "gpu_startup: the GPU's fixed cost, two processes in a row"
for i in 1 2; do "$BINDIR/gpu_startup" 1; done
fi

if stage e2e; then
for n in 1e7 1e8; do
  section "cpu, gpu and auto end to end, $n samples (REPEATS=3), and the backend auto chose"
  IMUNOISE_BIN="$BINDIR/imunoise" REPEATS=3 python3 scripts/compare_peers.py --samples "$n" \
    --backends cpu,gpu,auto --no-peers --keep "/tmp/e2e_$n" 2>&1 | tail -12
  for k in welch octave log; do
    f=$(ls -d /tmp/e2e_$n/out-*auto* 2>/dev/null | grep -m1 "$k" || true)
    [ -n "$f" ] && echo "auto $k: $(grep -m1 -o '"backend": "[^"]*"' "$f/report.json")"
  done
  if [ -n "${OLD_BIN:-}" ]; then
    echo "-- the earlier build ($OLD_BIN), gpu"
    IMUNOISE_BIN="$OLD_BIN" REPEATS=3 python3 scripts/compare_peers.py --samples "$n" \
      --backends gpu --no-peers 2>&1 | tail -4
  fi
done
fi
nvidia-smi --query-gpu=memory.used,temperature.gpu --format=csv 2>/dev/null
date
