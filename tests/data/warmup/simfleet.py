#!/usr/bin/env python3
"""Independent fleet simulator for qualifying `imunoise screen` (not using `imunoise simulate`).

Usage: simfleet.py OUTROOT N_UNITS SEED [--clean] [--minutes M] [--rate R] [--fmt arrow]

Writes a fleet of 6-axis IMUs (+ temperature) in mixed formats / layouts and truth.json with
per-unit, per-channel truth (N, B, K in SI, expected effective N incl. quantisation) and the list
of planted defects.
"""
import json, os, sys, shutil, argparse
import numpy as np
import pyarrow as pa, pyarrow.parquet as pq, pyarrow.ipc as ipc, pyarrow.csv as pacsv
from scipy import signal

D2R = np.pi / 180.0
G0 = 9.80665
# nominal noise (SI)
GYRO_N = 0.15 * D2R / 60.0            # 0.15 deg/sqrt(h) -> rad/s/sqrt(Hz)
GYRO_B = 3.0 * D2R / 3600.0           # 3 deg/h -> rad/s
GYRO_K = 2.0 * D2R / 3600.0 / 60.0    # 2 deg/h/sqrt(h) -> rad/s/sqrt(s)
ACC_N = 80e-6 * G0                    # 80 ug/sqrt(Hz)
ACC_B = 15e-6 * G0                    # 15 ug
ACC_K = 3e-6 * G0                     # 3 ug/sqrt(s)  (= 180 ug/sqrt(h))
GYRO_LSB = D2R / 131.0                # 1/131 deg/s per count (+-250 dps part)
ACC_LSB = 4 * G0 / 32768.0            # +-4 g in int16
SPREAD = {"N": 0.12, "B": 0.20, "K": 0.25}   # lognormal sigma of unit-to-unit spread

CH = ["gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"]


def flicker(n, fs, b, rng):
    """1/f noise whose two-sided PSD is b^2/(2 pi f) (IEEE bias instability b; Allan min 0.664 b)."""
    m = 1 << int(np.ceil(np.log2(2 * n)))
    f = np.fft.rfftfreq(m, 1 / fs)
    s1 = np.zeros_like(f)
    s1[1:] = b * b / (np.pi * f[1:])                  # one-sided
    amp = np.sqrt(s1 * fs * m / 2.0)
    z = (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f))) / np.sqrt(2)
    x = np.fft.irfft(z * amp, m)[:n]
    return x - x[0]


def channel(n, fs, N, B, K, rng):
    w = rng.standard_normal(n) * N * np.sqrt(fs)
    fl = flicker(n, fs, B, rng)
    rw = np.cumsum(rng.standard_normal(n)) * K * np.sqrt(1.0 / fs)
    return w + fl + rw


def build_unit(name, fs, minutes, rng, defects, true_fs=None):
    """Returns dict of channel arrays (SI), temperature, time (s), truth."""
    gen_fs = true_fs or fs
    n = int(round(minutes * 60 * gen_fs))
    tt = np.arange(n) / gen_fs
    truth = {}
    data = {}
    # temperature warm-up (3 degC, tc 300 s) + small wander + noise
    rise = rng.uniform(2.5, 3.5)
    temp = 22 + rise * (1 - np.exp(-tt / 300.0)) + rng.standard_normal(n) * 0.01
    temp = np.round(temp * 256) / 256
    ba, bb = signal.butter(2, 0.6, btype="low")  # corner at 0.3*fs (2-pole anti-alias)
    for c in CH:
        g = c.startswith("gyro")
        Nn, Bn, Kn = (GYRO_N, GYRO_B, GYRO_K) if g else (ACC_N, ACC_B, ACC_K)
        N = Nn * np.exp(SPREAD["N"] * rng.standard_normal())
        B = Bn * np.exp(SPREAD["B"] * rng.standard_normal())
        K = Kn * np.exp(SPREAD["K"] * rng.standard_normal())
        d = defects.get(c, {})
        N *= d.get("n_factor", 1.0)
        B *= d.get("b_factor", 1.0)
        x = channel(n, gen_fs, N, B, K, rng)
        x = signal.lfilter(ba, bb, x)
        if g:
            x += rng.normal(0, 0.3) * D2R                      # turn-on bias up to ~0.3 deg/s
            coup = rng.choice([-1, 1]) * 2e-4 * np.exp(0.2 * rng.standard_normal())  # rad/s/degC
            x += coup * (temp - temp[0])                       # warm-up through temperature
        else:
            x += rng.normal(0, 20e-3 * G0)                     # turn-on bias ~20 mg
            coup = 0.0
        if c == "accel_z":
            x += G0
        if "sine" in d:
            a, f0 = d["sine"]
            x += a * np.sin(2 * np.pi * f0 * tt + rng.uniform(0, 6.28))
        if "step" in d:
            ts, sz = d["step"]
            x[tt >= ts] += sz
        lsb = GYRO_LSB if g else ACC_LSB
        x = np.round(x / lsb) * lsb
        if "stuck" in d:
            t0, t1 = d["stuck"]
            sel = (tt >= t0) & (tt < t1)
            x[sel] = x[np.argmax(sel)]
        if "clip" in d:
            t0, t1 = d["clip"]
            sel = (tt >= t0) & (tt < t1)
            x[sel] = 32767 * lsb
        data[c] = x
        neff = np.sqrt(N * N + lsb * lsb / (12 * gen_fs))
        truth[c] = dict(N=N, B=B, K=K, N_eff=neff, coupling=coup)
    return tt, data, temp, truth


