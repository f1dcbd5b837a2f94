"""Backs the BENCHMARKS.md claim "campaign catalog read in one scan".

Reading a campaign's catalog of many fragments: ``Dataset.catalog`` (one polars scan over
every ``_catalog/*.parquet``) against a Python loop of ``pl.read_parquet`` and a concat (what
``Dataset.catalog`` did before, and what a script would write).

Fragments: one real fragment (a campaign of one simulated recording), copied ``--fragments``
times under distinct recording ids. Routes alternate; median of ``--repeats``.

Run:  python benchmarks/bench_catalog.py [--fragments 2000] [--repeats 7] [--dir bench-out/catalog]
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import time
from pathlib import Path

import polars as pl


def make(d: Path, n: int) -> Path:
    import thermrs
    from thermrs.simulate import simulate

    d.mkdir(parents=True, exist_ok=True)
    rec = d / "one.mcap"
    if not rec.exists():
        scen = d / "s.toml"
        scen.write_text(
            'format = "thermrs-scenario/1"\nseed = 1\n[[run]]\nname = "run1"\nspeed_pct = 30\n'
            'duration_min = 5\ncycle_s = 60\nstart = "ambient"\n'
        )
        simulate(thermrs.load_rig(), scen, rec, seed=1)
    ds = d / f"ds-{n}"
    if not (ds / "_catalog").is_dir() or len(list((ds / "_catalog").iterdir())) != n:
        shutil.rmtree(ds, ignore_errors=True)
        thermrs.campaign([rec], ds)
        (frag,) = (ds / "_catalog").glob("*.parquet")
        row = pl.read_parquet(frag)
        frag.unlink()
        for i in range(n):
            row.with_columns(pl.lit(f"r{i:06d}").alias("recording")).write_parquet(
                ds / "_catalog" / f"r{i:06d}.parquet"
            )
    return ds


def python_loop(ds: Path) -> pl.DataFrame:
    parts = sorted((ds / "_catalog").glob("*.parquet"))
    return pl.concat([pl.read_parquet(p) for p in parts], how="diagonal_relaxed").sort("recording")


def main() -> None:
    from thermrs.campaigns import Dataset

    ap = argparse.ArgumentParser()
    ap.add_argument("--fragments", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--dir", type=Path, default=Path("bench-out/catalog"))
    a = ap.parse_args()
    ds = make(a.dir, a.fragments)
    routes = {
        "Dataset.catalog (one scan)": lambda: Dataset.open(ds).catalog(),
        "loop of read_parquet + concat": lambda: python_loop(ds),
    }
    times: dict[str, list[float]] = {k: [] for k in routes}
    for r in range(a.repeats):
        for name in list(routes)[:: 1 if r % 2 == 0 else -1]:
            t = time.perf_counter()
            df = routes[name]()
            times[name].append(time.perf_counter() - t)
            assert df.height == a.fragments
    base = statistics.median(times["loop of read_parquet + concat"])
    print(f"{a.fragments} fragments, median of {a.repeats}")
    for name, ts in times.items():
        m = statistics.median(ts)
        print(f"  {name:32s} {m * 1000:8.1f} ms   {base / m:5.2f}x")


if __name__ == "__main__":
    main()
