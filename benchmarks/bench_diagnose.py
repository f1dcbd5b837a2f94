"""Backs the BENCHMARKS.md claim "diagnose three 15-h runs < 30 s".

Time a diagnosis of three 15-hour runs once they are extracted (issue #10: under a minute).

The runs are the diagnose-bench generator's (training at 30 %, held out at 75 % and a 10 %
cool-down; 60 s cycles, two cameras: 5,400 visits), with a thermal lag injected. Prints the
wall time of `thermrs.diagnose.diagnose` (best of --repeats) and the verdict.

    python benchmarks/bench_diagnose.py [--hours 15] [--repeats 2]
"""

from __future__ import annotations

import argparse
import os
import time

import thermrs
from thermrs.bench import make_runs
from thermrs.diagnose import diagnose
from thermrs.effects import ThermalLag
from thermrs.memo import CACHE_ENV

# Timed from scratch: no diagnosis is read from the on-disk cache (thermrs.memo).
os.environ[CACHE_ENV] = "off"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--hours", type=float, default=15.0)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    rig = thermrs.load_rig()
    runs = make_runs(rig, ThermalLag(tau_min=60.0), seed=5, hours=args.hours)
    visits = sum(t.height for t in runs)
    best = float("inf")
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        d = diagnose(runs[:1], runs[1:], rig)
        best = min(best, time.perf_counter() - t0)
    print(
        f"{len(runs)} runs of {args.hours:g} h, {visits} visits: diagnosis in {best:.1f} s "
        f"(best of {args.repeats}); verdict {d.status} {d.verdict['effect']}"
    )


if __name__ == "__main__":
    main()
