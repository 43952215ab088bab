#!/usr/bin/env bash
# False effects on clean accelerometers whose rate random walk rules from about 20 s on (B hidden
# under it), as a fleet of MEMS units records them: validation/k_dominated_spec.json (6 channels,
# N 40 ug/sqrt(Hz), B 10 ug, K 3 ug/sqrt(s), a 40-Hz low-pass, a 0.122-mg output step, 20 min at
# 200 Hz), SEEDS seeds from 101 (default 100), analysed as `analyze` runs them; prints every
# effect the loop added and the totals (about 1 min on 2 cores after the release build).
# Usage: validation/k_dominated.sh [SEEDS] > validation/k_dominated.md
set -euo pipefail
cd "$(dirname "$0")/.."
seeds="${1:-100}"
bin=target/release/imunoise
cargo build --release --quiet
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for s in $(seq 101 $((100 + seeds))); do
  "$bin" simulate --spec validation/k_dominated_spec.json --seed "$s" -o "$work/s$s.arrow" --quiet
done
"$bin" analyze "$work"/*.arrow -o "$work/out" --quiet --format json 2>/dev/null || true
echo "# False effects on K-dominated clean accelerometers"
echo
echo "\`validation/k_dominated.sh $seeds\` on $(date -u +%Y-%m-%d), commit $(git rev-parse --short HEAD)."
echo
python3 - "$work/out/report.json" <<'PY'
import collections, json, sys
doc = json.load(open(sys.argv[1]))
kinds = collections.Counter()
files = channels = with_effect = 0
rows = []
for f in doc["files"]:
    files += 1
    hit = False
    for a in f.get("analysis") or []:
        channels += 1
        for s in (a.get("residual_loop") or {}).get("steps", []):
            kinds[s["effect"]["kind"]] += 1
            hit = True
            rows.append((f["path"].split("/")[-1], a["channel"], s["effect"]["kind"], s["delta_bic"]))
    with_effect += hit
print(f"{files} records, {channels} channels; records with an effect added: {with_effect}; effects: "
      + (", ".join(f"{k} {v}" for k, v in sorted(kinds.items())) or "none"))
print()
print("| record | channel | effect | ΔBIC |")
print("|---|---|---|---|")
for r in rows:
    print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.1f} |")
PY
