"""Backs the BENCHMARKS.md rows "a rig worse than it states" and "blind right, before and after
the rig's excess is tested" (issue #45).

The cases are ``thermrs diagnose-bench``'s (:func:`thermrs.bench.world.cases.plan`,
the same seeds for the same ``--seed``, ``--nulls`` and ``--effect``), without the withheld
and two-effect diagnoses: each case is diagnosed once, as the bench's blind half does. The
independent bench world draws its rig and IR errors at ``--tolerance-scale`` times the rig's
stated tolerances. Printed per nuisance world: the bench's outcome classes (strict beside
lenient for cases with an effect), how often an effect of the robot is named on an
effect-free case, and how the diagnosis's estimate of that factor (``tests.tolerance_scale``)
does against the world's: its 95 % interval's coverage, its one-sided 95 % upper bound's
misses, and how often the verdict says the rig errs by more than it states.

    python benchmarks/bench_rig_excess.py --nulls 20 --tolerance-scale 3 --seed 1310000
    python benchmarks/bench_rig_excess.py --effect alpha_per_link thermal_lag \
        unmodelled_length fixture_drift sensor_drift joint_offset nonlinear_alpha \
        --snr 1 2 --seed 1340000
"""

from __future__ import annotations

import argparse
import json
import os
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np


def _with_scale(summary: Any) -> Any:
    """The bench's row of a diagnosis, with what this benchmark reads beside it."""

    def row(doc: dict[str, Any]) -> dict[str, Any]:
        out: dict[str, Any] = summary(doc)
        out["tolerance_scale"] = doc["tests"].get("tolerance_scale")
        out["tolerance_excess"] = doc["tests"].get("tolerance_excess")
        out["rig_errors_exceed_stated"] = doc["verdict"].get("rig_errors_exceed_stated")
        out["gap_closed_raw_ci95"] = doc["how_far"].get("gap_closed_raw_ci95")
        return out

    row.wrapped = True  # type: ignore[attr-defined]
    return row


def one(case: Any) -> dict[str, Any]:
    from thermrs.bench.world import cases

    cases.worker_init()
    if not getattr(cases._summary, "wrapped", False):
        cases._summary = _with_scale(cases._summary)
    return cases.run_case(case)


def main() -> None:
    from thermrs.bench.world.cases import plan
    from thermrs.bench.world.score import INSTRUMENTS, outcome, strict_outcome
    from thermrs.bench.world.world import Campaign
    from thermrs.rig import default_rig_path

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--effect", nargs="*", default=[])
    ap.add_argument("--snr", type=float, nargs="+", default=[1.0, 2.0])
    ap.add_argument("--nulls", type=int, default=0)
    ap.add_argument("--tolerance-scale", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=1310000)
    ap.add_argument("--hours", type=float, default=15.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    os.environ.setdefault("THERMRS_CACHE_DIR", "off")
    todo = plan(
        str(default_rig_path()),
        seeds=1,
        effects=tuple(a.effect),
        worlds=("white", "ar1"),
        snrs=tuple(a.snr),
        campaign=Campaign(hours=a.hours),
        nulls=a.nulls,
        pairs=False,
        withheld=False,
        first_seed=a.seed,
        tolerance_scale=a.tolerance_scale,
    )
    with ProcessPoolExecutor(a.jobs) as pool:
        rows = [r for r in pool.map(one, todo) if "skipped" not in r]
    k = a.tolerance_scale
    for world in ("white", "ar1"):
        here = [r for r in rows if r["world"] == world]
        free = [r for r in here if r["kind"] == "none"]
        eff = [r for r in here if r["kind"] != "none"]
        print(f"{world}: {len(here)} cases")
        if free:
            robot = sum(
                1
                for r in free
                if r["status"] in ("identified", "ambiguous", "partially explained")
                and set(r["named"]) - INSTRUMENTS
            )
            print(f"  effect-free: {dict(Counter(outcome(r) for r in free))}")
            print(f"  effect-free, an effect of the robot named: {robot} of {len(free)}")
            ts = [r["tolerance_scale"] for r in free if r.get("tolerance_scale")]
            if ts:
                cover = sum(t["ci95"][0] <= k <= t["ci95"][1] for t in ts)
                below = sum(t["upper95"] < k for t in ts)
                est = np.median([t["estimate"] for t in ts])
                print(
                    f"  factor (world {k:g}): median estimate {est:.2f}, 95 % interval covers "
                    f"{cover} of {len(ts)}, upper bound below it {below} of {len(ts)}"
                )
        if eff:
            print(f"  blind: {dict(Counter(outcome(r) for r in eff))}")
            print(f"  blind, strict: {dict(Counter(strict_outcome(r) for r in eff))}")
        said = sum(bool(r.get("rig_errors_exceed_stated")) for r in here)
        print(f"  the verdict says the rig errs by more than it states: {said} of {len(here)}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1, default=float)


if __name__ == "__main__":
    main()
