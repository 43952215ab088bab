#!/usr/bin/env python3
"""Differential test of two imunoise builds: OLD_BIN (a build to compare against, e.g. the
previous commit's release binary) against NEW_BIN (default: target/release/imunoise).

For changes meant to keep every result (speed work, refactors): "the same outputs" checked on
213 generated inputs and option sets, not on the sample alone.

Generates varied recordings (Arrow IPC file/stream, Parquet, CSV; batch layouts; dtypes; time
columns with gaps and jitter; NaN/inf/null placements), runs psd / avar / analyze with both
binaries (sequentially) and compares exit code, stderr, stdout, report.json (parsed, keys
"timings"/"elapsed_s" removed, floats bit-equal, int/float type-strict), .arrow/.csv bytes,
summary.md (ignoring the "analysed" timing line) and every other output file bytewise.

Usage: OLD_BIN=/path/to/old/imunoise python3 scripts/compare_builds.py [--only SUBSTR] [--keep]
Inputs, outputs and results.json go to COMPARE_DIR (default: a folder under the system's
temporary directory); a summary is printed at the end (about 40 s on 2 cores).
"""
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import time

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.ipc as ipc
import pyarrow.parquet as pq

_HERE = os.path.dirname(os.path.abspath(__file__))
OLD = os.environ.get("OLD_BIN", "")
NEW = os.environ.get("NEW_BIN", os.path.join(_HERE, "..", "target", "release", "imunoise"))
ROOT = os.environ.get("COMPARE_DIR", os.path.join(tempfile.gettempdir(), "imunoise-compare-builds"))
DATA = os.path.join(ROOT, "data")
WORK = os.path.join(ROOT, "work")
OUT = os.path.join(WORK, "out")  # identical -o path for both binaries

CHANNELS = [
    ("gyro_x", "gyro", "rad/s", 0.01),
    ("gyro_y", "gyro", "deg/s", 0.5),
    ("gyro_z", "gyro", "rad/s", 0.02),
    ("accel_x", "accel", "m/s^2", 0.05),
    ("accel_y", "accel", "g", 0.004),
    ("accel_z", "accel", "m/s^2", 0.05),
    ("temperature", "temperature", "degC", 0.01),
]
IRREGULAR = [1, 7, 65536, 100000, 3, 65535, 65537, 2, 131072, 999, 1, 40000, 262144, 5]


