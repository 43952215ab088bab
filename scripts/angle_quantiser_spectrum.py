#!/usr/bin/env python3
"""The spectrum of a coarse angle quantiser against IEEE 952's quantisation form.

White rate noise of density N (two-sided, rad/s/sqrt(Hz)) at fs is integrated, the angle rounded
to steps of r per-sample angle sigma (N/sqrt(fs)), and differenced back to a rate. The Welch
spectrum (4096-sample segments, one-sided, halved to two-sided) is divided by N^2 plus IEEE 952's
(4 Q^2 / tau0) sin^2(pi f tau0) with Q = step/sqrt(12). Printed: the mean ratio over frequency
bands, per r. This is the study behind ANGLE_ERROR_CORRELATED_FROM_STEPS in
src/model/resolution.rs (numpy and scipy; about 20 s).

    python3 scripts/angle_quantiser_spectrum.py
"""
import numpy as np
from scipy.signal import welch

FS = 100.0
N = 4.36e-5  # 0.15 deg/sqrt(h)
SAMPLES = 2_000_000


def main():
    rng = np.random.default_rng(2)
    tau0 = 1.0 / FS
    rate = rng.standard_normal(SAMPLES) * N * np.sqrt(FS)
    angle = np.cumsum(rate) * tau0
    bands = [(1, 5), (10, 20), (20, 30), (30, 40), (40, 50)]
    print("r (steps per sigma) | output levels | " + " | ".join(f"{a}-{b} Hz" for a, b in bands))
    for r in [0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.5]:
        step = r * N / np.sqrt(FS)
        q = step / np.sqrt(12.0)
        rounded = np.round(angle / step) * step
        out = np.diff(np.concatenate([[0.0], rounded])) / tau0
        f, p = welch(out, FS, nperseg=4096)
        p = p / 2.0
        model = N**2 + 4.0 * q**2 / tau0 * np.sin(np.pi * f * tau0) ** 2
        ratio = p / model
        levels = len(np.unique(np.round(out / (step / tau0))))
        cells = [f"{ratio[(f >= a) & (f < b)].mean():.3f}" for a, b in bands]
        print(f"{r} | {levels} | " + " | ".join(cells))


if __name__ == "__main__":
    main()
