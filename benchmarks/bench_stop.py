"""Backs the BENCHMARKS.md rows of issue 48's stop rule: the sequential diagnosis
(:mod:`thermrs.diagnose.sequential`) on the independent bench world, against the fixed protocol.

Each case is a bench-world case (:mod:`thermrs.bench.world`): three runs of ``--hours``
(training at 30 %; on another day 75 % from the room, then 10 % straight after it), one effect
at a target SNR or none. The second day is the recording being watched: the held-out runs,
one after the other, ``2 × hours`` long, the plan (the fixed protocol). A :class:`StopRule`
looks every ``--look-every-h`` hours of it until it says stop; the verdict at the stop is
scored as the bench scores a diagnosis (:func:`thermrs.bench.world.score.outcome`),
and so is the fixed protocol's (the whole recording diagnosed once at the full level).

    python benchmarks/bench_stop.py --seeds 2 --first-seed 4810000 --jobs 2 --jsonl stop.jsonl
    python benchmarks/bench_stop.py --summarize stop.jsonl

Each finished case is appended to ``--jsonl`` as it comes (a run cut short keeps what it did);
``--summarize`` counts a file of them.

Seeds 1000–4999 are the diagnoser's rules' own and are refused.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from multiprocessing import get_context
from typing import Any

import polars as pl
import thermrs
from scipy.stats import binomtest
from thermrs.bench.world.cases import (
    REACH,
    Case,
    _summary,
    case_rigs,
    case_truths,
    plan,
    worker_init,
)
from thermrs.bench.world.score import outcome
from thermrs.bench.world.truth import EFFECTS
from thermrs.bench.world.world import Campaign, draw_scene, render

#: Outcomes that are a wrong verdict (``outcome``): an effect named that is not there or not
#: the truth, or ``none`` where there is an effect.
WRONG = ("false attribution", "false none", "wrong")


@dataclass(frozen=True)
class Job:
    case: Case
    look_every_h: float
    level: float
    care_um: float | None


def run(job: Job) -> dict[str, Any]:
    """One case: the looks until the rule stops, and the fixed protocol's diagnosis."""
    from thermrs.diagnose import diagnose
    from thermrs.diagnose.sequential import StopRule

    t0 = time.process_time()
    case = job.case
    rig, wrig = case_rigs(case.rig_path)
    scene = draw_scene(
        wrig, case.campaign, case.world, case.seed, tolerances=rig.tolerances, scale=1.0
    )
    truths, snrs, _ = case_truths(wrig, scene, case.effects, case.target_snr, case.seed)
    row: dict[str, Any] = {
        "hours": case.campaign.hours,
        "look_every_h": job.look_every_h,
        "level": job.level,
        "kind": case.kind,
        "world": case.world,
        "truth": list(case.effects),
        "seed": case.seed,
        "target_snr": case.target_snr,
        "snr": snrs,
    }
    if any(s < REACH * case.lowest_snr for s in snrs):
        row["skipped"] = "the effect cannot reach the lowest SNR within its amplitude cap"
        return row
    tables = render(scene, tuple(truths))
    recording = pl.concat(tables[1:])
    planned = 2.0 * case.campaign.hours
    rule = StopRule(
        planned_hours=planned, look_every_h=job.look_every_h, level=job.level, care_um=job.care_um
    )
    h = 0.0
    while not rule.stopped:
        h = min(h + job.look_every_h, planned)
        rule.look(tables[:1], recording, rig, hours=h, seed=case.seed)
    last = rule.looks[-1]
    assert last.diagnosis is not None
    stop = {**row, **_summary(last.diagnosis.to_json())}
    fixed = diagnose(tables[:1], tables[1:], rig, seed=case.seed, level=job.level)
    fix = {**row, **_summary(fixed.to_json())}
    row.update(
        {
            "planned_hours": planned,
            "stop_hours": last.hours,
            "settled": last.settled,
            "hours_saved": planned - last.hours,
            "stop_status": stop["status"],
            "stop_named": stop["named"],
            "stop_outcome": outcome(stop),
            "fixed_status": fix["status"],
            "fixed_named": fix["named"],
            "fixed_outcome": outcome(fix),
            "message": last.message,
            "looks": [
                {
                    "hours": lk.hours,
                    "level": lk.level,
                    "status": lk.status,
                    "named": list(lk.named),
                    "detectable_95_um": lk.detectable_95_um,
                }
                for lk in rule.looks
            ],
            "cpu_s": time.process_time() - t0,
        }
    )
    return row


def _ci(k: int, n: int) -> str:
    if n == 0:
        return f"{k} of {n}"
    lo, hi = binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
    return f"{k} of {n} ({k / n:.1%}; 95 % CI {lo:.1%}–{hi:.1%})"


