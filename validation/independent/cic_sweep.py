#!/usr/bin/env python3
"""How the bandwidth detection reads decimation chains made by an independent generator
(numpy/scipy; not `imunoise simulate`), with plain low-passes as controls.

usage: validation/independent/cic_sweep.py SEEDS [BINARY] > validation/independent/cic_sweep.md

Each record: one gyro axis, 20 min at 200 Hz. White noise N = 4e-5 rad/s/sqrt(Hz) made at the
decimator's input rate, through the chain, then a rate random walk K = 2e-7 rad/s/sqrt(s) and
rounding to counts of N*sqrt(fs)/8 (int16 with a scale). Per chain it reports how often the
filter was read with a decimator and with the planted stages, the low-pass's corner against the
planted one, and N (the combined value) against the truth (white with the rounding) with its
1-sigma coverage.
"""
import json
import os
import statistics as st
import subprocess
import sys
import tempfile

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from scipy import signal

FS = 200.0
SECONDS = 1200
N = 4.0e-5
K = 2.0e-7
# name: (decimator stages, factor) or None, (low-pass order, corner) or None
CHAINS = {
    "sinc³ ↓8, then 2nd order at 50 Hz": ((3, 8), (2, 50.0)),
    "sinc³ ↓16 alone": ((3, 16), None),
    "sinc⁴ ↓4, then 1st order at 40 Hz": ((4, 4), (1, 40.0)),
    "sinc² ↓16 alone (= 1st order at fs/4 over a 1/3 floor)": ((2, 16), None),
    "control: 2nd order at 50 Hz": (None, (2, 50.0)),
    "control: 4th order at 60 Hz": (None, (4, 60.0)),
}


def record(decimator, lowpass, rng):
    n = int(FS * SECONDS)
    extra = 64
    if decimator:
        stages, factor = decimator
        w = rng.standard_normal((n + extra) * factor) * N * np.sqrt(FS * factor)
        h = np.ones(factor) / factor
        for _ in range(stages):
            w = signal.lfilter(h, [1.0], w)
        y = w[factor - 1::factor]
    else:
        y = rng.standard_normal(n + extra) * N * np.sqrt(FS)
    if lowpass:
        b, a = signal.butter(lowpass[0], lowpass[1] / (FS / 2))
        y = signal.lfilter(b, a, y)
    y = y[extra:]
    y = y + np.cumsum(rng.standard_normal(n)) * K / np.sqrt(FS)
    lsb = N * np.sqrt(FS) / 8
    return np.round(y / lsb).astype(np.int16), lsb


def main():
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    here = os.path.dirname(os.path.abspath(__file__))
    binary = sys.argv[2] if len(sys.argv) > 2 else os.path.join(
        here, "..", "..", "target", "release", "imunoise")
    print("# Decimation chains from an independent generator\n")
    print(f"`validation/independent/cic_sweep.py {seeds}`: one gyro axis per record, "
          f"{SECONDS // 60} min at {FS:g} Hz, {seeds} seeds per chain (see the script's doc).\n")
    print("| chain | filter found | read with a decimator | planted stages | corner / planted (median) "
          "| N ratio (median, range) | N 1σ coverage | what else was read |")
    print("|---|---|---|---|---|---|---|---|")
    for ci, (name, (decimator, lowpass)) in enumerate(CHAINS.items()):
        found = with_dec = stages_ok = cover = 0
        corners, ratios, other = [], [], {}
        for s in range(seeds):
            rng = np.random.default_rng(7_000_000 + 1000 * ci + s)
            counts, lsb = record(decimator, lowpass, rng)
            truth_n = float(np.sqrt(N**2 + lsb**2 / (12 * FS)))
            with tempfile.TemporaryDirectory() as tmp:
                path = os.path.join(tmp, "g.parquet")
                field = pa.field("gyro", pa.int16(), metadata={
                    "unit": "rad/s", "kind": "gyro", "scale": repr(float(lsb))})
                schema = pa.schema([field], metadata={"sample_rate_hz": str(FS)})
                pq.write_table(pa.Table.from_arrays([pa.array(counts)], schema=schema), path)
                subprocess.run([binary, "analyze", path, "-o", os.path.join(tmp, "out"),
                                "--backend", "cpu", "--quiet"], check=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                rep = json.load(open(os.path.join(tmp, "out", "report.json")))
            a = rep["files"][0]["analysis"][0]
            band = a.get("bandwidth")
            if band:
                found += 1
                lp = band["lowpass"]
                dec = lp.get("decimator")
                if dec:
                    with_dec += 1
                    stages_ok += decimator is not None and dec["stages"] == decimator[0]
                if lowpass and lp["order"] > 0:
                    corners.append(lp["corner_hz"] / lowpass[1])
                label = (f"sinc{dec['stages']}" if dec else "") + (
                    f" order {lp['order']}" if lp["order"] > 0 else "")
                other[label.strip()] = other.get(label.strip(), 0) + 1
            for t in a["combined"]["terms"]:
                if t["term"] == "random_walk":
                    ratios.append(t["value"] / truth_n)
                    cover += t["lo"] <= truth_n <= t["hi"]
        corner = f"{st.median(corners):.3f}" if corners else "–"
        reads = ", ".join(f"{k} {v}" for k, v in sorted(other.items()))
        planted = f"{stages_ok}/{seeds}" if decimator else "–"
        print(f"| {name} | {found}/{seeds} | {with_dec}/{seeds} | {planted} | {corner} | "
              f"{st.median(ratios):.4f} ({min(ratios):.4f}–{max(ratios):.4f}) | "
              f"{cover}/{len(ratios)} | {reads} |")


if __name__ == "__main__":
    main()
