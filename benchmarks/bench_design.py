"""Backs the BENCHMARKS.md claims "thermrs design < 5 minutes" and, from issue #33, "on the
demo's three 15-h runs ≤ 60 s of CPU; on three 15-h runs of a random rig ≤ 2 min".

Time `thermrs design` on three 15-hour runs. By default the demo's: the paper's 30 %, 75 % and
10 % runs with a joint offset, 300 s cycles, on the embedded rig, trained on run 1 and holding
out runs 2 and 3, 24-hour budget. With ``--random-rig SEED`` the same scenario on a random
KR 16-like rig (``tests/support/random_demo.py``, its link 2 and link 3 ROIs simulated with
the calibrated nodes), separating joint_offset from unmodelled_length. Prints the wall and CPU
time of `thermrs.design.design` (the diagnosis, the search, the noise calibration and the
proofs), the recommendation and its proof matrix. The whole command line is timed the same
way with

    /usr/bin/time thermrs design --rig RIG --train demo.mcap#run1 \
        --holdout demo.mcap#run2 demo.mcap#run3 -o bench-out/design --verbose

    python benchmarks/bench_design.py [--workdir bench-out/design-demo] [--random-rig 7]
        [--jobs J] [--recorded-proof]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import thermrs
from thermrs.analyses.demo import simulate_demo
from thermrs.design import design
from thermrs.memo import CACHE_ENV

# Timed from scratch: no diagnosis is read from the on-disk cache (thermrs.memo).
os.environ[CACHE_ENV] = "off"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--workdir", type=Path, default=Path("bench-out/design-demo"))
    ap.add_argument("--random-rig", type=int, default=None, metavar="SEED")
    ap.add_argument("--jobs", type=int, default=None, help="design(jobs=): the proof's threads")
    ap.add_argument("--recorded-proof", action="store_true", help="the proof's runs as recordings")
    args = ap.parse_args()
    between = None
    if args.random_rig is None:
        runs = [r.table for r in simulate_demo(args.workdir, reuse=True).runs]
        rig = thermrs.load_rig()
    else:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
        from tests.support.random_demo import random_demo_runs

        rig, runs = random_demo_runs(args.workdir / f"random-{args.random_rig}", args.random_rig)
        between = ["joint_offset", "unmodelled_length"]
    t0, c0 = time.perf_counter(), time.process_time()
    r = design(
        runs[:1], runs[1:], rig, budget_h=24.0, between=between, jobs=args.jobs,
        recorded_proof=args.recorded_proof,
    )  # fmt: skip
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    doc = r.to_json()
    rec = doc["recommended"]
    print(f"design of 3 runs of 15 h in {wall:.1f} s ({cpu:.1f} s of CPU)")
    print(f"recommended: {rec['label'] if rec else None} ({rec['hours'] if rec else '-'} h)")
    if rec is None:
        print(f"why not: {doc['why_not']}")
    for row in (doc["proof"] or {}).get("matrix", []):
        print(f"  truth {row['truth']}: {row['status']} {row['effect']} right={row['right']}")


if __name__ == "__main__":
    main()
