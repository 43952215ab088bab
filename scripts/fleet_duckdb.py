#!/usr/bin/env python3
"""Reads an `imunoise screen` output folder with an existing engine and prints the worst sensors.

The per-file results are a hive-partitioned Parquet dataset (DIR/results/shard=K/part-*.parquet):
this script reads it as one table, as any engine that knows the layout does, and prints
  * the ranking of the channels of one kind (default gyro) with the largest value of a term
    (default N, angle random walk; SI units, rad/s/sqrt(Hz) for gyros, m/s^2/sqrt(Hz) for
    accelerometers: one ranking mixing both would compare numbers in different units) — the
    README's DuckDB query;
  * the flagged channels of DIR/fleet.parquet with their reasons;
  * the rows per shard (the `shard` column comes from the folder names).

Usage: python3 scripts/fleet_duckdb.py DIR [--kind gyro|accel] [--term n] [--limit 10]
Needs duckdb (pip install duckdb); without it, pyarrow (pip install pyarrow) does the same through
pyarrow.dataset.
"""
import argparse
import pathlib
import sys


def with_duckdb(out: pathlib.Path, kind: str, term: str, limit: int) -> None:
    import duckdb

    con = duckdb.connect()
    results = str(out / "results" / "**" / "*.parquet")
    print(f"-- worst {limit} {kind} channels by {term}_value (DuckDB, hive_partitioning):")
    print(
        con.sql(
            f"SELECT sensor, channel, {term}_value FROM read_parquet(?, hive_partitioning=true) "
            f"WHERE status = 'ok' AND kind = ? ORDER BY {term}_value DESC NULLS LAST "
            f"LIMIT {int(limit)}",
            params=[results, kind],
        )
    )
    print("-- rows per shard:")
    print(
        con.sql(
            "SELECT shard, count(*) AS rows, count(DISTINCT key) AS files "
            "FROM read_parquet(?, hive_partitioning=true) GROUP BY shard ORDER BY shard",
            params=[results],
        )
    )
    fleet = out / "fleet.parquet"
    if fleet.exists():
        print("-- flagged (fleet.parquet):")
        print(
            con.sql(
                "SELECT sensor, channel, array_to_string(reasons, ' | ') AS why "
                "FROM read_parquet(?) WHERE flagged ORDER BY sensor, channel_index",
                params=[str(fleet)],
            )
        )


def with_pyarrow(out: pathlib.Path, kind: str, term: str, limit: int) -> None:
    import pyarrow.compute as pc
    import pyarrow.dataset as ds

    table = ds.dataset(out / "results", format="parquet", partitioning="hive").to_table()
    ok = table.filter(pc.and_(pc.equal(table["status"], "ok"), pc.equal(table["kind"], kind)))
    ranked = ok.sort_by([(f"{term}_value", "descending")]).slice(0, limit)
    print(f"-- worst {limit} {kind} channels by {term}_value (pyarrow.dataset, hive partitioning):")
    for s, c, v in zip(ranked["sensor"], ranked["channel"], ranked[f"{term}_value"]):
        print(f"{s.as_py():24} {c.as_py():12} {v.as_py()}")
    counts = pc.value_counts(table["shard"]).flatten()
    print("-- rows per shard:", {k.as_py(): n.as_py() for k, n in zip(*counts)})
    fleet = out / "fleet.parquet"
    if fleet.exists():
        f = ds.dataset(fleet, format="parquet").to_table()
        f = f.filter(f["flagged"])
        print("-- flagged (fleet.parquet):")
        for s, c, r in zip(f["sensor"], f["channel"], f["reasons"]):
            print(f"{s.as_py():24} {c.as_py():12} {' | '.join(r.as_py())}")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=pathlib.Path, help="the folder given to imunoise screen -o")
    p.add_argument("--kind", default="gyro", choices=["gyro", "accel"])
    p.add_argument("--term", default="n", choices=list("qnbkr"))
    p.add_argument("--limit", type=int, default=10)
    a = p.parse_args()
    if not (a.out / "results").is_dir():
        print(f"{a.out}: no results/ folder (not an imunoise screen output?)", file=sys.stderr)
        return 2
    try:
        import duckdb  # noqa: F401
    except ImportError:
        with_pyarrow(a.out, a.kind, a.term, a.limit)
    else:
        with_duckdb(a.out, a.kind, a.term, a.limit)
    return 0


if __name__ == "__main__":
    sys.exit(main())
