#!/usr/bin/env python3
"""Side-by-side speed and memory of imunoise (CPU path) and its peers on the same data.

Generates N samples (default 1e7) of white noise plus a random walk, writes them as an Arrow IPC file,
then runs, each in its own process so that peak memory is its own:
  * imunoise psd    (hann, nperseg 65536, 50% overlap)     vs scipy.signal.welch with the same options
  * imunoise avar   (OADEV, octave taus)                     vs allantools.oadev(taus="octave")
  * imunoise avar   (OADEV, 100 log-spaced taus)             vs allantools.oadev(taus=<the same taus>)
and prints wall time, the estimator's own time, peak resident memory and the ratios. Each peer
computes 1 + 5 times in its process: the ratios use the fastest warm call, the first is printed
beside it (scipy's Welch pays ≈1 s of one-time cost on its first call). imunoise is run 5 times
(fastest wall and compute time, largest peak memory) as the release binary, end to end (read the file, screen it, estimate, write Arrow/JSON); its
compute-only time is taken from the timings in its report.json (Welch: the estimator's own time,
welch_busy_s, its streamed updates plus finishing; beside it, reading + screening + Welch, as they
stream together; Allan: the estimator alone). The peers are timed on data already in memory
(loading excluded). Run it on an otherwise idle machine: both cores are used.

Usage: cargo build --release && python3 scripts/compare_peers.py [--samples N] [--keep DIR]
         [--backends cpu,gpu] [--no-peers]
--backends runs imunoise once per backend named (default cpu; gpu needs an adapter and fails
without one); REPEATS (default 5) sets the runs of each measurement and IMUNOISE_BIN the
binary (default target/release/imunoise); --no-peers skips the peers (where scipy or allantools is not installed).
Needs numpy and pyarrow, and scipy and allantools unless --no-peers.
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
BIN = pathlib.Path(os.environ.get("IMUNOISE_BIN", ROOT / "target" / "release" / "imunoise"))
NPERSEG = 65536
# Runs of each measurement: both tools are reported at their fastest (wall and compute each).
REPEATS = int(os.environ.get("REPEATS", "5"))


def log_taus(n, count=100):
    """`count` log-spaced averaging factors from 1 to the largest OADEV allows, made unique (so a few
    fewer than `count` at the small end). Pure Python: this process stays small, because a child
    forked from it starts with its resident memory counted in the child's peak."""
    import math

    m_max = (n - 1) // 2
    step = math.log10(m_max) / (count - 1)
    return sorted({int(round(10 ** (i * step))) for i in range(count)})


def make_data(path, n):
    import numpy as np
    import pyarrow as pa
    import pyarrow.ipc as ipc

    rng = np.random.default_rng(1)
    y = rng.standard_normal(n) + np.cumsum(1e-3 * rng.standard_normal(n))
    field = pa.field("y", pa.float64(), metadata={"unit": "rad/s", "kind": "gyro"})
    schema = pa.schema([field], metadata={"sample_rate_hz": "1"})
    table = pa.Table.from_arrays([pa.array(y)], schema=schema)
    with ipc.new_file(path, schema) as w:
        for b in table.to_batches(max_chunksize=1 << 16):
            w.write_batch(b)