def jitter_time(tt, fs, rng):
    return tt + rng.standard_normal(len(tt)) * 0.02 / fs     # 2 % of a period rms


def write_arrow(path, t_ns, data, temp, fs_label, unit_override=None, int_counts=True):
    unit_override = unit_override or {}
    fields, cols = [pa.field("time", pa.timestamp("ns", tz="UTC"))], [pa.array(t_ns, pa.timestamp("ns", tz="UTC"))]
    for c in CH:
        g = c.startswith("gyro")
        lsb = GYRO_LSB if g else ACC_LSB
        unit = unit_override.get(c, "rad/s" if g else "m/s^2")
        if int_counts:
            cnt = np.clip(np.round(data[c] / lsb), -32768, 32767).astype(np.int16)
            fields.append(pa.field(c, pa.int16(), metadata={"unit": unit, "kind": "gyro" if g else "accel", "scale": repr(lsb)}))
            cols.append(pa.array(cnt))
        else:
            fields.append(pa.field(c, pa.float32(), metadata={"unit": unit, "kind": "gyro" if g else "accel"}))
            cols.append(pa.array(data[c].astype(np.float32)))
    fields.append(pa.field("temperature", pa.float32(), metadata={"unit": "degC", "kind": "temperature"}))
    cols.append(pa.array(temp.astype(np.float32)))
    sch = pa.schema(fields, metadata={"sample_rate_hz": str(float(fs_label))})
    tbl = pa.Table.from_arrays(cols, schema=sch)
    return tbl


