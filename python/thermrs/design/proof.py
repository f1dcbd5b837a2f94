"""The proof before the robot: a design is recommended only if, for every confounded effect
taken as the truth with the parameters fitted to the user's runs, the simulator performing the
design (the new rig and scenario, that effect switched on, the rig's noise) and the diagnoser
run on the user's runs together with the simulated ones name that effect, ``identified``.

The verdicts are the diagnoser's own (:func:`thermrs.diagnose.diagnose`, its public result):
this module decides nothing about effects, it only records what the diagnoser says.

The user's runs are those of the world the diagnosis found most likely (the rival that fits
their held-out runs best): a proof with another rival as the truth diagnoses them *as that
truth would have made them* (:func:`counterfactual`): their measured spots with the drift the
best-fitting rival predicts replaced by the drift the truth predicts, each at its fitted α and
parameters. The noise and whatever both leave unexplained are kept; without this, runs made
by one effect would argue against every other truth and the proof would test the user's runs,
not the design.

The design's runs are simulated as the simulator's truth (:func:`thermrs.design.forecast.
truth_runs`): every visit's true spot, where the laser met the chip with the robot where it
really stood, and the links' true surface temperatures; no image is rendered, so the runs
carry no centroid noise (0.24 µm rms beside a floor of 1.5–2.7 µm on the demo's rig) and no
reading noise of the temperatures. ``recorded=True`` simulates them as recordings instead,
read back by the extraction: the whole chain, at about 2.5 s of CPU more per truth and 24 h.

Noise: the simulator's joint repeatability is scaled so that the noise floor the diagnoser
measures on an effect-free simulation of the design equals the floor it measured on the user's
runs (repeatability, the dominant term, is scaled by their ratio). That simulation is its
truth alone (:func:`thermrs.design.forecast.truth_runs`: the true spots, the robot's pose
error in; no image rendered): the centroids' own noise, which it leaves out, moved the floor
by 0.0–1.3 % on the demo's design (six seeds), against a spread of ±6 % from seed to seed, and
it only makes the proof's runs a little noisier than the user's, not cleaner.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from thermrs.design.files import rig_toml, scenario_toml
from thermrs.design.forecast import simulated_runs, truth_runs
from thermrs.design.measurements import Candidate
from thermrs.design.separation import Rival
from thermrs.rig import Rig

__all__ = ["calibrate_noise", "prove"]

#: The simulator's default joint repeatability (µrad rms, docs/scenarios.md).
DEFAULT_REPEATABILITY_URAD = 2.0
#: Simulation settings of the proof: one CCD frame per visit, uncompressed chunks (the fastest
#: to write and read).
SIM_EXTRA: dict[str, dict[str, Any]] = {
    "camera": {"frames_per_visit": 1},
    "output": {"compression": "none"},
}


def _split(cand: Candidate, tables: Sequence[pl.DataFrame]) -> tuple[list[pl.DataFrame], ...]:
    role = {r.name: r.role for r in cand.protocol.runs}
    tr = [t for t in tables if t.height and role.get(str(t["run"][0])) == "train"]
    ho = [t for t in tables if t.height and role.get(str(t["run"][0])) == "holdout"]
    return tr, ho


def counterfactual(
    tables: Sequence[pl.DataFrame], rig: Rig, actual: Rival, truth: Rival
) -> list[pl.DataFrame]:
    """The run tables as ``truth`` would have made them (see the module docstring)."""
    from thermrs.signatures import VisitSet

    if truth.effect == actual.effect:
        return list(tables)
    out = []
    for t in tables:
        vs = VisitSet([t], rig)
        d = vs.positions(effects=[truth.truth], alpha_per_k=truth.alpha_per_k) - vs.positions(
            effects=[actual.truth], alpha_per_k=actual.alpha_per_k
        )
        out.append(
            vs.table.with_columns(
                u_um=pl.Series(vs.table["u_um"].to_numpy() + d[: vs.n]),
                v_um=pl.Series(vs.table["v_um"].to_numpy() + d[vs.n :]),
            )
        )
    return out


def calibrate_noise(
    rig: Rig,
    cand: Candidate,
    floor_um: float,
    *,
    cycle_s: float,
    workdir: Path,
    seed: int,
) -> dict[str, float]:
    """The joint repeatability (µrad) that gives the design's simulated runs the user's noise
    floor: one effect-free simulation of its truth at the default repeatability (module docs),
    its floor measured as the diagnoser measures it (:func:`thermrs.diagnose.noise_floor_um`),
    the repeatability scaled by the ratio."""
    from thermrs.diagnose import noise_floor_um

    text, new = rig_toml(rig, cand)
    sc = scenario_toml(
        cand,
        cycle_s=cycle_s,
        name="design noise calibration",
        extra={**SIM_EXTRA, "motion": {"repeatability_urad": DEFAULT_REPEATABILITY_URAD}},
    )
    tables = truth_runs(new, text, sc, workdir=workdir, stem="calibration", seed=seed)
    tr, ho = _split(cand, tables)
    sim_floor = noise_floor_um(tr, ho, new)
    rep = DEFAULT_REPEATABILITY_URAD * floor_um / sim_floor if sim_floor > 0 else 2.0
    return {
        "user_floor_um": floor_um,
        "simulated_floor_um_at_default": sim_floor,
        "repeatability_urad": float(rep),
    }


def prove(
    rig: Rig,
    cand: Candidate,
    rivals: Sequence[Rival],
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    *,
    repeatability_urad: float,
    exclude: Sequence[str],
    cycle_s: float,
    workdir: Path,
    seed: int,
    progress: Callable[[str], object] | None = None,
    jobs: int = 1,
    recorded: bool = False,
) -> dict[str, Any]:
    """The proof matrix of ``cand``: per rival as the truth, the diagnoser's verdict on the
    user's runs (as that truth would have made them, from the rival that fits them best)
    with the design's runs simulated under that truth.

    The truths are proved side by side on ``jobs`` threads (the simulator and the extraction
    run without the GIL, the diagnosis mostly in numpy); each has its own seed, so the matrix
    is the same whatever ``jobs``. Ctrl-C stops every thread within a stage of the diagnosis.
    """
    say = progress or (lambda _m: None)
    # The world the user's runs come from: the rival that fits their held-out runs best.
    actual = min(rivals, key=lambda r: (not r.holdout_rms_um <= np.inf, r.holdout_rms_um))
    stop = threading.Event()

    setting = _Setting(
        rig, cand, actual, train, holdout, repeatability_urad, exclude, cycle_s, workdir, recorded
    )

    def one(k: int, truth: Rival) -> dict[str, Any]:
        return _prove_truth(setting, truth, seed=seed + 1 + k, cancel=stop.is_set)

    jobs = max(1, min(int(jobs), len(rivals)))
    if jobs == 1:
        rows = []
        for k, truth in enumerate(rivals):
            say(f"proof: {truth.effect} as the truth")
            rows.append(one(k, truth))
    else:
        from concurrent.futures import ThreadPoolExecutor

        from threadpoolctl import threadpool_limits  # type: ignore[import-untyped]

        say(f"proof: {', '.join(r.effect for r in rivals)} as the truth, {jobs} at a time")
        with threadpool_limits(limits=1, user_api="blas"), ThreadPoolExecutor(jobs) as pool:
            futures = [pool.submit(one, k, truth) for k, truth in enumerate(rivals)]
            try:
                rows = [f.result() for f in futures]
            except BaseException:
                stop.set()  # the other threads stop at their next check
                for f in futures:
                    f.cancel()
                raise
    return {
        "candidate": cand.label,
        "matrix": rows,
        "all_right": all(r["right"] for r in rows),
        "repeatability_urad": repeatability_urad,
        "seed": seed,
        "route": "recording" if recorded else "truth",
    }


@dataclass(frozen=True)
class _Setting:
    """What every truth of one candidate's proof shares."""

    rig: Rig
    cand: Candidate
    actual: Rival  # the rival that fits the user's held-out runs best
    train: Sequence[pl.DataFrame]
    holdout: Sequence[pl.DataFrame]
    repeatability_urad: float
    exclude: Sequence[str]
    cycle_s: float
    workdir: Path
    recorded: bool  # the design's runs simulated as recordings, not as their truth


