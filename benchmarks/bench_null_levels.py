"""Backs the BENCHMARKS.md row "each test of `none` at its stated level on effect-free worlds"
(issue #45).

A verdict other than `none` on an effect-free rig must come no more often than the level says,
and so must each of the four tests `none` must pass (the first step's: the held-out residual at
the floor, white at the thermal time scales, the best candidate's gain, and the floor not
contradicted; Bonferroni at level/4 each). The bench's ``--nulls`` cases draw one noise per
world, so a world whose own rig errs in its tails weighs as much as the rest; here each
effect-free world (``--worlds`` of them from ``--seed`` on, each drawn from its seed as a
bench case's is, :func:`thermrs.bench.world.world.draw_scene`, its nuisances at
``--tolerance-scale`` times the rig's stated tolerances) is rendered again ``--noises`` times
with fresh visit and instrument noise, and every rendering diagnosed. Printed: how many
renderings have each test below level/4 and below the level, and how many are not `none`.

    python benchmarks/bench_null_levels.py --world ar1 --worlds 10 --noises 6 --seed 2300000
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

TESTS = ("p_at_floor", "p_white_at_thermal_scales", "p_best_gain", "p_floor_contradicted")


def one(job: tuple[str, int, int, float, float]) -> list[dict[str, Any]]:
    """Every rendering of one world: its verdict and its first step's four p-values."""
    from thermrs.bench.world.cases import case_rigs, worker_init
    from thermrs.bench.world.world import Campaign, draw_scene, render
    from thermrs.diagnose import diagnose
    from thermrs.rig import default_rig_path, load_rig

    worker_init()
    world, seed, noises, hours, scale = job
    rig = load_rig(default_rig_path())
    _, wrig = case_rigs(rig.source)
    scene = draw_scene(
        wrig,
        Campaign(hours=hours, cycle_s=600.0, sigma_um=2.0),
        world,
        seed,
        tolerances=rig.tolerances,
        scale=scale,
    )
    out = []
    for i in range(noises):
        tables = render(dataclasses.replace(scene, seed=seed * 1000 + i), ())
        doc = diagnose(tables[:1], tables[1:], rig, seed=seed * 1000 + i).to_json()
        first = doc["tests"]["steps"][0]
        out.append(
            {
                "world": world,
                "seed": seed,
                "noise": i,
                "corr_time_min": scene.corr_time_min,
                "status": doc["verdict"]["status"],
                **{k: first[k] for k in TESTS},
            }
        )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", choices=("white", "ar1"), default="ar1")
    ap.add_argument("--worlds", type=int, default=10)
    ap.add_argument("--noises", type=int, default=6)
    ap.add_argument("--seed", type=int, default=2300000)
    ap.add_argument("--hours", type=float, default=15.0)
    ap.add_argument("--tolerance-scale", type=float, default=1.0)
    ap.add_argument("--level", type=float, default=0.05)
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    jobs = [(a.world, a.seed + k, a.noises, a.hours, a.tolerance_scale) for k in range(a.worlds)]
    with ProcessPoolExecutor(a.jobs) as ex:
        rows = [r for got in ex.map(one, jobs) for r in got]
    p = np.array([[r[k] for k in TESTS] for r in rows])
    n = len(rows)
    print(f"{a.world}, {a.hours:g} h, {a.worlds} worlds × {a.noises} noises = {n} diagnoses")
    for j, k in enumerate(TESTS):
        below4 = int(np.sum(p[:, j] < a.level / 4))
        below = int(np.sum(p[:, j] < a.level))
        print(f"  {k}: below {a.level / 4:g} in {below4} of {n}, below {a.level:g} in {below}")
    other = sum(r["status"] != "none" for r in rows)
    print(f"  not `none`: {other} of {n}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"args": vars(a), "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
