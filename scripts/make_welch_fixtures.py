#!/usr/bin/env python3
"""Writes tests/data/psd/welch_scipy.json: inputs and scipy.signal.welch outputs for the parity test
(tests/integration/psd/parity.rs).

Run from the repository root:

    python3 scripts/make_welch_fixtures.py

The output is deterministic for a given numpy/scipy (fixed seed, fixed case list). The committed
fixture was made with Python 3.11, numpy 2.4.6 and scipy 1.17.1; the versions used are recorded in
the file itself ("versions").

Cases: a pairwise-covering design over window (the six named ones and a custom Kaiser window),
nperseg (64, 100, 127, 256), noverlap (default, 0, another), nfft (default, a larger even and a
larger odd one), detrend (constant, linear, none = scipy's detrend=False), scaling (density,
spectrum), average (mean, median), segment count (1, 2, 3, 4, 7, 12: both parities for the median),
input signal and sample rate: every pair of option values appears in at least one case. Input
lengths are noverlap + segments·step + a random remainder (dropped by Welch), mostly odd.
Each input signal is stored once; a case uses its first n samples.
"""

import itertools
import json
import platform
import sys
from pathlib import Path

import numpy as np
import scipy
import scipy.signal

SEED = 20240917
OUT = Path("tests/data/psd/welch_scipy.json")
SIGNAL_LEN = 3400  # enough for 12 segments of 256 without overlap plus a remainder

rng = np.random.default_rng(SEED)


def make_signals():
    t = np.arange(SIGNAL_LEN)
    # Offset, drift, white noise, a random walk and a sinusoid off the bin grid: something of every
    # kind the detrend options and windows treat differently, with a moderate dynamic range.
    mixed = (
        0.3
        + 2e-4 * t
        + rng.standard_normal(SIGNAL_LEN)
        + np.cumsum(0.02 * rng.standard_normal(SIGNAL_LEN))
        + 0.8 * np.sin(2 * np.pi * 0.1234 * t + 0.4)
    )
    white = -1.2 + 0.5 * rng.standard_normal(SIGNAL_LEN)
    # AR(1), phi = 0.9: a red spectrum (Gauss-Markov noise).
    e = rng.standard_normal(SIGNAL_LEN)
    ar = np.empty(SIGNAL_LEN)
    ar[0] = e[0]
    for i in range(1, SIGNAL_LEN):
        ar[i] = 0.9 * ar[i - 1] + e[i]
    return {"mixed": mixed, "white": white, "ar1": ar}


FACTORS = {
    "window": ["hann", "hamming", "blackman", "blackmanharris", "flattop", "boxcar", "custom"],
    "nperseg": [64, 100, 127, 256],
    "noverlap": ["default", "zero", "other"],
    "nfft": ["default", "even", "odd"],
    "detrend": ["constant", "linear", "none"],
    "scaling": ["density", "spectrum"],
    "average": ["mean", "median"],
    "segments": [1, 2, 3, 4, 7, 12],
    "signal": ["mixed", "white", "ar1"],
    "fs": [1.0, 100.0, 207.0, 1000.0],
}


def pairwise_cases():
    """Greedy pairwise covering: repeatedly add the random candidate that covers most uncovered
    pairs of factor values."""
    names = list(FACTORS)
    uncovered = {
        (a, va, b, vb)
        for a, b in itertools.combinations(names, 2)
        for va in range(len(FACTORS[a]))
        for vb in range(len(FACTORS[b]))
    }
    cases = []
    while uncovered:
        best, best_gain = None, -1
        for _ in range(200):
            cand = {f: int(rng.integers(len(FACTORS[f]))) for f in names}
            gain = sum(
                (a, cand[a], b, cand[b]) in uncovered for a, b in itertools.combinations(names, 2)
            )
            if gain > best_gain:
                best, best_gain = cand, gain
        for a, b in itertools.combinations(names, 2):
            uncovered.discard((a, best[a], b, best[b]))
        cases.append({f: FACTORS[f][i] for f, i in best.items()})
    return cases


def resolve(case):
    """Turns factor levels into welch() arguments and an input length."""
    nperseg = case["nperseg"]
    noverlap = {"default": None, "zero": 0, "other": (3 * nperseg) // 4}[case["noverlap"]]
    nfft = {
        "default": None,
        "even": 1 << (2 * nperseg - 1).bit_length(),
        "odd": nperseg + 37 if (nperseg + 37) % 2 else nperseg + 38,
    }[case["nfft"]]
    ov = nperseg // 2 if noverlap is None else noverlap
    step = nperseg - ov
    remainder = int(rng.integers(step))
    n = ov + case["segments"] * step + remainder
    assert n <= SIGNAL_LEN
    return nperseg, noverlap, nfft, n


def main():
    signals = make_signals()
    windows = {
        f"kaiser_{n}": scipy.signal.get_window(("kaiser", 8.6), n, fftbins=True)
        for n in FACTORS["nperseg"]
    }
    cases = pairwise_cases()
    # A few cases on their own: scipy's defaults, and a single segment with zero padding.
    cases += [
        dict(window="hann", nperseg=n, noverlap="default", nfft="default", detrend="constant",
             scaling="density", average="mean", segments=7, signal="mixed", fs=100.0)
        for n in FACTORS["nperseg"]
    ]
    out_cases = []
    for i, case in enumerate(cases):
        nperseg, noverlap, nfft, n = resolve(case)
        x = signals[case["signal"]][:n]
        if case["window"] == "custom":
            window_arg = windows[f"kaiser_{nperseg}"]
            window_field = {"custom": f"kaiser_{nperseg}"}
        else:
            window_arg = case["window"]
            window_field = case["window"]
        detrend = False if case["detrend"] == "none" else case["detrend"]
        f, p = scipy.signal.welch(
            x, fs=case["fs"], window=window_arg, nperseg=nperseg, noverlap=noverlap, nfft=nfft,
            detrend=detrend, scaling=case["scaling"], average=case["average"],
        )
        out_cases.append({
            "id": i,
            "signal": case["signal"],
            "n": n,
            "fs": case["fs"],
            "window": window_field,
            "nperseg": nperseg,
            "noverlap": noverlap,
            "nfft": nfft,
            "detrend": case["detrend"],
            "scaling": case["scaling"],
            "average": case["average"],
            "segments": case["segments"],
            "f_last": float(f[-1]),
            "psd": [float(v) for v in p],
        })
    doc = {
        "generator": "scripts/make_welch_fixtures.py",
        "seed": SEED,
        "versions": {
            "python": platform.python_version(),
            "numpy": np.__version__,
            "scipy": scipy.__version__,
        },
        "signals": {k: [float(v) for v in s] for k, s in signals.items()},
        "windows": {k: [float(v) for v in w] for k, w in windows.items()},
        "cases": out_cases,
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(doc, separators=(",", ":")) + "\n")
    medians = [c for c in out_cases if c["average"] == "median"]
    print(
        f"{OUT}: {len(out_cases)} cases ({len(medians)} median, segment counts "
        f"{sorted({c['segments'] for c in medians})}), {OUT.stat().st_size / 1e6:.2f} MB",
        file=sys.stderr,
    )


if __name__ == "__main__":
    main()
