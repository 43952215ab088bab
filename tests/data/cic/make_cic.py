#!/usr/bin/env python3
"""Independent generator of tests/data/cic/cic_gyro_10min.parquet (numpy/scipy only; it does not
use `imunoise simulate`).

Two gyro axes at an output rate of 200 Hz, 10 minutes, made at the decimator's input rate and
decimated as a sigma-delta part does:
  gyro_a: white noise N through a sinc^3 decimator (3 moving averages of 8 samples at 1600 Hz,
          every 8th kept), then a 2nd-order digital Butterworth at 50 Hz (scipy.signal.butter,
          bilinear) at the output rate;
  gyro_b: white noise N through a sinc^2 decimator (2 moving averages of 16 samples at 3200 Hz,
          every 16th kept; a Bartlett window), nothing after it.
Both get a rate random walk K added at the output rate (after the filter: it lives far below the
band's edge), and are rounded to int16 counts of LSB = N*sqrt(fs)/8 (white rounding, 1/768 of the
white variance). Usage: make_cic.py OUT_DIR [SEED]  (writes the parquet and truth.json there).
"""
import json
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from scipy import signal

FS = 200.0
MINUTES = 10
N = 4.0e-5        # rad/s/sqrt(Hz)
K = 2.0e-7        # rad/s/sqrt(s)


def cic(x, stages, factor):
    h = np.ones(factor) / factor
    for _ in range(stages):
        x = signal.lfilter(h, [1.0], x)
    return x[factor - 1::factor]


def main():
    out = sys.argv[1]
    seed = int(sys.argv[2]) if len(sys.argv) > 2 else 20261129
    rng = np.random.default_rng(seed)
    n = int(FS * 60 * MINUTES)
    lsb = N * np.sqrt(FS) / 8
    cols, truth = {}, {}
    for name, stages, factor, lowpass in [("gyro_a", 3, 8, (2, 50.0)), ("gyro_b", 2, 16, None)]:
        fs_in = FS * factor
        # Warm-up of 64 output samples dropped (the filters' start transient).
        extra = 64
        w = rng.standard_normal((n + extra) * factor) * N * np.sqrt(fs_in)
        y = cic(w, stages, factor)
        if lowpass:
            b, a = signal.butter(lowpass[0], lowpass[1] / (FS / 2))
            y = signal.lfilter(b, a, y)
        y = y[extra:]
        y += np.cumsum(rng.standard_normal(n)) * K / np.sqrt(FS)
        counts = np.round(y / lsb)
        assert np.abs(counts).max() < 32767
        cols[name] = pa.array(counts.astype(np.int16))
        truth[name] = {
            "N": N, "K": K, "lsb": lsb,
            "N_with_rounding": float(np.sqrt(N**2 + lsb**2 / (12 * FS))),
            "decimator": {"stages": stages, "factor": factor},
            "lowpass": {"order": lowpass[0], "corner_hz": lowpass[1]} if lowpass else None,
        }
    fields = [pa.field(k, pa.int16(), metadata={"unit": "rad/s", "kind": "gyro",
                                                 "scale": repr(float(lsb))}) for k in cols]
    schema = pa.schema(fields, metadata={"sample_rate_hz": str(FS)})
    table = pa.Table.from_arrays(list(cols.values()), schema=schema)
    pq.write_table(table, f"{out}/cic_gyro_10min.parquet", compression="zstd",
                   compression_level=19)
    with open(f"{out}/truth.json", "w") as f:
        json.dump({"rate_hz": FS, "minutes": MINUTES, "seed": seed, "channels": truth}, f,
                  indent=1)


if __name__ == "__main__":
    main()