# ----------------------------------------------------------------------------- generation
def batch_lengths(spec, n):
    """spec: 'one' | ('equal', k) | ('list', [sizes...]) (cycled, last one truncated)."""
    if spec == "one":
        return [n]
    kind, arg = spec
    if kind == "equal":
        out = [arg] * (n // arg)
        if n % arg:
            out.append(n % arg)
        return out
    if kind == "list":
        out, i, left = [], 0, n
        while left > 0:
            k = min(arg[i % len(arg)], left)
            out.append(k)
            left -= k
            i += 1
        return out
    raise ValueError(spec)


def resolve_rows(where, n, bounds, rng):
    """Rows named by a placement: start, end, boundary:K (last row of batch K and first of K+1),
    bstart:K (first row of batch K), batch:K (all rows of batch K), mid, row:N, random:K."""
    if where == "start":
        return 0
    if where == "end":
        return n - 1
    if where == "mid":
        return n // 2
    kind, _, arg = where.partition(":")
    if kind == "row":
        return int(arg)
    if kind in ("boundary", "bstart"):
        k = int(arg) % max(1, len(bounds) - 1)
        b = bounds[k + 1] if k + 1 < len(bounds) else n // 2
        return b - 1 if kind == "boundary" else b
    if kind == "random":
        return int(rng.integers(0, n))
    raise ValueError(where)


def make_recipe_data(r):
    rng = np.random.default_rng(r["seed"])
    n = r["n"]
    rate = r["rate"]
    nch = r["nch"]
    chans = CHANNELS[:nch] if not r.get("chans") else [c for c in CHANNELS if c[0] in r["chans"]]
    lens = batch_lengths(r["batches"], n)
    bounds = np.concatenate([[0], np.cumsum(lens)]).astype(int).tolist()
    data = {}
    for i, (name, kind, unit, sigma) in enumerate(chans):
        white = rng.standard_normal(n) * sigma
        walk = np.cumsum(rng.standard_normal(n)) * sigma * 1e-3
        y = white + walk + (9.81 if name == "accel_z" else 0.0) + (25.0 if kind == "temperature" else 0.0)
        if r.get("amp"):
            y = y * r["amp"]
        data[name] = y
    # non-finite placements: (value, where, channels ('all' | [idx]), runlen)
    masks = {name: np.zeros(n, dtype=np.int8) for name in data}  # 0 ok 1 nan 2 inf 3 -inf 4 null
    code = {"nan": 1, "inf": 2, "-inf": 3, "null": 4}
    names = list(data)
    for value, where, which, run in r.get("bad", []):
        if where.startswith("batch:"):
            k = int(where[6:]) % len(lens)
            rows = list(range(bounds[k], bounds[k + 1]))
        elif where == "allrows":
            rows = list(range(n))
        else:
            r0 = resolve_rows(where, n, bounds, rng)
            if where == "end":
                r0 = n - run
            rows = [x for x in range(r0, r0 + run) if 0 <= x < n]
        cols = names if which == "all" else [names[i % len(names)] for i in which]
        for c in cols:
            masks[c][rows] = code[value]
    # time column
    t = None
    if r.get("time"):
        dt = 1.0 / (r.get("time_rate") or rate)
        idx = np.arange(n, dtype=np.float64)
        extra = np.zeros(n)
        for where, missing in r.get("gaps", []):
            g = resolve_rows(where, n, bounds, rng)
            extra[g:] += missing
        idx = idx + extra
        jit = r.get("jitter", 0.0)
        if jit:
            idx = idx + rng.uniform(-jit, jit, n)
        t = r.get("t0", 1000.0) + idx * dt
        if r.get("dup_time_at") is not None:
            k = r["dup_time_at"]
            t[k] = t[k - 1]
        if r.get("back_time_at") is not None:
            k = r["back_time_at"]
            t[k] = t[k - 1] - dt
    return chans, data, masks, t, lens


def arrow_array(name, y, mask, dtype, unit):
    """Column array of dtype with non-finite codes applied; int dtypes: scale in metadata."""
    if dtype in ("int16", "int32"):
        scale = {"int16": 1e-4, "int32": 1e-7}[dtype]
        if unit == "degC":
            scale = 1e-2
        info = np.iinfo(dtype)
        c = np.clip(np.round(y / scale), info.min, info.max).astype(dtype)
        valid = mask == 0  # ints: every non-finite code becomes null
        arr = pa.array(c, mask=~valid)
        return arr, {"unit": unit, "scale": repr(scale)}
    np_t = np.float64 if dtype == "float64" else np.float32
    v = y.astype(np_t)
    v[mask == 1] = np.nan
    v[mask == 2] = np.inf
    v[mask == 3] = -np.inf
    arr = pa.array(v, mask=(mask == 4)) if (mask == 4).any() else pa.array(v)
    return arr, {"unit": unit}


def time_array(r, t):
    enc = r["time"]
    if enc == "f64s":
        return "time", pa.array(t), {}
    if enc == "ts_ns":
        ns = np.round(t * 1e9).astype(np.int64)
        return "time", pa.array(ns, type=pa.timestamp("ns", tz="UTC")), {}
    if enc == "i64ms":
        return "time", pa.array(np.round(t * 1e3).astype(np.int64)), {"unit": "ms"}
    if enc == "i64us_nounit":
        return "timestamp", pa.array(np.round(t * 1e6).astype(np.int64)), {}
    if enc == "f64s_named":
        return "t_sec", pa.array(t), {}
    raise ValueError(enc)


def build_table(r):
    chans, data, masks, t, lens = make_recipe_data(r)
    fields, arrays = [], []
    if t is not None:
        tn, ta, tmeta = time_array(r, t)
        fields.append(pa.field(tn, ta.type, metadata=tmeta or None))
        arrays.append(ta)
    dtypes = r.get("dtypes", ["float64"])
    for i, (name, kind, unit, _) in enumerate(chans):
        dt = dtypes[i % len(dtypes)]
        arr, meta = arrow_array(name, data[name], masks[name], dt, unit)
        if r.get("kind_meta", True):
            meta["kind"] = kind
        fields.append(pa.field(name, arr.type, metadata=meta))
        arrays.append(arr)
    smeta = {}
    if r.get("meta_rate", True):
        smeta["sample_rate_hz"] = str(r.get("meta_rate_value", r["rate"]))
    schema = pa.schema(fields, metadata=smeta or None)
    table = pa.Table.from_arrays(arrays, schema=schema)
    return table, lens


def write_recipe(r):
    os.makedirs(DATA, exist_ok=True)
    table, lens = build_table(r)
    ext = {"arrow": ".arrow", "arrows": ".arrows", "parquet": ".parquet", "csv": ".csv"}[r["fmt"]]
    path = os.path.join(DATA, r["name"] + ext)
    slices, off = [], 0
    for k in lens:
        slices.append(table.slice(off, k))
        off += k
    if r["fmt"] == "arrow":
        with pa.OSFile(path, "wb") as f, ipc.new_file(f, table.schema) as w:
            for s in slices:
                for b in s.to_batches(max_chunksize=max(1, s.num_rows)):
                    w.write_batch(b)
    elif r["fmt"] == "arrows":
        with pa.OSFile(path, "wb") as f, ipc.new_stream(f, table.schema) as w:
            for s in slices:
                for b in s.to_batches(max_chunksize=max(1, s.num_rows)):
                    w.write_batch(b)
    elif r["fmt"] == "parquet":
        with pq.ParquetWriter(path, table.schema, compression=r.get("compression", "snappy")) as w:
            for s in slices:
                w.write_table(s, row_group_size=max(1, s.num_rows))
    elif r["fmt"] == "csv":
        # header "name [unit]"; null -> empty cell, nan/inf as pyarrow prints them
        cols, names = [], []
        for f, col in zip(table.schema, table.columns):
            unit = (f.metadata or {}).get(b"unit")
            if f.name.startswith("t") and f.name in ("time", "timestamp", "t_sec"):
                if pa.types.is_timestamp(f.type):
                    col = pa.array(col.cast(pa.int64()).to_numpy() / 1e9)
                names.append(f.name)
            else:
                if pa.types.is_integer(f.type):
                    scale = float((f.metadata or {}).get(b"scale", b"1"))
                    np_c = col.to_numpy(zero_copy_only=False).astype(np.float64) * scale
                    col = pa.array(np_c, mask=col.is_null().to_numpy(zero_copy_only=False))
                names.append(f"{f.name} [{unit.decode()}]" if unit and r.get("csv_units", True) else f.name)
            cols.append(col)
        t = pa.Table.from_arrays(cols, names=names)
        pacsv.write_csv(t, path, pacsv.WriteOptions(include_header=True,
                                                    quoting_style=r.get("csv_quoting", "needed")))
        if r.get("csv_literal_nan"):
            # rewrite pyarrow's "nan"/"inf" spellings as NaN / -inf / Infinity variants
            with open(path) as fh:
                txt = fh.read()
            txt = txt.replace("-inf", "-Infinity").replace(",nan", ",NaN").replace(",inf", ",INF")
            with open(path, "w") as fh:
                fh.write(txt)
    return path


# ----------------------------------------------------------------------------- comparison
def strip(x):
    if isinstance(x, dict):
        return {k: strip(v) for k, v in x.items() if k not in ("timings", "elapsed_s")}
    if isinstance(x, list):
        return [strip(v) for v in x]
    return x


def fbits(v):
    return struct.pack("<d", v).hex()


def json_diff(a, b, path="$"):
    """First difference (path, old, new) or None; strict on types, floats bit-equal."""
    if type(a) is not type(b):
        return (path, repr(a)[:200], repr(b)[:200])
    if isinstance(a, dict):
        ka, kb = list(a), list(b)
        if set(ka) != set(kb):
            return (path + " keys", sorted(set(ka) - set(kb)), sorted(set(kb) - set(ka)))
        for k in ka:
            d = json_diff(a[k], b[k], f"{path}.{k}")
            if d:
                return d
        if ka != kb:
            return (path + " key order", ka, kb)
        return None
    if isinstance(a, list):
        if len(a) != len(b):
            return (path + " length", len(a), len(b))
        for i, (x, y) in enumerate(zip(a, b)):
            d = json_diff(x, y, f"{path}[{i}]")
            if d:
                return d
        return None
    if isinstance(a, float):
        if fbits(a) != fbits(b):
            return (path, repr(a), repr(b))
        return None
    if a != b:
        return (path, repr(a)[:200], repr(b)[:200])
    return None


def first_byte_diff(x, y):
    n = min(len(x), len(y))
    for i in range(n):
        if x[i] != y[i]:
            return i
    return n if len(x) != len(y) else None


def text_first_line_diff(x, y):
    lx, ly = x.splitlines(), y.splitlines()
    for i, (p, q) in enumerate(zip(lx, ly)):
        if p != q:
            return f"line {i + 1}: OLD {p[:200]!r} NEW {q[:200]!r}"
    if len(lx) != len(ly):
        return f"line count OLD {len(lx)} NEW {len(ly)}"
    return None


def list_files(d):
    out = {}
    if not os.path.isdir(d):
        return out
    for root, _, files in os.walk(d):
        for f in files:
            p = os.path.join(root, f)
            out[os.path.relpath(p, d)] = p
    return out


def compare_dirs(da, db):
    diffs = []
    fa, fb = list_files(da), list_files(db)
    if set(fa) != set(fb):
        diffs.append(f"file sets differ: only OLD {sorted(set(fa) - set(fb))} only NEW {sorted(set(fb) - set(fa))}")
    for rel in sorted(set(fa) & set(fb)):
        A = open(fa[rel], "rb").read()
        B = open(fb[rel], "rb").read()
        if rel.endswith(".json"):
            try:
                ja, jb = strip(json.loads(A)), strip(json.loads(B))
            except Exception as e:  # noqa: BLE001
                diffs.append(f"{rel}: JSON parse error {e}")
                continue
            d = json_diff(ja, jb)
            if d:
                diffs.append(f"{rel}: first diff at {d[0]}: OLD {d[1]} NEW {d[2]}")
        elif rel.endswith("summary.md"):
            la = [l for l in A.decode().splitlines() if "analysed" not in l]
            lb = [l for l in B.decode().splitlines() if "analysed" not in l]
            if la != lb:
                diffs.append(f"{rel}: {text_first_line_diff(chr(10).join(la), chr(10).join(lb))}")
        elif A != B:
            i = first_byte_diff(A, B)
            extra = ""
            if rel.endswith(".csv"):
                extra = " " + str(text_first_line_diff(A.decode(), B.decode()))
            diffs.append(f"{rel}: bytes differ at offset {i} (sizes {len(A)} vs {len(B)}){extra}")
    return diffs


def run_bin(binary, args):
    if os.path.exists(OUT):
        shutil.rmtree(OUT)
    t0 = time.time()
    p = subprocess.run([binary] + args, capture_output=True, cwd=WORK, timeout=1800)
    return p.returncode, p.stdout, p.stderr, time.time() - t0


def compare_run(args):
    """Runs OLD then NEW with the same -o path; returns (diffs, info)."""
    dirs = {}
    res = {}
    for tag, binary in (("old", OLD), ("new", NEW)):
        rc, so, se, el = run_bin(binary, args)
        dest = os.path.join(WORK, f"out_{tag}")
        if os.path.exists(dest):
            shutil.rmtree(dest)
        if os.path.exists(OUT):
            os.rename(OUT, dest)
        dirs[tag] = dest
        res[tag] = (rc, so, se, el)
    diffs = []
    (rca, soa, sea, ela), (rcb, sob, seb, elb) = res["old"], res["new"]
    if rca != rcb:
        diffs.append(f"exit code OLD {rca} NEW {rcb}")
    if sea != seb:
        diffs.append(f"stderr: {text_first_line_diff(sea.decode(errors='replace'), seb.decode(errors='replace'))}")
    if soa != sob:
        try:
            d = json_diff(strip(json.loads(soa)), strip(json.loads(sob)))
            if d:
                diffs.append(f"stdout JSON first diff at {d[0]}: OLD {d[1]} NEW {d[2]}")
        except Exception:  # noqa: BLE001
            diffs.append(f"stdout: {text_first_line_diff(soa.decode(errors='replace'), sob.decode(errors='replace'))}")
    diffs += compare_dirs(dirs["old"], dirs["new"])
    info = {"rc": rca, "stderr_old": sea.decode(errors="replace")[-400:], "t_old": round(ela, 2),
            "t_new": round(elb, 2), "files": len(list_files(dirs["old"]))}
    return diffs, info


# ----------------------------------------------------------------------------- recipes
def recipes():
    R = []

    def add(name, **kw):
        base = dict(name=name, seed=len(R) + 1, fmt="arrow", n=20000, rate=100, nch=3,
                    batches="one", dtypes=["float64"], time=None, bad=[], gaps=[], cmds=["psd", "avar"])
        base.update(kw)
        R.append(base)

    # --- clean files, batch layouts, formats, dtypes, channel counts
    add("a_one_f64_1ch", n=300, nch=1, cmds=["psd", "psd_default", "avar"])
    add("a_one_f64_3ch_2M", n=2_000_000, nch=3, rate=400)
    add("a_equal64k_f32_7ch", n=700_000, nch=7, batches=("equal", 65536), dtypes=["float32"])
    add("a_irreg_mixed_6ch", n=1_200_000, nch=6, batches=("list", IRREGULAR),
        dtypes=["float64", "float32", "int16"], time="ts_ns", rate=200)
    add("a_equal1000_int16_3ch", n=150_000, nch=3, batches=("equal", 1000), dtypes=["int16"],
        cmds=["psd", "avar", "avar1", "analyze"])
    add("a_tiny_batches", n=5000, nch=2, batches=("list", [1, 7, 1, 2, 3]), cmds=["psd", "avar", "avar_all"])
    add("a_equal7_1ch_time", n=20_000, nch=1, batches=("equal", 7), time="f64s")
    add("a_int32_scale_4ch", n=400_000, nch=4, batches=("equal", 100000), dtypes=["int32"], time="i64ms", rate=1000)
    add("s_one_f64_5ch", fmt="arrows", n=500_000, nch=5)
    add("s_irreg_f32_2ch_time", fmt="arrows", n=900_000, nch=2, batches=("list", IRREGULAR), dtypes=["float32"], time="ts_ns")
    add("s_equal65536_7ch_int16", fmt="arrows", n=600_000, nch=7, batches=("equal", 65536), dtypes=["int16", "float64"])
    add("s_batches_1row", fmt="arrows", n=400, nch=3, batches=("equal", 1), time="f64s")
    add("p_one_rg_3ch", fmt="parquet", n=1_000_000, nch=3, time="ts_ns", rate=200)
    add("p_irreg_rg_6ch", fmt="parquet", n=800_000, nch=6, batches=("list", IRREGULAR), dtypes=["float32", "int16"])
    add("p_equal_100000_1ch", fmt="parquet", n=2_000_000, nch=1, batches=("equal", 100000), rate=1000)
    add("p_small_zstd", fmt="parquet", n=3000, nch=4, batches=("equal", 700), compression="zstd", time="i64ms", rate=100)
    add("c_plain_3ch_time", fmt="csv", n=200_000, nch=3, time="f64s", cmds=["psd", "avar", "analyze"])
    add("c_nometa_7ch", fmt="csv", n=120_000, nch=7, time="f64s", rate=200, dtypes=["float32"])
    add("c_notime_rateflag", fmt="csv", n=50_000, nch=2, time=None, meta_rate=False,
        cmds=["psd_rate", "avar_rate", "psd"])
    add("c_int_values", fmt="csv", n=30_000, nch=3, dtypes=["int16"], time="f64s")
    add("c_quoted_all", fmt="csv", n=10_000, nch=2, time="f64s", csv_quoting="all_valid")
    # --- rate sources
    add("a_rate_from_time_only", n=100_000, nch=3, meta_rate=False, time="ts_ns", rate=250,
        batches=("equal", 30000))
    add("a_rate_disagree", n=5000, nch=2, time="f64s", rate=100, meta_rate_value=120, cmds=["psd", "avar"])
    add("a_int_time_nounit", n=50_000, nch=2, time="i64us_nounit", rate=500, batches=("equal", 4096),
        meta_rate=False)
    add("a_time_named_flag", n=30_000, nch=2, time="f64s_named", cmds=["psd_timecol", "avar_timecol", "psd_notime"])
    # --- non-finite placements
    bad_all = [("nan", "start", "all", 3), ("inf", "boundary:0", [1], 2), ("null", "bstart:2", [0], 1),
               ("-inf", "mid", "all", 5), ("nan", "end", [0], 4)]
    add("a_nf_irreg_f64", n=600_000, nch=3, batches=("list", IRREGULAR), bad=bad_all, time="ts_ns", cmds=["nf3_psd", "nf3_avar"])
    add("a_nf_equal64k_f32", n=300_000, nch=2, batches=("equal", 65536), dtypes=["float32"],
        bad=[("nan", "boundary:1", "all", 2), ("nan", "boundary:3", [1], 9), ("inf", "start", [0], 1)],
        cmds=["nf3_psd", "nf3_avar"])
    add("a_nf_whole_batch", n=200_000, nch=3, batches=("equal", 20000),
        bad=[("nan", "batch:2", "all", 0), ("nan", "batch:3", [0], 0)], cmds=["nf3_psd", "nf3_avar"])
    add("a_nf_first_batch_all_nan", n=200_000, nch=2, batches=("list", [50, 70000, 1, 129949]),
        bad=[("nan", "batch:0", "all", 0), ("null", "batch:2", "all", 0)], cmds=["nf3_psd", "nf3_avar"])
    add("a_nf_last_batch_nan", n=100_000, nch=2, batches=("list", [99990, 10]),
        bad=[("nan", "batch:1", [0], 0), ("inf", "batch:1", [1], 0)], cmds=["nf3_psd", "nf3_avar"])
    add("a_nf_channel_all_nan", n=5000, nch=3, bad=[("nan", "allrows", [1], 0)], cmds=["nf3_psd"])
    add("s_nf_int16_nulls", fmt="arrows", n=500_000, nch=4, batches=("list", IRREGULAR), dtypes=["int16"],
        bad=[("null", "random:0", "all", 1), ("null", "boundary:2", [2], 3), ("null", "start", [3], 1),
             ("null", "end", "all", 2)], time="f64s", cmds=["nf3_psd", "nf3_avar"])
    add("s_nf_one_row_batches", fmt="arrows", n=300, nch=2, batches=("equal", 1),
        bad=[("nan", "row:5", "all", 3), ("inf", "row:100", [0], 1)], cmds=["nf3_psd", "nf3_avar"])
    add("p_nf_mixed", fmt="parquet", n=700_000, nch=5, batches=("equal", 65536), dtypes=["float32", "int16", "float64"],
        bad=bad_all + [("nan", "boundary:5", "all", 10)], time="ts_ns", rate=200, cmds=["nf3_psd", "nf3_avar"])
    add("c_nf_cells", fmt="csv", n=150_000, nch=3, time="f64s",
        bad=[("null", "start", [0], 2), ("nan", "mid", "all", 4), ("inf", "row:70000", [2], 1),
             ("-inf", "end", [1], 3)], cmds=["nf3_psd", "nf3_avar", "nf_interp_batchrows"])
    add("c_nf_literal", fmt="csv", n=40_000, nch=2, time="f64s", csv_literal_nan=True,
        bad=[("nan", "row:10", "all", 2), ("inf", "row:20000", [0], 1), ("-inf", "row:30000", [1], 1)],
        cmds=["nf3_psd"])
    add("a_nf_analyze", n=120_000, nch=3, batches=("equal", 10000), time="ts_ns",
        bad=[("nan", "boundary:3", "all", 3), ("null", "start", [1], 2)], cmds=["nf_analyze_interp", "nf_analyze_drop"])
    # --- gaps and jitter
    gaps = [("bstart:1", 1), ("mid", 3), ("boundary:4", 2), ("row:17", 10)]
    add("a_gaps_irreg", n=800_000, nch=3, batches=("list", IRREGULAR), time="ts_ns", rate=200, gaps=gaps,
        cmds=["gap3_psd", "gap3_avar"])
    add("a_gaps_jitter", n=300_000, nch=2, batches=("equal", 65536), time="f64s", gaps=gaps, jitter=0.2,
        cmds=["gap3_psd", "gap3_avar"])
    add("a_jitter_only_amb", n=100_000, nch=2, batches=("equal", 3000), time="f64s", jitter=0.45,
        cmds=["psd", "gap3_psd", "gap3_avar"])
    add("a_jitter_035", n=200_000, nch=3, batches=("list", IRREGULAR), time="ts_ns", jitter=0.35, rate=200,
        gaps=[("bstart:1", 1)], cmds=["gap3_avar"])
    add("s_gaps_bstart_every", fmt="arrows", n=200_000, nch=4, batches=("equal", 20000), time="ts_ns",
        gaps=[(f"bstart:{k}", 1 + k % 3) for k in range(9)], cmds=["gap3_psd", "gap3_avar"])
    add("p_gaps_int_ms", fmt="parquet", n=400_000, nch=3, batches=("equal", 50000), time="i64ms", rate=1000,
        gaps=[("bstart:2", 5), ("row:1", 1), ("end", 2)], dtypes=["int16"], cmds=["gap3_psd", "gap3_avar"])
    add("c_gaps_jitter", fmt="csv", n=100_000, nch=3, time="f64s", gaps=gaps, jitter=0.1,
        cmds=["gap3_psd", "gap3_avar", "gap_fill_batchrows"])
    add("a_gaps_and_nf", n=400_000, nch=3, batches=("list", IRREGULAR), time="ts_ns", gaps=gaps,
        bad=[("nan", "bstart:1", "all", 1), ("nan", "boundary:4", [0], 3), ("inf", "start", [2], 2)],
        cmds=["gapnf_mix"])
    add("a_gaps_nf_analyze", n=150_000, nch=3, batches=("equal", 4096), time="ts_ns", rate=200,
        gaps=[("bstart:3", 2), ("row:100000", 4)], bad=[("nan", "bstart:3", "all", 2), ("nan", "row:50000", [1], 3)],
        cmds=["gapnf_analyze"])
    add("a_dup_time", n=10_000, nch=2, time="f64s", dup_time_at=5000, cmds=["psd", "gap_ignore_psd"])
    add("a_back_time", n=10_000, nch=2, batches=("equal", 1000), time="ts_ns", back_time_at=3000, cmds=["psd"])
    # --- other options
    add("a_channels_subset", n=300_000, nch=6, batches=("equal", 65536), time="ts_ns",
        cmds=["psd_channels", "avar_channels", "psd_unitkind", "psd_unitkind_ok", "fmt_json_only", "fmt_arrow_only"])
    add("a_empty", n=0, nch=3, time="f64s", cmds=["psd", "avar"])
    add("p_2M_7ch_f32_nf", fmt="parquet", n=2_000_000, nch=7, dtypes=["float32"], batches=("equal", 65536),
        time="ts_ns", rate=1000, bad=[("nan", "boundary:3", "all", 2), ("inf", "boundary:10", [4], 1),
        ("nan", "end", [6], 7)], cmds=["nf_interp_psd_avar"])
    add("a_2M_1ch_int16_null", n=2_000_000, nch=1, dtypes=["int16"], batches=("list", IRREGULAR),
        bad=[("null", "boundary:2", "all", 4), ("null", "start", "all", 1)], cmds=["nf_interp_psd_avar", "nf_drop_br"])
    add("a_saturated_int16", n=100_000, nch=3, dtypes=["int16"], amp=40.0, batches=("equal", 8192))
    add("a_short_avar_fail", n=3, nch=1, cmds=["avar", "psd", "avar_hdev"])
    add("a_json_stdout", n=80_000, nch=3, time="ts_ns", batches=("list", IRREGULAR), cmds=["psd_json", "avar_json"])
    add("a_psd_opts", n=500_000, nch=2, batches=("equal", 65536), cmds=["psd_opts1", "psd_opts2", "psd_median"])
    add("a_avar_taus", n=50_000, nch=2, batches=("equal", 5000), cmds=["avar_decade", "avar_10pd", "avar_list", "avar_conf"])
    add("a_batchrows_flag", n=1_000_000, nch=2, cmds=["psd_br7", "avar_br1000", "avar_brmax"])
    add("a_multifile_1", n=100_000, nch=3, time="ts_ns", cmds=["multi"])
    add("c_multifile_2", fmt="csv", n=60_000, nch=3, time="f64s", cmds=[])
    add("a_analyze_small7ch", n=60_000, nch=7, batches=("list", [1, 7, 30000, 29992]), dtypes=["float32", "int16"],
        time="ts_ns", cmds=["analyze", "analyze_stats"])
    add("p_analyze", fmt="parquet", n=100_000, nch=2, batches=("equal", 10000), time="ts_ns", rate=200,
        cmds=["analyze"])
    return R


AVAR5 = ["--stat", "oadev,mdev,adev,hdev,ohdev"]
FMT = ["--format", "json,arrow,csv", "--backend", "cpu"]


def commands(r, path, all_paths):
    """(label, args) list for a recipe."""
    def psd(*extra):
        seg = []
        if r["n"] < 16384 and "--nperseg" not in extra:
            seg = ["--nperseg", str(max(8, 1 << int(math.log2(max(8, r["n"] // 4)))))]
        return ["psd", path, "-o", OUT, "-q", *FMT, *seg, *extra]

    def avar(*extra, stat=AVAR5):
        return ["avar", path, "-o", OUT, "-q", *FMT, *stat, *extra]

    def analyze(*extra):
        return ["analyze", path, "-o", OUT, "-q", "--backend", "cpu", *extra]

    out = []
    for c in r["cmds"]:
        if c == "psd":
            out.append((c, psd()))
        elif c == "psd_default":
            out.append((c, ["psd", path, "-o", OUT, "-q", *FMT]))
        elif c == "avar":
            out.append((c, avar()))
        elif c == "avar1":
            out.append((c, avar(stat=["--stat", "mdev"])))
        elif c == "avar_hdev":
            out.append((c, avar(stat=["--stat", "hdev"])))
        elif c == "avar_all":
            out.append((c, avar("--taus", "all")))
        elif c == "analyze":
            out.append((c, analyze()))
        elif c == "analyze_stats":
            out.append((c, analyze("--stat", "oadev,hdev", "--format", "json,csv")))
        elif c == "psd_rate":
            out.append((c, psd("--rate", "100")))
        elif c == "avar_rate":
            out.append((c, avar("--rate", "100", stat=["--stat", "oadev"])))
        elif c == "psd_timecol":
            out.append((c, psd("--time-column", "t_sec")))
        elif c == "avar_timecol":
            out.append((c, avar("--time-column", "t_sec")))
        elif c == "psd_notime":
            out.append((c, psd("--no-time")))
        elif c in ("nf3_psd", "nf3_avar"):
            for pol in ("error", "drop", "interpolate"):
                args = psd("--on-nonfinite", pol) if c == "nf3_psd" else avar("--on-nonfinite", pol)
                out.append((f"{c}:{pol}", args))
        elif c == "nf_interp_batchrows":
            out.append((c, avar("--on-nonfinite", "interpolate", "--batch-rows", "777")))
        elif c == "nf_analyze_interp":
            out.append((c, analyze("--on-nonfinite", "interpolate")))
        elif c == "nf_analyze_drop":
            out.append((c, analyze("--on-nonfinite", "drop")))
        elif c in ("gap3_psd", "gap3_avar"):
            for pol in ("error", "ignore", "fill"):
                args = psd("--on-gap", pol) if c == "gap3_psd" else avar("--on-gap", pol)
                out.append((f"{c}:{pol}", args))
        elif c == "gap_fill_batchrows":
            out.append((c, psd("--on-gap", "fill", "--batch-rows", "1000")))
        elif c == "gap_ignore_psd":
            out.append((c, psd("--on-gap", "ignore")))
        elif c == "gapnf_mix":
            for g in ("ignore", "fill"):
                for nf in ("drop", "interpolate"):
                    out.append((f"{c}:{g}/{nf}/psd", psd("--on-gap", g, "--on-nonfinite", nf)))
                    out.append((f"{c}:{g}/{nf}/avar", avar("--on-gap", g, "--on-nonfinite", nf)))
            out.append((f"{c}:error/drop", avar("--on-nonfinite", "drop")))
            out.append((f"{c}:fill/interp/notime", psd("--on-gap", "fill", "--no-time", "--on-nonfinite", "interpolate")))
        elif c == "gapnf_analyze":
            out.append((c, analyze("--on-gap", "fill", "--on-nonfinite", "interpolate")))
        elif c == "psd_channels":
            out.append((c, psd("--channels", "gyro_z,accel_x")))
        elif c == "avar_channels":
            out.append((c, avar("--channels", "accel_y", stat=["--stat", "ohdev"])))
        elif c == "psd_unitkind":
            out.append((c, psd("--unit", "gyro_x=deg/s", "--kind", "*=aux", "--channels", "gyro_x,gyro_y,nope")))
        elif c == "psd_unitkind_ok":
            out.append((c, psd("--unit", "gyro_x=deg/s", "--unit", "accel_y=mg", "--kind", "*=aux")))
        elif c == "fmt_json_only":
            out.append((c, ["avar", path, "-o", OUT, "-q", "--format", "json", "--backend", "cpu", *AVAR5]))
        elif c == "fmt_arrow_only":
            out.append((c, ["psd", path, "-o", OUT, "-q", "--format", "arrow", "--backend", "cpu"]))
        elif c == "nf_interp_psd_avar":
            out.append((c + ":psd", psd("--on-nonfinite", "interpolate")))
            out.append((c + ":avar", avar("--on-nonfinite", "interpolate")))
            out.append((c + ":avar_oadev", avar("--on-nonfinite", "interpolate", stat=["--stat", "oadev"])))
        elif c == "nf_drop_br":
            out.append((c, avar("--on-nonfinite", "drop", "--batch-rows", "3000")))
        elif c == "psd_json":
            out.append((c, ["psd", path, "--json", "-q", "--backend", "cpu"]))
        elif c == "avar_json":
            out.append((c, ["avar", path, "--json", "-q", "--backend", "cpu", *AVAR5]))
        elif c == "psd_opts1":
            out.append((c, psd("--window", "blackmanharris", "--nperseg", "1000", "--noverlap", "999",
                               "--nfft", "1024", "--detrend", "linear", "--bins-per-decade", "7")))
        elif c == "psd_opts2":
            out.append((c, psd("--window", "boxcar", "--nperseg", "65536", "--scaling", "spectrum",
                               "--detrend", "none", "--bins-per-decade", "0")))
        elif c == "psd_median":
            out.append((c, psd("--average", "median", "--nperseg", "256")))
        elif c == "avar_decade":
            out.append((c, avar("--taus", "decade")))
        elif c == "avar_10pd":
            out.append((c, avar("--taus", "10-per-decade", stat=["--stat", "oadev"])))
        elif c == "avar_list":
            out.append((c, avar("--taus", "0.01,0.1,1,10,100")))
        elif c == "avar_conf":
            out.append((c, avar("--confidence", "0.95", stat=["--stat", "adev,oadev"])))
        elif c == "psd_br7":
            out.append((c, psd("--batch-rows", "7")))
        elif c == "avar_br1000":
            out.append((c, avar("--batch-rows", "1000")))
        elif c == "avar_brmax":
            out.append((c, avar("--batch-rows", "16777216")))
        elif c == "multi":
            others = [p for n_, p in all_paths.items() if n_ in ("c_multifile_2", "a_short_avar_fail")]
            bad = os.path.join(DATA, "does_not_exist.arrow")
            out.append(("multi:psd", ["psd", path, *others, bad, "-o", OUT, "-q", *FMT]))
            out.append(("multi:avar", ["avar", path, *others, "-o", OUT, "-q", *FMT, *AVAR5]))
            out.append(("multi:analyze", ["analyze", path, *others[:1], "-o", OUT, "-q", "--backend", "cpu"]))
        else:
            raise ValueError(c)
    return out


def main():
    if not (OLD and os.path.exists(OLD)):
        sys.exit("set OLD_BIN to the build to compare against (a release binary)")
    if not os.path.exists(NEW):
        sys.exit(f"no build at {NEW}: cargo build --release, or set NEW_BIN")
    only = None
    if "--only" in sys.argv:
        only = sys.argv[sys.argv.index("--only") + 1]
    os.makedirs(WORK, exist_ok=True)
    rs = recipes()
    # files other recipes refer to (multi-file commands) are written first
    all_paths = {}
    for r in rs:
        if r["name"] in ("c_multifile_2", "a_short_avar_fail"):
            all_paths[r["name"]] = write_recipe(r)
    results = []
    n_runs = 0
    t_start = time.time()
    for r in rs:
        if only and only not in r["name"]:
            continue
        path = all_paths.get(r["name"]) or write_recipe(r)
        recipe_desc = {k: v for k, v in r.items() if k != "cmds"}
        for label, args in commands(r, path, all_paths):
            diffs, info = compare_run(args)
            n_runs += 1
            if diffs:
                # rerun OLD vs NEW once more to tell a real difference from nondeterminism
                diffs2, _ = compare_run(args)
                info["rerun_same"] = diffs2 == diffs
            status = "DIFF" if diffs else "same"
            print(f"[{n_runs:3d}] {status} {r['name']:28s} {label:28s} rc={info['rc']} "
                  f"t={info['t_old']}/{info['t_new']}s files={info['files']}"
                  + (f" stderr={info['stderr_old'].strip().splitlines()[-1][:100]!r}" if info["stderr_old"].strip() else ""),
                  flush=True)
            for d in diffs:
                print("      ", d, flush=True)
            results.append({"recipe": recipe_desc, "label": label,
                            "cmd": " ".join(["imunoise"] + args), "diffs": diffs, **info})
        if path not in all_paths.values() and "--keep" not in sys.argv:
            os.remove(path)
    n_diff = sum(1 for x in results if x["diffs"])
    with open(os.path.join(ROOT, "results.json"), "w") as f:
        json.dump(results, f, indent=1, default=str)
    rcs = {}
    for x in results:
        rcs[x["rc"]] = rcs.get(x["rc"], 0) + 1
    print(f"\n{n_runs} combinations run in {time.time() - t_start:.0f} s; exit codes {rcs}; "
          f"{n_diff} with differences")


if __name__ == "__main__":
    main()