def _prove_truth(
    s: _Setting, truth: Rival, *, seed: int, cancel: Callable[[], bool]
) -> dict[str, Any]:
    """One row of the proof matrix: ``truth`` simulated performing the design, diagnosed with
    the user's runs as ``truth`` would have made them."""
    from thermrs.diagnose import diagnose

    def check(_stage: str) -> None:
        if cancel():
            raise KeyboardInterrupt("cancelled")

    _, new = rig_toml(s.rig, s.cand)
    sim_text, _ = rig_toml(s.rig, s.cand, alpha_per_k=truth.alpha_per_k)
    sc = scenario_toml(
        s.cand,
        cycle_s=s.cycle_s,
        name=f"design proof, truth {truth.effect}",
        effects=[truth.truth.to_dict()],
        extra={**SIM_EXTRA, "motion": {"repeatability_urad": s.repeatability_urad}},
    )
    route = simulated_runs if s.recorded else truth_runs
    tables = route(
        new, sim_text, sc, workdir=s.workdir, stem=f"proof-{truth.effect}", seed=seed,
        cancel=cancel,
    )  # fmt: skip
    tr, ho = _split(s.cand, tables)
    u_tr = counterfactual(s.train, s.rig, s.actual, truth)
    u_ho = counterfactual(s.holdout, s.rig, s.actual, truth)
    # The verdict is all a proof reads: the stability score (descriptive, no part of it) is
    # not computed.
    d = diagnose(
        [*u_tr, *tr], [*u_ho, *ho], new, exclude=list(s.exclude), bootstrap=0, progress=check
    ).to_json()
    v = d["verdict"]
    return {
        "truth": truth.effect,
        "truth_params": truth.truth.to_dict(),
        "truth_alpha_per_k": truth.alpha_per_k,
        "status": v["status"],
        "effect": v["effect"],
        "params": v["params"],
        "confounded_with": v.get("confounded_with", []),
        "reason": v.get("reason"),
        "ranking": [
            {"effect": r["effect"], "holdout_rms_um": r["holdout_rms_um"]}
            for r in d.get("ranking", [])[:4]
        ],
        "pairs_cos": [
            {"effects": c.get("effects"), "cos": c.get("cos")} for c in d.get("confounded", [])
        ],
        "right": bool(v["status"] == "identified" and v["effect"] == truth.effect),
        "choices_match": all(
            v["params"].get(k) == val
            for k, val in truth.truth.to_dict().items()
            if k != "name" and isinstance(val, str)
        ),
    }