def run_measured(cmd):
    """Runs cmd; returns (wall seconds, peak RSS MiB of that process, stdout)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out = p.stdout.read()
    err = p.stderr.read()
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"{' '.join(map(str, cmd))} failed:\n{err.decode()}")
    return wall, usage.ru_maxrss / 1024.0, out


def worker(kind, path, taus):
    """Runs one peer computation in this process and prints its compute time as JSON."""
    import numpy as np
    import pyarrow.ipc as ipc

    if kind == "make":
        make_data(path, int(taus))
        return
    y = ipc.open_file(path).read_all().column("y").to_numpy()

    def compute():
        t0 = time.perf_counter()
        if kind == "welch":
            import scipy.signal

            scipy.signal.welch(y, fs=1.0, window="hann", nperseg=NPERSEG, noverlap=NPERSEG // 2)
        else:
            import allantools

            t = "octave" if kind == "oadev_octave" else np.array(taus, dtype=float)
            allantools.oadev(y, rate=1.0, data_type="freq", taus=t)
        return time.perf_counter() - t0

    # The first call pays one-time costs (imports, FFT plans, first touch of large buffers): the
    # later ones are what a long-running session sees. The ratio uses the fastest of REPEATS warm
    # calls (single calls of scipy's Welch on this machine range from 0.27 to 0.66 s).
    cold = compute()
    warm = min(compute() for _ in range(REPEATS))
    print(json.dumps({"compute_s": warm, "cold_s": cold}))


def imunoise_compute_s(out_dir, kind):
    """The estimator's own time from report.json, and the time from the first byte read to the
    estimate. Welch streams while the file is read: its own time is welch_busy_s (the updates on the
    estimating thread while the reader thread goes on, plus finishing), and reading + screening +
    Welch together take read_s + welch_s, which the peers' time does not include. The Allan variance
    runs on the channel in memory (avar_s) after reading (read_s)."""
    doc = json.loads((out_dir / "report.json").read_text())
    t = doc["files"][0]["timings"]
    if kind == "welch":
        return t["welch_busy_s"], t["read_s"] + t["welch_s"]
    return t["avar_s"], t["read_s"] + t["avar_s"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--samples", type=float, default=1e7)
    ap.add_argument("--keep", type=pathlib.Path)
    ap.add_argument("--backends", default="cpu")
    ap.add_argument("--no-peers", action="store_true")
    ap.add_argument("--worker", nargs=2, help=argparse.SUPPRESS)
    ap.add_argument("--taus", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker(args.worker[0], args.worker[1], json.loads(args.taus) if args.taus else None)
        return
    if not BIN.exists():
        sys.exit("build the release binary first: cargo build --release")
    n = int(args.samples)
    work = args.keep or pathlib.Path(tempfile.mkdtemp(prefix="imunoise-compare-"))
    work.mkdir(parents=True, exist_ok=True)
    data = work / "y.arrow"
    run_measured([sys.executable, __file__, "--worker", "make", str(data), "--taus", str(n)])
    taus = log_taus(n)
    tau_list = ",".join(str(m) for m in taus)  # rate is 1 Hz: tau in seconds = m

    tasks = [
        ("Welch hann nperseg 65536", "welch",
         ["psd", str(data), "--nperseg", str(NPERSEG), "--bins-per-decade", "0"]),
        ("OADEV octave taus", "oadev_octave", ["avar", str(data), "--taus", "octave"]),
        (f"OADEV {len(taus)} log-spaced taus", "oadev_log", ["avar", str(data), "--taus", tau_list]),
    ]
    print(f"{n} samples, f64 ({data.stat().st_size / 2**20:.0f} MiB file), {os.cpu_count()} cores; imunoise {BIN}")
    print(f"{'task':34} {'tool':11} {'wall s':>8} {'compute s':>10} {'read+comp s':>12} {'peak MiB':>9}")
    backends = args.backends.split(",")
    for label, kind, cli in tasks:
        ours = {}
        for backend in backends:
            out_dir = work / f"out-{kind}-{backend}"
            runs = []
            for _ in range(REPEATS):
                wall, rss, _ = run_measured(
                    [BIN, *cli, "-o", str(out_dir), "--format", "arrow,json", "--quiet", "--backend", backend]
                )
                runs.append((wall, rss, *imunoise_compute_s(out_dir, kind)))
            wall = min(r[0] for r in runs)
            rss = max(r[1] for r in runs)
            compute = min(r[2] for r in runs)
            with_read = min(r[3] for r in runs)
            ours[backend] = (wall, compute, with_read)
            name = "imunoise" if backends == ["cpu"] else f"imunoise {backend}"
            print(f"{label if backend == backends[0] else '':34} {name:11} {wall:8.3f} {compute:10.3f} {with_read:12.3f} {rss:9.0f}")
        if args.no_peers:
            continue
        peer_cmd = [sys.executable, __file__, "--worker", kind, str(data), "--taus", json.dumps(taus)]
        p_wall, p_rss, p_out = run_measured(peer_cmd)
        measured = json.loads(p_out)
        peer, cold = measured["compute_s"], measured["cold_s"]
        peer_name = "scipy" if kind == "welch" else "allantools"
        print(f"{'':34} {peer_name:11} {p_wall:8.3f} {peer:10.3f} {'':12} {p_rss:9.0f}   (fastest warm call; first call {cold:.3f} s)")
        for backend, (wall, compute, with_read) in ours.items():
            tag = "ratio" if len(ours) == 1 else f"ratio {backend}"
            print(f"{'':34} {tag:11} {'':8} {peer / compute:9.1f}x (compute)  {peer / with_read:.1f}x (read + compute)"
                  f"  {peer / wall:.1f}x (imunoise end to end vs peer compute)")
    if not args.keep:
        import shutil

        shutil.rmtree(work)


if __name__ == "__main__":
    main()
