"""Backs the BENCHMARKS.md rows "campaign folds on Dask workers" and
:data:`thermrs.analyses.diagnose.CLUSTER_FROM_VISITS`.

A leave-one-run-out diagnosis of ``--runs`` runs of ``--hours`` each (the diagnose-bench
generator's runs, a thermal lag injected; three runs per seed), its folds one after another
in this process (``workers=1``) and side by side on the local Dask cluster thermrs starts
(``workers=--workers``, its start included). Prints each route's wall time and CPU (this
process, and its worker processes), and whether the diagnoses are the same.

    python benchmarks/bench_folds.py [--hours 15] [--runs 3] [--workers 2]
"""

from __future__ import annotations

import argparse
import os
import resource
import time

import polars as pl
import thermrs
from thermrs.analyses.diagnose import diagnose_splits
from thermrs.analyses.inputs import Split
from thermrs.bench import make_runs
from thermrs.effects import ThermalLag
from thermrs.memo import CACHE_ENV

# Timed from scratch: no diagnosis is read from the on-disk cache (thermrs.memo).
os.environ[CACHE_ENV] = "off"


def cpu(who: int) -> float:
    """User and system CPU seconds of this process or its reaped children."""
    u = resource.getrusage(who)
    return u.ru_utime + u.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--hours", type=float, default=15.0)
    ap.add_argument("--runs", type=int, default=3, help="a multiple of 3")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    rig = thermrs.load_rig()
    runs: list[pl.DataFrame] = []
    for k in range(args.runs // 3):
        tables = make_runs(rig, ThermalLag(tau_min=60.0), seed=5 + k, hours=args.hours)
        runs += [t.with_columns(pl.col("run") + f"-{k}") for t in tables]
    sets = [
        Split(f"without {i}", [r for j, r in enumerate(runs) if j != i], [runs[i]])
        for i in range(len(runs))
    ]
    visits = sum(t.height for s in sets for t in (*s.train, *s.holdout))
    print(f"{len(sets)} folds of {len(runs)} runs of {args.hours:g} h: {visits} visits in all")
    docs = []
    for workers in (1, args.workers):
        t0, c0, k0 = time.perf_counter(), cpu(resource.RUSAGE_SELF), cpu(resource.RUSAGE_CHILDREN)
        folds = diagnose_splits(sets, rig, workers=workers)
        wall = time.perf_counter() - t0
        own = cpu(resource.RUSAGE_SELF) - c0
        kids = cpu(resource.RUSAGE_CHILDREN) - k0
        docs.append([f.diagnosis.to_json() for f in folds])
        where = "in this process" if workers == 1 else f"on {workers} workers"
        print(f"  {where}: {wall:.1f} s wall, CPU {own:.1f} s here + {kids:.1f} s in workers")
    print(f"  same diagnoses: {docs[0] == docs[1]}")


if __name__ == "__main__":
    main()
