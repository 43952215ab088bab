#!/usr/bin/env python3
"""A second simulator, independent of the crate's own (`src/sim`): numpy/scipy, written apart from it,
so that the loop is also judged on records its own simulator does not make (FFT-shaped flicker,
bilinear digital resonances and filters, int16 output, a temperature with a random-walk wander).

usage: python3 validation/independent/sim.py {effects|clean} SEED OUT.arrow   (writes OUT.arrow and OUT.truth.json)

Per seed: (rate, duration) cycles over (200 Hz, 30 min), (100 Hz, 60 min), (400 Hz, 20 min)
by seed % 3.  Every channel: white noise N, true 1/f flicker (FFT-shaped, S2(f)=B^2/(2 pi f),
two-sided, from 1/(2T) to Nyquist), rate random walk K; then a digital Butterworth low-pass
(order 2 or 4, corner 0.25-0.40 fs, random per seed), then output glitches (spikes channel only),
then int16 quantisation (gyro 1/131 deg/s per LSB, accel 1/16384 g per LSB).
A temperature channel (float32 degC, 1/256 degC resolution) warms by dT=6 C with tau=600 s.

effects file (one planted effect per channel, applied before the low-pass except spikes):
  gyro_x  wandering vibration line, f0=0.045 fs, frequency f0 + 0.3 Hz*sin(2 pi t/P) + slow RW,
          amplitude 5e-4 rad/s (input), truth also given after the filter gain
  gyro_y  resonance: 2nd-order band-pass (bilinear) f0=0.07 fs, Q=20, sigma 3e-4 rad/s, white-driven
  gyro_z  first-order Gauss-Markov, Tc log-uniform in [1,300] s, sigma 1e-4 rad/s
  gyro_d  exponential warm-up drift A(1-exp(-t/300 s)), A=150 deg/h (no temperature link)
  accel_x bias step of 1.5e-3 m/s^2 at a random time in [0.2T, 0.8T]
  accel_y temperature coupling 5e-4 (m/s^2)/degC applied to the true temperature
  accel_z 20 output glitches of +-(10..30) sigma_out (after the filter), + gravity 9.80665
effects2 (other seeds' rng): gyro_x a STATIONARY line of 1.5e-4 at 0.045 fs*(1+-2%), gyro_y resonance Q=50
  sigma 1.5e-4, gyro_z GM Tc log-uniform in [1,30] s, accel_x step 3e-3, accel_y coupling 1.5e-3 (m/s^2)/degC.
clean file: the same channels, no planted effect (temperature channel still warming).
"""
import json
import sys

import numpy as np
import pyarrow as pa
from scipy import signal

D2R = np.pi / 180.0


def flicker(rng, n, fs, B):
    """1/f rate noise with two-sided PSD B^2/(2 pi f) for f >= 1/(2T)."""
    T = n / fs
    f = np.fft.rfftfreq(n, 1 / fs)
    S = np.zeros_like(f)
    m = f > 0
    fm = np.maximum(f[m], 1 / (2 * T))
    S[m] = B ** 2 / (2 * np.pi * fm)
    X = np.sqrt(n * fs * S / 2) * (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f)))
    X[0] = 0
    if n % 2 == 0:
        X[-1] = np.sqrt(n * fs * S[-1]) * rng.standard_normal()
    return np.fft.irfft(X, n)


def base(rng, n, fs, N, B, K):
    w = N * np.sqrt(fs) * rng.standard_normal(n)
    fl = flicker(rng, n, fs, B)
    rw = np.cumsum(K * np.sqrt(1 / fs) * rng.standard_normal(n))
    return w + fl + rw


