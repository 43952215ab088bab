#!/usr/bin/env python3
"""Generate tests/data/avar/allantools_parity.json: allantools results on seeded random data.

What it writes: 3000 rate samples at 50 Hz (white noise + a random walk + an offset, numpy
default_rng seed 20240601, so the file is the same on every run), and allantools' oadev, adev,
mdev, hdev and ohdev of them with data_type="freq" on the "octave", "decade" and "all" tau grids:
for each, the averaging factors m = tau * rate, the deviations and allantools' term counts n.
The Rust tests (tests/integration/avar/allantools.rs) recompute every deviation and require
agreement to 1e-10 relative.

Run from the repository root:

    python3 scripts/make_avar_fixtures.py

Made with Python 3.11, numpy, allantools 2024.06 (the versions are recorded in the file).
"""

import json
import os

import allantools
import numpy as np

SEED = 20240601
N = 3000
RATE_HZ = 50.0
STATISTICS = ["oadev", "adev", "mdev", "hdev", "ohdev"]
GRIDS = ["octave", "decade", "all"]
OUT = os.path.join("tests", "data", "avar", "allantools_parity.json")


def make_data():
    rng = np.random.default_rng(SEED)
    white = rng.standard_normal(N)
    walk = np.cumsum(rng.standard_normal(N)) * 0.05
    return 10.0 + white + walk


def main():
    y = make_data()
    results = []
    for stat in STATISTICS:
        func = getattr(allantools, stat)
        for grid in GRIDS:
            taus, devs, _errs, ns = func(y, rate=RATE_HZ, data_type="freq", taus=grid)
            m = [int(round(t * RATE_HZ)) for t in taus]
            results.append(
                {
                    "statistic": stat,
                    "grid": grid,
                    "m": m,
                    "deviation": [float(d) for d in devs],
                    "n": [int(n) for n in ns],
                }
            )
    fixture = {
        "description": "allantools deviations of seeded random rate data, data_type='freq'",
        "generator": "scripts/make_avar_fixtures.py",
        "seed": SEED,
        "allantools_version": allantools.__version__,
        "numpy_version": np.__version__,
        "rate_hz": RATE_HZ,
        "y": [float(v) for v in y],
        "results": results,
    }
    with open(OUT, "w") as f:
        json.dump(fixture, f, separators=(",", ":"))
        f.write("\n")
    print(f"wrote {OUT} ({os.path.getsize(OUT)} bytes, {len(results)} result sets)")


if __name__ == "__main__":
    main()
