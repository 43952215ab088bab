#!/usr/bin/env python3
"""Calibration of the coefficient intervals, per case, domain and term, from the JSON lines the
validation example appends with `VALIDATION_DUMP=path` (one line per simulated record: each
domain's kept terms with their 1σ intervals, and the combined terms).

    VALIDATION_DUMP=/tmp/v.jsonl cargo run --release --example validation -- 50 1800
    python3 validation/calibration.py /tmp/v.jsonl > validation/calibration.md

For each estimate the normalised error is ln(truth/value) over the interval's half-width in log
on the side the truth lies (ln(hi/value) above, ln(value/lo) below): a calibrated 1σ interval
gives a median |error| of 0.674 and covers the truth in 68.3 % of records. Coverage alone, from
50 seeds, has a binomial standard error of 6.6 points; the median |error| says more per seed.
A median |error| above 0.674 means intervals too narrow (or a bias), below means too wide.
"""

import json
import math
import statistics
import sys


def normalised_error(value, lo, hi, truth):
    if truth >= value:
        width = math.log(hi / value) if hi > value else 0.0
    else:
        width = math.log(value / lo) if 0.0 < lo < value else 0.0
    error = math.log(truth / value)
    if width <= 0.0:
        return math.inf if error != 0.0 else 0.0
    return error / width


def main(path):
    rows = [json.loads(line) for line in open(path, encoding="utf-8")]
    cases = list(dict.fromkeys(r["case"] for r in rows))
    print("| case | records | domain | term | kept | coverage (1σ, nominal 68.3 %) | "
          "median abs. normalised error (0.674) | 90th percentile (1.645) | median ratio |")
    print("|---|---|---|---|---|---|---|---|---|")
    for case in cases:
        records = [r for r in rows if r["case"] == case]
        for domain in ("combined", "allan", "spectrum"):
            for term in ("N", "B", "K"):
                errors, ratios, covered = [], [], 0
                for r in records:
                    fit = r.get(domain)
                    if fit is None:
                        continue
                    terms = fit if domain == "combined" else fit["terms"]
                    found = [t for t in terms if t["term"] == term]
                    if not found:
                        continue
                    e, truth = found[0], r["truth"][term]
                    if truth <= 0.0:
                        # None planted (the case without K): no error to normalise; results.md
                        # says how often the term was kept all the same.
                        continue
                    covered += e["lo"] <= truth <= e["hi"]
                    errors.append(abs(normalised_error(e["value"], e["lo"], e["hi"], truth)))
                    ratios.append(e["value"] / truth)
                if not errors:
                    continue
                errors.sort()
                print(f"| {case} | {len(records)} | {domain} | {term} | {len(errors)} | "
                      f"{100 * covered / len(errors):.0f} % | {statistics.median(errors):.2f} | "
                      f"{errors[int(0.9 * (len(errors) - 1))]:.2f} | "
                      f"{statistics.median(ratios):.3f} |")


if __name__ == "__main__":
    main(sys.argv[1])