def save(tbl, path, fmt):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    if fmt == "arrow":
        with ipc.new_file(path, tbl.schema) as w:
            w.write_table(tbl, max_chunksize=65536)
    elif fmt == "parquet":
        pq.write_table(tbl, path, row_group_size=131072)
    elif fmt == "csv":
        # time in s (float), gyro deg/s, accel g, temperature degC: units in the header
        t = tbl.column("time").cast(pa.int64()).to_numpy() / 1e9
        t = t - t[0]
        cols = {"time": np.round(t, 6)}
        for c in CH:
            x = tbl.column(c).to_numpy().astype(np.float64)
            md = tbl.schema.field(c).metadata
            if b"scale" in md:
                x = x * float(md[b"scale"])
            if c.startswith("gyro"):
                cols[f"{c} [deg/s]"] = np.round(x / D2R, 7)
            else:
                cols[f"{c} [g]"] = np.round(x / G0, 8)
        cols["temperature [degC]"] = np.round(tbl.column("temperature").to_numpy().astype(np.float64), 5)
        pacsv.write_csv(pa.table(cols), path, pacsv.WriteOptions(quoting_style="none"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("n", type=int)
    ap.add_argument("seed", type=int)
    ap.add_argument("--clean", action="store_true")
    ap.add_argument("--minutes", type=float)
    ap.add_argument("--rate", type=float)
    ap.add_argument("--fmt")
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    root = a.out
    if os.path.exists(root):
        shutil.rmtree(root)
    os.makedirs(root)
    fleet = os.path.join(root, "fleet")
    truth = {"units": {}, "defects": {}, "files": {}}
    # planted defects (unit index -> description)
    plan = {}
    if not a.clean:
        plan = {
            3: ("high_arw_gyro_y", {"gyro_y": {"n_factor": 3.0}}),
            7: ("high_accel_bias_instability_x", {"accel_x": {"b_factor": 6.0}}),
            11: ("vibration_line_37Hz", {c: {"sine": (0.02 if c.startswith("accel") else 2e-3, 37.0)} for c in CH}),
            15: ("bias_step_gyro_z", {"gyro_z": {"step": (400.0, 0.02 * D2R)}}),
            19: ("stuck_gyro_x_90s", {"gyro_x": {"stuck": (300.0, 390.0)}}),
            23: ("clipped_accel_z_20s", {"accel_z": {"clip": (200.0, 220.0)}}),
            27: ("gyro_z_deg_s_labelled_rad_s", {}),
            31: ("rate_200Hz_stamped_100Hz", {}),
            35: ("rate_meta_100_stamps_200", {}),
            39: ("truncated_file", {}),
            43: ("empty_file", {}),
            47: ("nan_in_accel_y", {}),
            51: ("duplicate_of_unit_50", {}),
            55: ("axes_swapped_gravity_on_x", {}),
            59: ("corrupt_csv_row", {}),
        }
    for i in range(a.n):
        name = f"IMU{i:04d}"
        # format / layout by index
        if a.fmt:
            fmt = a.fmt
        else:
            fmt = ["arrow", "parquet", "csv"][i % 3]
        fs = a.rate or [100.0, 200.0, 400.0][(i // 3) % 3] if not a.rate else a.rate
        if fmt == "csv" and not a.rate:
            fs = [100.0, 200.0][(i // 3) % 2]      # keep CSVs smaller
        minutes = a.minutes or float(rng.choice([10, 15, 20, 30]))
        if fmt == "csv" and not a.minutes:
            minutes = min(minutes, 15.0)
        dname, defects = plan.get(i, (None, {}))
        true_fs = None
        fs_label = fs
        if dname == "rate_200Hz_stamped_100Hz":
            true_fs, fs_label, fs = 200.0, 100.0, 100.0
        if dname == "rate_meta_100_stamps_200":
            fs = 200.0
            fs_label = 100.0
        if dname == "duplicate_of_unit_50":
            continue
        tt, data, temp, tr = build_unit(name, fs, minutes, rng, defects, true_fs=true_fs)
        # time stamps (labelled grid)
        n = len(tt)
        stamp_fs = fs if dname != "rate_200Hz_stamped_100Hz" else 100.0
        ts = jitter_time(np.arange(n) / stamp_fs, stamp_fs, rng)
        t_ns = (1_790_000_000 * 10**9 + i * 10**12 + np.round(ts * 1e9)).astype(np.int64)
        if dname == "axes_swapped_gravity_on_x":
            data["accel_x"], data["accel_z"] = data["accel_z"], data["accel_x"]
            tr["accel_x"], tr["accel_z"] = tr["accel_z"], tr["accel_x"]
        unit_override = {}
        if dname == "gyro_z_deg_s_labelled_rad_s":
            data["gyro_z"] = data["gyro_z"] / D2R       # numbers in deg/s
            unit_override["gyro_z"] = "rad/s"
            if fmt == "arrow":
                fmt = "parquet"                          # float column so the values survive
        if dname == "nan_in_accel_y":
            data["accel_y"] = data["accel_y"].copy()
            data["accel_y"][[12345, 12346, 50000]] = np.nan
            if fmt == "arrow":
                fmt = "parquet"
        if dname == "rate_meta_100_stamps_200":
            fmt = "arrow"                                # CSV cannot carry sample_rate_hz
        int_counts = fmt == "arrow"
        tbl = write_arrow(None, t_ns, data, temp, fs_label, unit_override, int_counts=int_counts)
        if dname == "corrupt_csv_row":
            fmt = "csv"
        sub = {"arrow": os.path.join(fleet, "lotA", f"line{i % 2 + 1}"),
               "parquet": os.path.join(fleet, "lotB"),
               "csv": os.path.join(root, "csvdrop")}[fmt]
        ext = {"arrow": ".arrow", "parquet": ".parquet", "csv": ".csv"}[fmt]
        path = os.path.join(sub, name + ext)
        save(tbl, path, fmt)
        if dname == "truncated_file":
            sz = os.path.getsize(path)
            with open(path, "r+b") as f:
                f.truncate(int(sz * 0.6))
        if dname == "empty_file":
            open(path, "w").close()
        if dname == "corrupt_csv_row":
            with open(path, "rb") as f:
                lines = f.read().split(b"\n")
            lines[5001] = b"\x00\x17garbage,,,\xff\xfe"
            with open(path, "wb") as f:
                f.write(b"\n".join(lines))
        truth["units"][name] = {"path": os.path.relpath(path, root), "fmt": fmt, "rate_hz": fs,
                                "true_rate_hz": true_fs or fs, "minutes": minutes, "channels": tr,
                                "defect": dname}
        if dname:
            truth["defects"][name] = dname
        if i == 50 and not a.clean:
            # duplicate of unit 50 under another name (unit 51)
            dup = os.path.join(sub, f"IMU{51:04d}" + ext)
            shutil.copyfile(path, dup)
            truth["units"][f"IMU{51:04d}"] = dict(truth["units"][name], path=os.path.relpath(dup, root),
                                                   defect="duplicate_of_unit_50")
            truth["defects"][f"IMU{51:04d}"] = "duplicate_of_unit_50"
        print(name, fmt, fs, minutes, dname or "", flush=True)
    with open(os.path.join(root, "truth.json"), "w") as f:
        json.dump(truth, f, indent=1)


if __name__ == "__main__":
    main()
