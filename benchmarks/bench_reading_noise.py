"""Backs the BENCHMARKS.md row "a noisy thermography is the instrument's" (issue #45).

Each case: the independent bench world (:mod:`thermrs.bench.world`: its own kinematics,
thermal network and instruments, the rig's errors at 1× its stated tolerances) renders three
15-h runs, effect-free or with one effect at a target SNR, and every link's reading gets white
noise of ``--reading-noise`` kelvin added (beside the world's own 0.03 K): a thermography
scattering from visit to visit by reflections, a ROI on an edge. The runs are diagnosed as
``thermrs diagnose`` does; counted per noise size:

- effect-free: the verdict (an effect of the robot named, the thermal camera named, `none`,
  `unexplained` with nothing named);
- with an effect: the true effect named (lenient: among others);
- every case: each ROI's reading noise estimate against the truth (the added noise and the
  world's in quadrature), and the chips' and poses' part of the floor
  (``noise_floor.thermometers.chips_ci95``) against the world's visit repeatability σ.

``--pose-correlation-min``: the AR(1) world's pose error correlated over that time instead of
a time drawn in 10–30 min (the floor counts as noise a correlation time up to a tenth of the
shortest thermal time constant, about 23 min on these runs; anything slower is gap).

Seeds from ``--seed`` (fresh: never the seeds 1000–4999 the diagnoser's rules were chosen on).

    python benchmarks/bench_reading_noise.py --reading-noise 0.1 0.3 --cases 10 \
        --effect none thermal_lag --seed 2630000 --jobs 2
"""

from __future__ import annotations

import argparse
import dataclasses
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

WORLD_K = 0.03  # the bench world's own reading noise per link (K)


def one(args: tuple[str, str, int, float, float, float | None]) -> dict[str, Any]:
    import polars as pl
    import thermrs
    from thermrs.bench.world.cases import case_rigs, case_truths
    from thermrs.bench.world.world import Campaign, draw_scene, render
    from thermrs.diagnose import diagnose
    from thermrs.effects import is_instrument

    effect, world, seed, extra_k, snr, corr_min = args
    rig, wrig = case_rigs(str(thermrs.default_rig_path()))
    scene = draw_scene(wrig, Campaign(hours=15.0), world, seed, tolerances=rig.tolerances)
    if corr_min is not None:  # the AR(1) world's pose error at this correlation time
        scene = dataclasses.replace(scene, corr_time_min=corr_min)
    truths: tuple[Any, ...] = ()
    if effect != "none":
        got, _, _ = case_truths(wrig, scene, (effect,), snr, seed)
        truths = tuple(got)
    tables = render(scene, truths)
    rng = np.random.default_rng([seed, 7])
    links = list(scene.ir_gain)
    tables = [
        t.with_columns(
            **{f"{k}_c": pl.col(f"{k}_c") + rng.normal(0.0, extra_k, t.height) for k in links}
        )
        for t in tables
    ]
    doc = diagnose(tables[:1], tables[1:], rig, seed=seed, bootstrap=0).to_json()
    v = doc["verdict"]
    th = doc["noise_floor"].get("thermometers") or {}
    truth_k = float(np.hypot(extra_k, WORLD_K))
    est = th.get("reading_noise_k") or {}
    chips = th.get("chips_ci95")
    sigma = scene.campaign.sigma_um
    return {
        "effect": effect,
        "world": world,
        "seed": seed,
        "reading_noise_k": extra_k,
        "status": v["status"],
        "named": v["effects"],
        "robot_named": [e for e in v["effects"] if not is_instrument(e)],
        "true_named": effect in v["effects"],
        "reading_rel_error": [est[k] / truth_k - 1.0 for k in links if k in est],
        "chips_covers": None if not chips else bool(chips[0] <= sigma <= chips[1]),
        "floor_covers": bool(
            doc["noise_floor"]["holdout_ci95"][0] <= sigma <= doc["noise_floor"]["holdout_ci95"][1]
        ),
        "thermometers_um": th.get("thermometers_um"),
        "floor_um": doc["noise_floor_um"],
        "sigma_um": sigma,
    }


def _cp(k: int, n: int) -> str:
    from scipy.stats import beta

    lo = beta.ppf(0.025, k, n - k + 1) if k > 0 else 0.0
    hi = beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    return f"{k}/{n} ({lo:.0%}–{hi:.0%})"


def _statuses(rs: list[dict[str, Any]]) -> str:
    return ", ".join(
        f"{s} {sum(r['status'] == s for r in rs)}" for s in sorted({r["status"] for r in rs})
    )


def _report(head: str, effect: str, rs: list[dict[str, Any]]) -> None:
    if effect == "none":
        robot = sum(bool(r["robot_named"]) for r in rs)
        inst = sum(bool(r["named"]) and not r["robot_named"] for r in rs)
        print(f"{head} an effect of the robot named {_cp(robot, len(rs))}; the thermal camera "
              f"named {inst}; {_statuses(rs)}")  # fmt: skip
    else:
        hit = sum(r["true_named"] for r in rs)
        print(f"{head} {effect} named {_cp(hit, len(rs))}; {_statuses(rs)}")
    err = np.abs([x for r in rs for x in r["reading_rel_error"]])
    chips = [r["chips_covers"] for r in rs if r["chips_covers"] is not None]
    floor = [r["floor_covers"] for r in rs]
    if len(err):
        med, top = np.median(err), np.max(err)
        print(f"  reading noise estimate: median |error| {med:.1%}, max {top:.1%}")
    print(f"  chips' part's interval covers σ {_cp(sum(chips), len(chips))}; the whole "
          f"floor's {_cp(sum(floor), len(floor))}")  # fmt: skip
    f = np.array([r["floor_um"] for r in rs])
    t = np.array([r["thermometers_um"] or 0.0 for r in rs])
    c = np.sqrt(np.maximum(f**2 - t**2, 0.0))
    print(f"  the floor {f.mean():.3f} µm on average (sd {f.std(ddof=1):.3f}), its chips' part "
          f"{c.mean():.3f}, against σ = {rs[0]['sigma_um']:g}")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reading-noise", type=float, nargs="+", default=[0.1, 0.3])
    ap.add_argument("--effect", nargs="+", default=["none", "thermal_lag"])
    ap.add_argument("--world", nargs="+", default=["white", "ar1"])
    ap.add_argument("--cases", type=int, default=10, help="per effect, world and noise size")
    ap.add_argument("--snr", type=float, default=2.0)
    ap.add_argument("--seed", type=int, default=2630000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument(
        "--pose-correlation-min",
        type=float,
        default=None,
        help="the AR(1) world's pose error correlated over this many minutes (default: drawn "
        "in 10–30 min)",
    )
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    todo = [
        (e, w, a.seed + 1000 * i + 10 * j + k, x, a.snr, a.pose_correlation_min)
        for i in range(a.cases)
        for j, x in enumerate(a.reading_noise)
        for k, (e, w) in enumerate((e, w) for e in a.effect for w in a.world)
    ]
    with ProcessPoolExecutor(a.jobs) as pool:
        rows = list(pool.map(one, todo))
    for x in a.reading_noise:
        for e in a.effect:
            for w in a.world:
                rs = [
                    r for r in rows if (r["reading_noise_k"], r["effect"], r["world"]) == (x, e, w)
                ]
                if rs:
                    _report(f"reading noise {x} K, {e}, {w}:", e, rs)
    if a.json:
        import json

        with open(a.json, "w", encoding="utf-8") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
