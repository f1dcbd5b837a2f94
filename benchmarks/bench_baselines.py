"""Backs the BENCHMARKS.md lines on the baselines (issue 49): where the physical model earns its
keep against regressions of the drift on the temperatures, inside and outside the training range.

Runs of the independent bench world (:mod:`thermrs.bench.world`: its own kinematics,
thermal physics, effects and instruments; the diagnoser and the baselines never see its model),
one effect at a target SNR, fresh seeds, independent 2 µm visit errors. Per case two campaigns
of one world (same rig, α, thermal links, rooms, instruments and effect):

- interpolation: training at 30 % from the room; held out, another 30 % run on the next day;
- extrapolation: the same training run; held out, a 75 % run on the next day (another speed)
  and a 10 % run straight after it (a cool-down).
- with ``--two-train``, trained on both speeds: the 30 % and the 75 % run trained on, the
  cool-down held out.

Each campaign is diagnosed (:func:`thermrs.diagnose.diagnose`) and its baselines fitted on the
same training run and scored on the same held-out runs
(:func:`thermrs.analyses.baselines.compare_baselines`); the held-out rms of the nominal model,
the diagnosed model and each baseline is printed per held-out run, then the medians of each
model's rms over the diagnosed model's per kind of held-out run.

    python benchmarks/bench_baselines.py [--effects thermal_lag joint_offset ...] \\
        [--snr 1 2] [--seeds 1] [--first-seed 4900] [--hours 12] [--withheld] [--two-train] \\
        [--json OUT.json]
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from typing import Any
from unittest import mock

import numpy as np
import thermrs
from thermrs.analyses.baselines import MODELS, compare_baselines
from thermrs.bench.world import world as bw
from thermrs.bench.world.cases import case_truths
from thermrs.bench.world.geometry import read_rig
from thermrs.bench.world.world import Campaign, draw_scene, render
from thermrs.diagnose import diagnose

#: The interpolation campaign: the bench world's runs with the held-out 75 % run replaced by
#: another 30 % run (three runs, so that the world's draws are the same as the default's).
RUNS_INTERP = (("train", 0.30, 0), ("hold_same", 0.30, 1), ("hold_cool_after_30", 0.10, 1))
#: What each held-out run tests.
#: The key of a held-out run of the campaign trained on two runs.
TWO = " (trained on 30+75 %)"
KIND = {
    "hold_same": "interpolation (same speed)",
    "hold_fast": "extrapolation (75 %)",
    "hold_cool": "extrapolation (cool-down)",
    "hold_cool" + TWO: "cool-down, trained on 30+75 %",
}
EFFECTS = (
    "thermal_lag",
    "joint_offset",
    "fixture_drift",
    "sensor_drift",
    "unmodelled_length",
    "nonlinear_alpha",
    "alpha_per_link",
)


def one_case(
    rig: Any,
    effect: str,
    snr: float,
    seed: int,
    campaign: Campaign,
    *,
    withheld: bool = False,
    two_train: bool = False,
) -> dict[str, Any]:
    wrig = read_rig(rig.source)
    scene = draw_scene(wrig, campaign, "white", seed)
    truths, reached, _ = case_truths(wrig, scene, (effect,), snr, seed)
    out: dict[str, Any] = {
        "effect": effect,
        "target_snr": snr,
        "snr": reached[0],
        "seed": seed,
        "runs": {},
    }
    # Extrapolation: the bench world's own campaign.
    ext = render(scene, tuple(truths))
    # Interpolation: the same world with the 75 % run replaced by a second 30 % run.
    with mock.patch.object(bw, "RUNS", RUNS_INTERP):
        scene_i = draw_scene(wrig, campaign, "white", seed)
        interp = render(scene_i, tuple(truths))
    splits = [(interp[:1], interp[1:2], ""), (ext[:1], ext[1:], "")]
    if two_train:
        # Trained on both speeds (30 % and 75 %), the cool-down held out.
        splits.append((ext[:2], ext[2:], TWO))
    for train, hold, tag in splits:
        d = diagnose(train, hold, rig, seed=seed)
        c = compare_baselines(train, hold, rig, diagnosis=d, seed=seed, draws=499)
        scored = [c.nominal, c.diagnosed, *c.baselines]
        if withheld:
            # The effect withheld from the library: the physical model as the diagnoser makes
            # it without the truth (what a baseline competes with when the effect is outside
            # the library).
            dx = diagnose(train, hold, rig, seed=seed, exclude=[effect])
            cx = compare_baselines(train, hold, rig, diagnosis=dx, seed=seed, models=())
            assert cx.diagnosed is not None
            scored.append(replace(cx.diagnosed, name="withheld"))
        for m in scored:
            assert m is not None
            for pr in m.per_run:
                row = out["runs"].setdefault(
                    pr["run"] + tag,
                    {
                        "floor_um": c.noise_floor_um,
                        "verdict": d.outcome,
                        "named": d.verdict["effects"],
                    },
                )
                row[m.name] = pr["rms_um"]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--effects", nargs="+", default=list(EFFECTS))
    ap.add_argument("--snr", nargs="+", type=float, default=[1.0, 2.0])
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--first-seed", type=int, default=4900)
    ap.add_argument("--hours", type=float, default=12.0)
    ap.add_argument("--json", default=None)
    ap.add_argument(
        "--two-train",
        action="store_true",
        help="Also train on the 30 % and 75 % runs and hold out the cool-down.",
    )
    ap.add_argument(
        "--withheld",
        action="store_true",
        help="Also diagnose with the true effect excluded from the library (column withheld).",
    )
    args = ap.parse_args()
    rig = thermrs.load_rig()
    campaign = Campaign(hours=args.hours, cycle_s=600.0, sigma_um=2.0)
    cols = ["nominal", "diagnosed", *(["withheld"] if args.withheld else []), *MODELS]
    print(
        f"{'effect':17s} {'SNR':>4s} {'seed':>5s} {'held-out run':12s} {'verdict':19s}"
        + "".join(f"{c[:13]:>14s}" for c in cols),
        flush=True,
    )
    cases = []
    t0 = time.perf_counter()
    for effect in args.effects:
        for snr in args.snr:
            for s in range(args.seeds):
                seed = args.first_seed + s
                c = one_case(
                    rig,
                    effect,
                    snr,
                    seed,
                    campaign,
                    withheld=args.withheld,
                    two_train=args.two_train,
                )
                cases.append(c)
                for run, row in c["runs"].items():
                    print(
                        f"{effect:17s} {c['snr']:4.2f} {seed:5d} {run:12s} "
                        f"{row['verdict'][:19]:19s}" + "".join(f"{row[m]:14.2f}" for m in cols),
                        flush=True,
                    )
    print(f"\n{len(cases)} cases in {time.perf_counter() - t0:.0f} s.")
    summary: dict[str, Any] = {}
    for ref in ["diagnosed", *(["withheld"] if args.withheld else [])]:
        print(
            f"Median over cases of each model's held-out rms ÷ the {ref} model's (and the "
            "cases where it is lower):"
        )
        for run, kind in KIND.items():
            rows = [c["runs"][run] for c in cases if run in c["runs"]]
            if not rows:
                continue
            line = {}
            for m in cols:
                ratio = np.array([r[m] / r[ref] for r in rows])
                line[m] = {
                    "median_ratio": float(np.median(ratio)),
                    "lower": int(np.sum(ratio < 1.0)),
                    "cases": len(rows),
                }
            summary.setdefault(ref, {})[kind] = line
            print(
                f"  {kind:28s}"
                + "".join(
                    f"  {m}: {v['median_ratio']:.2f} ({v['lower']}/{v['cases']})"
                    for m, v in line.items()
                    if m != ref
                )
            )
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump({"cases": cases, "summary": summary, "hours": args.hours}, fh, indent=1)


if __name__ == "__main__":
    main()