def summarize(rows: list[dict[str, Any]]) -> dict[str, Any]:
    done = [r for r in rows if "skipped" not in r]
    out: dict[str, Any] = {}
    for label, sel in (
        ("effect-free", [r for r in done if r["kind"] == "none"]),
        ("one effect", [r for r in done if r["kind"] == "single"]),
        ("all", done),
    ):
        n = len(sel)
        out[label] = {
            "cases": n,
            "wrong_at_stop": _ci(sum(r["stop_outcome"] in WRONG for r in sel), n),
            "wrong_fixed": _ci(sum(r["fixed_outcome"] in WRONG for r in sel), n),
            "settled_early": _ci(sum(r["settled"] for r in sel), n),
            "wrong_among_settled": _ci(
                sum(r["stop_outcome"] in WRONG for r in sel if r["settled"]),
                sum(r["settled"] for r in sel),
            ),
            "identified_truth_alone_at_stop": _ci(sum(_alone(r, "stop") for r in sel), n),
            "identified_truth_alone_fixed": _ci(sum(_alone(r, "fixed") for r in sel), n),
            "stop_outcomes": _counts([r["stop_outcome"] for r in sel]),
            "fixed_outcomes": _counts([r["fixed_outcome"] for r in sel]),
            "median_hours_saved": statistics.median([r["hours_saved"] for r in sel])
            if sel
            else None,
            "mean_hours_saved": statistics.fmean([r["hours_saved"] for r in sel]) if sel else None,
            "median_stop_hours_settled": statistics.median(
                [r["stop_hours"] for r in sel if r["settled"]]
            )
            if any(r["settled"] for r in sel)
            else None,
        }
    out["by_effect"] = {
        e: {
            "cases": len(s),
            "stop": _counts([r["stop_outcome"] for r in s]),
            "stop_hours": [r["stop_hours"] for r in s],
        }
        for e in EFFECTS
        if (s := [r for r in done if r["truth"] == [e]])
    }
    out["skipped"] = len(rows) - len(done)
    return out


def _alone(r: dict[str, Any], which: str) -> bool:
    """``identified`` with exactly the true effects named (the bench's strict right)."""
    named = set(r[f"{which}_named"])
    return r[f"{which}_status"] == "identified" and bool(named) and named == set(r["truth"])


def _counts(xs: list[str]) -> dict[str, int]:
    c: dict[str, int] = {}
    for x in xs:
        c[x] = c.get(x, 0) + 1
    return c


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--first-seed", type=int, default=None)
    ap.add_argument("--summarize", default=None, help="count the cases of a --jsonl file")
    ap.add_argument("--snr", type=float, nargs="+", default=[1.0, 2.0])
    ap.add_argument("--effect", nargs="*", default=None, help="default: every effect")
    ap.add_argument("--worlds", nargs="+", default=["white", "ar1"])
    ap.add_argument("--nulls", type=int, default=5, help="effect-free cases per seed and world")
    ap.add_argument("--hours", type=float, default=12.0, help="length of each run")
    ap.add_argument("--cycle-s", type=float, default=600.0)
    ap.add_argument("--look-every-h", type=float, default=2.0)
    ap.add_argument("--level", type=float, default=0.05)
    ap.add_argument("--care-um", type=float, default=None)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--jsonl", default=None, help="append each case's row to this file")
    args = ap.parse_args()
    if args.summarize:
        with open(args.summarize) as f:
            found = [json.loads(line) for line in f if line.strip()]
        print(json.dumps(summarize(found), indent=2, ensure_ascii=False))
        print(f"{len(found)} cases")
        return
    if args.first_seed is None:
        raise SystemExit("give --first-seed (fresh seeds: not 1000–4999)")
    last = args.first_seed + 1000 * args.seeds
    if args.first_seed <= 4999 and last > 1000:
        raise SystemExit("seeds 1000–4999 are the diagnoser's rules' own: give fresh ones")
    rig = thermrs.load_rig()
    cases = plan(
        str(rig.source),
        seeds=args.seeds,
        effects=tuple(EFFECTS if args.effect is None else args.effect),
        worlds=tuple(args.worlds),
        snrs=tuple(sorted(args.snr)),
        campaign=Campaign(hours=args.hours, cycle_s=args.cycle_s, sigma_um=2.0),
        nulls=args.nulls,
        pairs=False,
        withheld=False,
        first_seed=args.first_seed,
    )
    jobs = [Job(c, args.look_every_h, args.level, args.care_um) for c in cases]
    os.environ.setdefault("THERMRS_CACHE_DIR", tempfile.mkdtemp(prefix="thermrs-stop-"))
    t0 = time.perf_counter()
    rows: list[dict[str, Any]] = []

    def done(r: dict[str, Any]) -> None:
        rows.append(r)
        if args.jsonl:
            with open(args.jsonl, "a") as f:
                f.write(json.dumps(r, default=float) + "\n")
        truth = "+".join(r["truth"]) or "none"
        got = (
            "skipped"
            if "skipped" in r
            else f"{r['stop_status']} {r['stop_named']} at {r['stop_hours']:g} h "
            f"({r['stop_outcome']}; fixed: {r['fixed_outcome']})"
        )
        print(f"{len(rows)}/{len(jobs)} {r['world']} {truth} SNR {r['target_snr']:g}: {got}",
              flush=True)  # fmt: skip

    if args.jobs <= 1:
        worker_init()
        for j in jobs:
            done(run(j))
    else:
        with ProcessPoolExecutor(args.jobs, get_context("spawn"), initializer=worker_init) as pool:
            for fut in as_completed([pool.submit(run, j) for j in jobs]):
                done(fut.result())
    print(json.dumps(summarize(rows), indent=2, ensure_ascii=False))
    print(f"{len(rows)} cases in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
