#!/usr/bin/env python3
"""Makes data/sample_imu.arrow, the small recording the README's quick start runs on.

A static 6-axis IMU with its temperature sensor, 15 minutes at 100 Hz (90,000 rows), written as an
Arrow IPC file with units, kinds, integer scale and the sample rate in its metadata:

  time          timestamp[ns, UTC], from 2026-01-01T00:00:00Z
  gyro_x/y/z    float32, deg/s  (kind gyro)
  accel_x/y/z   int32 counts, scale 1e-5 -> m/s^2  (kind accel)
  temperature   float32, degC

Noise (truth, per axis):
  gyro   angle random walk N = 0.15 deg/sqrt(h) (= 0.0025 deg/s/sqrt(Hz)), bias instability (true 1/f
         flicker) B = 4 deg/h, rate random walk K = 2 deg/h/sqrt(h), and a bias offset per axis.
  accel  velocity random walk 0.06 m/s/sqrt(h) (= 1e-3 m/s^2/sqrt(Hz)), flicker 20 ug, gravity on z.
  temperature  warms by 3 degC with a 5-minute time constant, plus 0.01 degC white noise.
Effects the IEEE model does not contain (for the residual loop to find):
  accel_x   a 12.5 Hz vibration line of amplitude 2e-3 m/s^2 (a pump on the bench);
  gyro_z    a temperature coupling of 0.02 deg/s per degC.

Run: python3 scripts/make_sample.py   (numpy and pyarrow; seed fixed, output deterministic for a given
numpy version).
"""
import pathlib

import numpy as np
import pyarrow as pa
import pyarrow.ipc as ipc

RATE = 100.0
N = 90_000
SEED = 20261121
OUT = pathlib.Path(__file__).resolve().parent.parent / "data" / "sample_imu.arrow"


def flicker(rng, n, rate, b_coeff):
    """Noise with a true 1/f PSD over the whole band, scaled so that its Allan deviation plateau is
    0.664*B (IEEE 952: S(f) = B^2/(2*pi*f), two-sided)."""
    white = rng.standard_normal(n)
    spec = np.fft.rfft(white)
    f = np.fft.rfftfreq(n, 1.0 / rate)
    shape = np.zeros_like(f)
    shape[1:] = 1.0 / np.sqrt(f[1:])
    x = np.fft.irfft(spec * shape, n)
    # White noise of unit variance has two-sided PSD 1/rate; shaping by f^-1/2 gives 1/(rate*f).
    # Target two-sided B^2/(2 pi f)  ->  multiply by B*sqrt(rate/(2 pi)).
    return x * b_coeff * np.sqrt(rate / (2 * np.pi))


def main():
    rng = np.random.default_rng(SEED)
    t = np.arange(N) / RATE
    deg = np.pi / 180.0
    temperature = 25.0 + 3.0 * (1 - np.exp(-t / 300.0)) + 0.01 * rng.standard_normal(N)

    cols = {}
    n_gyro = 0.15 / 60.0  # deg/s/sqrt(Hz)
    b_gyro = 4.0 / 3600.0  # deg/s
    k_gyro = 2.0 / 3600.0 / 60.0  # deg/s/sqrt(s)
    for axis, bias in zip("xyz", (0.02, -0.015, 0.01)):
        w = n_gyro * np.sqrt(RATE) * rng.standard_normal(N)
        rrw = np.cumsum(k_gyro / np.sqrt(RATE) * rng.standard_normal(N))
        g = bias + w + flicker(rng, N, RATE, b_gyro) + rrw
        if axis == "z":
            g += 0.02 * (temperature - 25.0)
        cols[f"gyro_{axis}"] = g.astype(np.float32)

    n_acc = 1e-3  # m/s^2/sqrt(Hz)
    b_acc = 20e-6 * 9.80665  # m/s^2
    for axis, offset in zip("xyz", (0.05, -0.03, 9.80665)):
        a = offset + n_acc * np.sqrt(RATE) * rng.standard_normal(N) + flicker(rng, N, RATE, b_acc)
        if axis == "x":
            a += 2e-3 * np.sin(2 * np.pi * 12.5 * t + 0.3)
        cols[f"accel_{axis}"] = np.round(a / 1e-5).astype(np.int32)

    start = np.datetime64("2026-01-01T00:00:00", "ns").astype(np.int64)
    times = start + np.round(t * 1e9).astype(np.int64)

    fields = [pa.field("time", pa.timestamp("ns", tz="UTC"))]
    arrays = [pa.array(times, type=pa.timestamp("ns", tz="UTC"))]
    for axis in "xyz":
        fields.append(pa.field(f"gyro_{axis}", pa.float32(), metadata={"unit": "deg/s", "kind": "gyro"}))
        arrays.append(pa.array(cols[f"gyro_{axis}"]))
    for axis in "xyz":
        fields.append(
            pa.field(f"accel_{axis}", pa.int32(), metadata={"unit": "m/s^2", "kind": "accel", "scale": "1e-5"})
        )
        arrays.append(pa.array(cols[f"accel_{axis}"]))
    fields.append(pa.field("temperature", pa.float32(), metadata={"unit": "degC", "kind": "temperature"}))
    arrays.append(pa.array(temperature.astype(np.float32)))

    schema = pa.schema(fields, metadata={"sample_rate_hz": str(RATE), "source": "scripts/make_sample.py"})
    table = pa.Table.from_arrays(arrays, schema=schema)
    OUT.parent.mkdir(exist_ok=True)
    with ipc.new_file(OUT, schema) as w:
        for batch in table.to_batches(max_chunksize=16_384):
            w.write_batch(batch)
    print(f"wrote {OUT} ({OUT.stat().st_size / 1e6:.2f} MB, {N} rows)")


if __name__ == "__main__":
    main()