def main():
    kind, seed, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    rng = np.random.default_rng({"effects": 1000, "clean": 5000, "effects2": 9000}[kind] + seed)
    e2 = kind == "effects2"
    if e2:
        kind = "effects"
    fs, minutes = [(200.0, 30), (100.0, 60), (400.0, 20)][seed % 3]
    n = int(fs * minutes * 60)
    t = np.arange(n) / fs
    T = n / fs
    order = int(rng.choice([2, 4]))
    corner = float(rng.uniform(0.25, 0.40) * fs)
    sos = signal.butter(order, corner, fs=fs, output="sos")

    def gain(f):
        w, h = signal.sosfreqz(sos, worN=[f], fs=fs)
        return float(abs(h[0]))

    gN, gB, gK = 0.15 * D2R / 60, 4 * D2R / 3600, 10 * D2R / 3600 / 60  # rad/s/sqrtHz, rad/s, rad/s/sqrt(s)
    aN, aB, aK = 1e-3, 20e-6 * 9.80665, 1e-5
    gh = (1 / 131) * D2R  # rad/s per LSB
    ah = 9.80665 / 16384  # m/s^2 per LSB

    # temperature
    dT, tauT = 6.0, 600.0
    Ttrue = 25.0 + dT * (1 - np.exp(-t / tauT)) + 0.05 * np.cumsum(rng.standard_normal(n)) / np.sqrt(fs * 60)
    Tmeas = np.round((Ttrue + 0.02 * rng.standard_normal(n)) * 256) / 256

    chans = {}
    truth = {"kind": kind, "seed": seed, "rate_hz": fs, "duration_s": T, "filter": {"order": order, "corner_hz": corner},
             "gyro": {"N": gN, "B": gB, "K": gK, "lsb": gh, "N_with_quant": float(np.sqrt(gN**2 + gh**2 / (12 * fs)))},
             "accel": {"N": aN, "B": aB, "K": aK, "lsb": ah, "N_with_quant": float(np.sqrt(aN**2 + ah**2 / (12 * fs)))},
             "effects": {}}
    names = ["gyro_x", "gyro_y", "gyro_z", "gyro_d", "accel_x", "accel_y", "accel_z"]
    for nm in names:
        g = nm.startswith("gyro")
        x = base(rng, n, fs, *(gN, gB, gK) if g else (aN, aB, aK))
        post = np.zeros(n)
        if kind == "effects":
            if nm == "gyro_x":
                f0 = 0.045 * fs
                P = rng.uniform(300, 900)
                wander = 0.0 if e2 else 0.3
                f0 = f0 * (1 + 0.02 * rng.uniform(-1, 1)) if e2 else f0
                rw = np.cumsum(rng.standard_normal(n)) / np.sqrt(fs)
                rw = rw - rw.mean()
                rw = 0.05 * rw / max(1e-12, np.abs(rw).max())
                finst = f0 + wander * np.sin(2 * np.pi * t / P + rng.uniform(0, 6.28)) + (0 if e2 else 1) * rw
                ph = 2 * np.pi * np.cumsum(finst) / fs
                A = 1.5e-4 if e2 else 5e-4
                x += A * np.sin(ph)
                truth["effects"][nm] = {"type": "line" if e2 else "wandering_line", "f_center_hz": f0, "f_min_hz": float(finst.min()),
                                        "f_max_hz": float(finst.max()), "wander_period_s": P, "amplitude_input": A,
                                        "amplitude_after_filter": A * gain(f0)}
            elif nm == "gyro_y":
                f0, Q, sig = (0.07 * fs, 50.0, 1.5e-4) if e2 else (0.07 * fs, 20.0, 3e-4)
                w0 = 2 * np.pi * f0
                b, a = signal.bilinear([w0 / Q, 0], [1, w0 / Q, w0 ** 2], fs=fs)
                # prewarp not applied: compute the actual digital peak
                imp = signal.lfilter(b, a, np.r_[1.0, np.zeros(200000)])
                e = rng.standard_normal(n)
                r = signal.lfilter(b, a, e) / np.sqrt(np.sum(imp ** 2))
                x += sig * r
                wd, hd = signal.freqz(b, a, worN=2 ** 18, fs=fs)
                fpk = float(wd[np.argmax(abs(hd))])
                hm = abs(hd) ** 2 >= 0.5 * abs(hd).max() ** 2
                bw = float(wd[hm].max() - wd[hm].min())
                truth["effects"][nm] = {"type": "resonance", "f0_hz_analog": f0, "f0_hz_digital_peak": fpk, "Q": Q, "Q_digital_3dB": fpk / bw,
                                        "sigma": sig, "sigma_after_filter_approx": sig * gain(fpk)}
            elif nm == "gyro_z":
                Tc = float(np.exp(rng.uniform(np.log(1), np.log(30 if e2 else 300))))
                sig = 1e-4
                a = np.exp(-1 / (fs * Tc))
                e = sig * np.sqrt(1 - a ** 2) * rng.standard_normal(n)
                e[0] = sig * rng.standard_normal()
                x += signal.lfilter([1.0], [1.0, -a], e)
                truth["effects"][nm] = {"type": "gauss_markov", "Tc_s": Tc, "sigma": sig, "record_over_Tc": T / Tc}
            elif nm == "gyro_d":
                A, td = 150 * D2R / 3600, 300.0
                x += A * (1 - np.exp(-t / td))
                truth["effects"][nm] = {"type": "drift_exp", "amplitude": A, "tau_s": td}
            elif nm == "accel_x":
                ts = float(rng.uniform(0.2, 0.8) * T)
                s = (3e-3 if e2 else 1.5e-3) * rng.choice([-1, 1])
                x += s * (t >= ts)
                truth["effects"][nm] = {"type": "step", "time_s": ts, "size": s}
            elif nm == "accel_y":
                c = 1.5e-3 if e2 else 5e-4
                x += c * (Ttrue - 25.0)
                truth["effects"][nm] = {"type": "coupling", "coef": c, "dT": float(Ttrue[-1] - Ttrue[0])}
        # remove filter start-up transient influence by prepending? use steady-state init
        zi = signal.sosfilt_zi(sos) * x[0]
        y, _ = signal.sosfilt(sos, x, zi=zi)
        if kind == "effects" and nm == "accel_z":
            sd = aN * np.sqrt(fs)
            idx = np.sort(rng.choice(np.arange(100, n - 100), 20, replace=False))
            amp = rng.uniform(10, 30, 20) * sd * rng.choice([-1, 1], 20)
            y[idx] += amp
            truth["effects"][nm] = {"type": "spikes", "count": 20, "sigma_white_prefilter": sd,
                                    "amp_abs_min": float(abs(amp).min()), "amp_abs_max": float(abs(amp).max())}
        if nm == "accel_z":
            y = y + 9.80665
        h = gh if g else ah
        q = np.round(y / h)
        assert np.abs(q).max() < 32767, nm
        chans[nm] = (q.astype(np.int16), "deg/s" if g else "m/s^2", "gyro" if g else "accel",
                     repr(1 / 131) if g else repr(1 / 16384), "deg/s" if g else "g")
    fields, arrays = [], []
    for nm, (q, unit, knd, scale, sunit) in chans.items():
        fields.append(pa.field(nm, pa.int16(), metadata={"unit": sunit, "kind": knd, "scale": scale}))
        arrays.append(pa.array(q))
    fields.append(pa.field("temperature", pa.float32(), metadata={"unit": "degC", "kind": "temperature"}))
    arrays.append(pa.array(Tmeas.astype(np.float32)))
    schema = pa.schema(fields, metadata={"sample_rate_hz": str(fs), "source": "sim.py"})
    with pa.OSFile(out, "wb") as f, pa.ipc.new_file(f, schema) as w:
        w.write_table(pa.Table.from_arrays(arrays, schema=schema))
    json.dump(truth, open(out.replace(".arrow", ".truth.json"), "w"), indent=1)


if __name__ == "__main__":
    main()
