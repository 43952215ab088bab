#!/usr/bin/env bash
# Reruns the validation study and writes validation/results.md (about 5 min on 2 cores with the
# defaults: 32 cases × 50 seeds, 30 min at 100 Hz unless a case says otherwise).
set -euo pipefail
cd "$(dirname "$0")/.."
seeds="${1:-50}"
seconds="${2:-1800}"
{
  echo "# Validation of the model stage"
  echo
  echo "\`validation/run.sh $seeds $seconds\` on $(date -u +%Y-%m-%d), commit $(git rev-parse --short HEAD)."
  echo
  cargo run --release --quiet --example validation -- "$seeds" "$seconds"
} > validation/results.md
cat validation/results.md
