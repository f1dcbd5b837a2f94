"""Backs the BENCHMARKS.md row "strict identification: what any test could reach" (issue #45).

For every one-effect case of ``thermrs diagnose-bench --json`` output(s), the same world and
effect are drawn again (seed, world, target SNR, tolerance scale, run length, from the file)
and :func:`thermrs.bench.world.separability.strict_power_bound` bounds the probability that
*any* level-5 % test names the effect alone: the most powerful test of the closest member of
the hardest rival family against the truth, from the world's own noise-free signatures. The sum
of those bounds over a family's cases bounds the expected number of strictly right verdicts:
where it falls short of 90 % of the cases, strict identification at 90 % is impossible on these
runs' poses, whatever the diagnoser — the data cannot tell the effects apart, and only another
experiment (``thermrs design``) can.

    thermrs diagnose-bench --hours 15 --seeds 2 --snr 0.5 1 2 4 --json h15.json
    python benchmarks/bench_separability.py h15.json --jobs 2

With ``--guarded 2 3``, each case also gets
:func:`thermrs.bench.world.separability.guarded_power_bound` at those scales: the most any test
could name an effect at all while naming one in at most 5 % of the effect-free worlds whose
rig errs by that many times its stated tolerances (the guard :mod:`thermrs.diagnose.guard`
keeps). Summed per family beside the lenient count.
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from typing import Any


def one(args: tuple[dict[str, Any], dict[str, Any], str]) -> dict[str, Any]:
    from thermrs.bench.world.cases import case_rigs, case_truths
    from thermrs.bench.world.separability import guarded_power_bound, strict_power_bound
    from thermrs.bench.world.world import Campaign, draw_scene

    row, setup, rig_path, guarded, draws, strict = args
    rig, wrig = case_rigs(rig_path)
    campaign = Campaign(
        hours=float(setup["hours"]), cycle_s=float(setup["cycle_s"]), sigma_um=setup["sigma_um"]
    )
    scene = draw_scene(
        wrig,
        campaign,
        row["world"],
        row["seed"],
        tolerances=rig.tolerances,
        scale=float(row.get("tolerance_scale", 1.0)),
    )
    truths, snrs, _ = case_truths(
        wrig, scene, tuple(row["truth"]), float(row["target_snr"]), row["seed"]
    )
    b: dict[str, Any] = strict_power_bound(scene, tuple(truths)) if strict else {}
    for k in guarded:
        g = guarded_power_bound(
            scene, tuple(truths), tolerances=rig.tolerances, scale=k, draws=draws, seed=row["seed"]
        )
        b[f"guarded_{k:g}"] = g["power_bound"]
    return {
        "effect": row["truth"][0],
        "world": row["world"],
        "seed": row["seed"],
        "snr": snrs[0],
        "strict_outcome": row.get("strict_outcome"),
        "outcome": row.get("outcome"),
        "status": row.get("status"),
        "named": row.get("named"),
        **b,
    }


def main() -> None:
    import numpy as np
    import thermrs

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("bench_json", nargs="+", help="diagnose-bench --json output")
    ap.add_argument("--rig", default=str(thermrs.default_rig_path()))
    ap.add_argument("--min-snr", type=float, default=1.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", default=None)
    ap.add_argument("--effect", nargs="*", default=[], help="only these effects' cases")
    ap.add_argument(
        "--no-strict", action="store_true", help="the guarded bound only (no strict ceiling)"
    )
    ap.add_argument("--draws", type=int, default=400, help="nuisance draws per scale (guarded)")
    ap.add_argument(
        "--guarded",
        type=float,
        nargs="*",
        default=[],
        help="also the guarded bound at these multiples of the stated tolerances",
    )
    a = ap.parse_args()
    todo = []
    for path in a.bench_json:
        with open(path) as f:
            doc = json.load(f)
        for r in doc["results"]:
            if r["kind"] == "single" and "skipped" not in r and r["target_snr"] >= a.min_snr:
                if a.effect and r["truth"][0] not in a.effect:
                    continue
                todo.append((r, doc["setup"], a.rig, tuple(a.guarded), a.draws, not a.no_strict))
    with ProcessPoolExecutor(a.jobs) as pool:
        rows = list(pool.map(one, todo))
    print(
        f"{'effect':<18} {'cases':>5} {'strict right':>12} {'any test, at most':>18} "
        "hardest rival (cases)"
    )
    for e in sorted({r["effect"] for r in rows} if not a.no_strict else ()):
        here = [r for r in rows if r["effect"] == e]
        right = sum(r["strict_outcome"] == "right" for r in here)
        bound = float(np.sum([r["power_bound"] for r in here]))
        hard: dict[str, int] = {}
        for r in here:
            hard[r["hardest"]] = hard.get(r["hardest"], 0) + 1
        print(
            f"{e:<18} {len(here):>5} {right:>12} {bound:>11.1f} ({bound / len(here):.0%}) "
            + ", ".join(f"{k} {v}" for k, v in sorted(hard.items(), key=lambda kv: -kv[1]))
        )
    for k in a.guarded:
        print(f"\nnamed at all, the null's rig at {k:g}x its tolerances:")
        print(f"{'effect':<18} {'cases':>5} {'lenient right':>13} {'any test, at most':>18}")
        for e in sorted({r["effect"] for r in rows}):
            here = [r for r in rows if r["effect"] == e]
            right = sum(r["outcome"] == "right" for r in here)
            bound = float(np.sum([r[f"guarded_{k:g}"] for r in here]))
            print(f"{e:<18} {len(here):>5} {right:>13} {bound:>11.1f} ({bound / len(here):.0%})")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1, default=float)


if __name__ == "__main__":
    main()
