#!/bin/bash
# The residual loop on records of the independent simulator (sim.py), with the truth known.
# usage: validation/independent/run.sh SEEDS [BINARY]   e.g. validation/independent/run.sh 10
# Runs `analyze` on SEEDS records of each kind (effects: one planted effect per channel;
# effects2: other sizes; clean: the same sensor, nothing planted), keeps report.json per record
# under validation/independent/runs/ (ignored by git), then prints the scores (score.py) as markdown.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
seeds=${1:-10}
bin=${2:-$root/target/release/imunoise}
runs=${RUNS:-$here/runs}
mkdir -p "$runs"
for kind in effects effects2 clean; do
  for ((s = 0; s < seeds; s++)); do
    f=$runs/${kind}_$s.arrow
    [ -f "$runs/${kind}_$s.report.json" ] && continue
    python3 "$here/sim.py" "$kind" "$s" "$f"
    "$bin" analyze "$f" -o "$runs/out_${kind}_$s" --quiet --format json >/dev/null 2>&1 || true
    cp "$runs/out_${kind}_$s/report.json" "$runs/${kind}_$s.report.json"
    rm -rf "$runs/out_${kind}_$s" "$f"
  done
done
python3 "$here/score.py" "$runs"
