"""Backs the BENCHMARKS.md claim "thermrs design < 5 minutes".

Time `thermrs design` on the demo's three 15-hour runs (issue #18: under 5 minutes).

Simulates the demo scenario (the paper's 30 %, 75 % and 10 % runs with a joint offset, 300 s
cycles), extracts it, cuts it into its runs, then runs `thermrs.design.design` (training on
run 1, holding out runs 2 and 3; 24-hour budget) and prints the wall time of the design (the
diagnosis, the search, the noise calibration and the proofs), the recommendation and its proof
matrix. The whole command line is timed the same way with

    /usr/bin/time -v thermrs design --rig RIG --train demo.mcap#run1 \
        --holdout demo.mcap#run2 demo.mcap#run3 -o bench-out/design

    python benchmarks/bench_design.py [--workdir bench-out/design-demo]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import thermrs
from thermrs.design import design
from thermrs.report.demo import simulate_demo


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--workdir", type=Path, default=Path("bench-out/design-demo"))
    args = ap.parse_args()
    runs = simulate_demo(args.workdir, reuse=True).runs
    rig = thermrs.load_rig()
    t0 = time.perf_counter()
    r = design([runs[0].table], [x.table for x in runs[1:]], rig, budget_h=24.0)
    wall = time.perf_counter() - t0
    doc = r.to_json()
    rec = doc["recommended"]
    print(f"design of 3 runs of 15 h in {wall:.0f} s")
    print(f"recommended: {rec['label'] if rec else None} ({rec['hours'] if rec else '-'} h)")
    for row in (doc["proof"] or {}).get("matrix", []):
        print(f"  truth {row['truth']}: {row['status']} {row['effect']} right={row['right']}")


if __name__ == "__main__":
    main()
