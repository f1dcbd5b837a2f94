"""Backs the BENCHMARKS.md claim "issue 16's failing kinds: named blind, never none withheld".

The diagnoser on the kinds of case issue 16 saw it fail on, made by the independent bench
world (:mod:`thermrs.bench.world`): three 15-h runs (30 %; next day 75 %, then 10 %
straight after), 600 s cycles, independent 2 µm visit errors, one effect at the issue's size,
blind and with the effect excluded from the library.

    python benchmarks/bench_diagnose_cases.py [--seeds 4]
"""

from __future__ import annotations

import argparse

import thermrs
from thermrs.bench.world.cases import make_case
from thermrs.bench.world.world import Campaign
from thermrs.diagnose import diagnose

#: (effect, SNR): the issue's table (effect rms over the nominal model ÷ 2 µm).
CASES = (("thermal_lag", 1.05), ("thermal_lag", 1.85), ("fixture_drift", 1.3),
         ("sensor_drift", 0.65))  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=4)
    args = ap.parse_args()
    rig = thermrs.load_rig()
    campaign = Campaign(hours=15.0, cycle_s=600.0, sigma_um=2.0)
    for effect, snr in CASES:
        for seed in range(args.seeds):
            tables, _, reached = make_case(
                str(rig.source), (effect,), snr, world="white", seed=seed, campaign=campaign
            )
            blind = diagnose(tables[:1], tables[1:], rig, seed=seed)
            excl = diagnose(tables[:1], tables[1:], rig, seed=seed, exclude=[effect])
            print(
                f"{effect:14s} SNR {reached[0]:.2f} seed {seed}: {blind.status} "
                f"{blind.verdict['effects']} | excluded: {excl.status} {excl.verdict['effects']}",
                flush=True,
            )


if __name__ == "__main__":
    main()
