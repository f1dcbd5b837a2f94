"""Design the measurement that separates confounded effects, and prove it before the robot.

When the diagnosis is ``ambiguous`` (two or more SPEC §6 effects explain the runs about
equally well), :func:`design`:

1. takes the confounded set (the verdict's effect and its rivals, or the effects given) with
   the parameters the diagnoser fitted to each (:mod:`thermrs.design.separation`);
2. searches candidate additional measurements (:mod:`thermrs.design.measurements`): run
   protocols on the user's rig, and new poses with a new chip where the laser lands, recorded
   with a protocol; their visits and drivers forecast by the simulator's thermal model
   (:mod:`thermrs.design.forecast`);
3. ranks them by the separation criterion (the least, over ordered pairs, of the expected
   margin in standard errors by which the truth beats its rival, ``z_AB = √λ_AB``);
4. proves the best ones (:mod:`thermrs.design.proof`): each rival as the truth, simulated on
   the new rig and scenario with the user's noise floor, diagnosed with the user's runs; the
   design is recommended only if every truth comes out ``identified`` and right;
5. writes ``rig.toml``, ``scenario.toml`` and ``design.json`` (:meth:`DesignResult.write`;
   ``docs/outputs.md``, "SPEC §7 extensions: design.json").

Example
-------
>>> import thermrs
>>> callable(thermrs.design.design)
True
>>> # r = thermrs.design.design([train], [holdout], thermrs.load_rig(), budget_h=24)
>>> # r.write("design-out"); r.recommended["label"]
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import polars as pl

from thermrs.defaults import DESIGN_BUDGET_H
from thermrs.design.files import rig_toml, scenario_toml, write_text_atomic
from thermrs.design.measurements import DEFAULT_LIMITS_DEG, Candidate
from thermrs.design.search import NOT_SEARCHED, Z_TARGET, search
from thermrs.design.separation import Rival, rivals_from
from thermrs.errors import InputError
from thermrs.rig import Rig

__all__ = ["DesignResult", "design", "rival_drift"]

#: Candidates proved at most (best first) before the design gives up.
PROOF_TRIES = 3
#: Format tag of design.json.
FORMAT = "thermrs-design/1"
CRITERION = (
    "z_AB = sqrt(lambda_AB), lambda_AB = min over B's families and parameters of "
    "||P_perp[alpha column, mountings, B's signature] mu_A||^2 / sigma^2: the non-centrality "
    "of the likelihood-ratio test of A (the truth, at the parameters fitted to the user's "
    "runs) against its rival B on the user's runs plus the candidate's, with sigma the noise "
    "floor the diagnosis measured (white noise: optimistic for autocorrelated residuals; the "
    "proof decides). A candidate's score is its least z over ordered pairs."
)


@dataclass
class DesignResult:
    """What :func:`design` found: see :meth:`to_json` (``design.json``)."""

    diagnosis: dict[str, Any]
    confounded: list[str]
    budget_h: float
    limits_deg: tuple[tuple[float, float], ...]
    limits_source: str
    rig: Rig
    cycle_s: float
    rivals: list[Rival] = field(default_factory=list)
    ranked: list[dict[str, Any]] = field(default_factory=list)
    best: Candidate | None = None
    recommended: dict[str, Any] | None = None
    why_not: str | None = None
    proofs: list[dict[str, Any]] = field(default_factory=list)
    now: list[dict[str, Any]] = field(default_factory=list)
    noise: dict[str, float] = field(default_factory=dict)
    recorded_proof: bool = False
    seconds: float = 0.0
    #: The effects asked to be separated (``between``), or None: the diagnosis' confounded.
    between: list[str] | None = None

    @property
    def proof(self) -> dict[str, Any] | None:
        """The proof of the recommended (or else the best tried) candidate."""
        for p in self.proofs:
            if p["all_right"]:
                return p
        return self.proofs[0] if self.proofs else None

    def proofs_tried(self) -> list[dict[str, Any]]:
        """Each proof that ran, in the order tried: the candidate, its rank (1 = best
        least z), hours, least z, and the proof's outcome with the verdicts it got wrong."""
        rank = {c["label"]: c for c in self.ranked}
        out = []
        for i, p in enumerate(self.proofs):
            c = rank.get(p["candidate"], {})
            out.append(
                {
                    "tried": i + 1,
                    "candidate": p["candidate"],
                    "rank": c["rank"] + 1 if "rank" in c else None,
                    "hours": c.get("hours"),
                    "min_z": c.get("min_z"),
                    "all_right": p["all_right"],
                    "wrong": [
                        f"{r['truth']} → {r['status']} {r['effect'] or ''}".strip()
                        for r in p["matrix"]
                        if not r["right"]
                    ],
                }
            )
        return out

    def separation_said(self) -> str | None:
        """The separation now and with the recommended (else the best) candidate, said once
        and in words that agree with the diagnosis: a white-noise z on the given runs that
        looks large beside a diagnosis that could not separate the pair is said to overstate
        what correlated residuals carry (the diagnoser's rival test allows for them)."""
        if not self.now:
            return None
        worst_now = min(self.now, key=lambda p: p["z"])
        said = (
            f"On the given runs the least z is {worst_now['z']:.1f} ({worst_now['truth']} "
            f"over {worst_now['rival']})"
        )
        high = [p for p in self.now if p["z"] >= Z_TARGET]
        # Only a diagnosis that called them confounded "does not separate" them (effects
        # asked for with `between` may be ones it told apart).
        if (
            high
            and self.confounded
            and self.diagnosis.get("verdict", {}).get("status") == ("ambiguous")
        ):
            best = max(high, key=lambda p: p["z"])
            said += (
                f"; z up to {best['z']:.1f} ({best['truth']} over {best['rival']}) counts "
                "every visit as independent and overstates what these runs carry: the "
                "diagnoser, which allows for their correlated residuals, does not separate "
                f"{', '.join(self.confounded)} on them"
            )
        else:
            said += f", below the {Z_TARGET:g} a separation needs"
        target = self.recommended
        if target is None and self.ranked and self.best is not None:
            target = next((c for c in self.ranked if c["label"] == self.best.label), None)
        if target is not None:
            worst = min(target["separation"], key=lambda p: p["z"])
            which = "the recommended measurement" if self.recommended else "the best candidate"
            said += (
                f". With {which} added it would be {worst['z']:.1f} ({worst['truth']} over "
                f"{worst['rival']}, white noise too); the proof by simulation decides"
            )
        return said + "."

    def roles(self) -> dict[str, str]:
        """For each run of the scenario: ``train`` or ``holdout``."""
        if self.best is None:
            return {}
        return {r.name: r.role for r in self.best.protocol.runs}

    def to_json(self) -> dict[str, Any]:
        """The ``design.json`` document."""
        v = self.diagnosis.get("verdict", {})
        return {
            "format": FORMAT,
            "diagnosis": {
                "status": v.get("status"),
                "effect": v.get("effect"),
                "confounded_with": v.get("confounded_with", []),
                "noise_floor_um": self.diagnosis.get("noise_floor_um"),
            },
            "confounded": self.confounded,
            # The effects asked to be separated (--between), or null: the diagnosis' own.
            "between": self.between,
            "rivals": [r.to_json() for r in self.rivals],
            "criterion": CRITERION,
            "separation_now": self.now,
            # The separation now and after, in words that agree with the diagnosis.
            "separation_said": self.separation_said(),
            "budget_h": self.budget_h,
            "joint_limits_deg": [list(x) for x in self.limits_deg],
            "joint_limits_source": self.limits_source,
            "cycle_s": self.cycle_s,
            "candidates": self.ranked,
            "not_searched": NOT_SEARCHED,
            "recommended": self.recommended,
            "why_not": self.why_not,
            "roles": self.roles(),
            "proof": self.proof,
            # Every candidate whose proof ran, in the order tried (the recommendation, if
            # any, is the one that passed).
            "proofs_tried": self.proofs_tried(),
            "noise": self.noise,
            "files": {"rig": "rig.toml", "scenario": "scenario.toml"}
            if self.recommended is not None and self.best is not None
            else {},
            "seconds": self.seconds,
        }

    def write(self, out_dir: str | Path) -> list[Path]:
        """Write ``design.json`` into ``out_dir`` (created), and ``rig.toml`` and
        ``scenario.toml`` of the recommended candidate when one is (a candidate whose proof
        failed is no measurement to make: it stays in ``design.json``), atomically."""
        import json

        d = Path(out_dir)
        d.mkdir(parents=True, exist_ok=True)
        written = []
        if self.recommended is not None and self.best is not None:
            text, _ = rig_toml(self.rig, self.best)
            write_text_atomic(d / "rig.toml", text)
            sc = scenario_toml(
                self.best, cycle_s=self.cycle_s, name=f"thermrs design: {self.best.label}"
            )
            write_text_atomic(d / "scenario.toml", sc)
            written += [d / "rig.toml", d / "scenario.toml"]
        write_text_atomic(d / "design.json", json.dumps(self.to_json(), indent=2))
        written.append(d / "design.json")
        return written


def _confounded(doc: dict[str, Any], between: Sequence[str] | None) -> list[str]:
    if between:
        names = list(dict.fromkeys(between))
        if len(names) < 2:
            raise InputError("--between needs at least two effects to separate")
        return names
    v = doc["verdict"]
    if v["status"] != "ambiguous":
        return []
    return list(dict.fromkeys([v["effect"], *v.get("confounded_with", [])]))


def design(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    rig: Rig | str | os.PathLike[str],
    *,
    exclude: Sequence[str] = (),
    between: Sequence[str] | None = None,
    budget_h: float = DESIGN_BUDGET_H,
    cycle_s: float = 300.0,
    limits_deg: Sequence[tuple[float, float]] | None = None,
    prove_it: bool = True,
    recorded_proof: bool = False,
    seed: int = 0,
    workdir: str | Path | None = None,
    diagnosis: Any | None = None,
    progress: Callable[[str], object] | None = None,
    jobs: int | None = None,
) -> DesignResult:
    """Find and prove the measurement that separates the confounded effects.

    Parameters
    ----------
    train, holdout
        The user's run tables (as for :func:`thermrs.diagnose.diagnose`).
    rig
        The rig they were recorded on.
    exclude
        Effects the diagnoser may not name (passed to every diagnosis).
    between
        The effects to separate (default: the diagnosis's confounded set, if ambiguous).
    budget_h
        Most recording hours (idle time included) a candidate may take.
    cycle_s
        The cycle of the designed runs (one visit of every pose per cycle).
    limits_deg
        Joint ranges (degrees) for new poses; default :data:`DEFAULT_LIMITS_DEG`.
    prove_it
        Run the proof (simulations and diagnoses); without it nothing is recommended.
    recorded_proof
        Simulate the proof's runs as recordings (every image rendered, written and read back
        by the extraction) instead of as the simulator's truth (the true spots with the
        robot's pose error, :func:`thermrs.design.forecast.truth_runs`): the whole chain, at
        about 2.5 s of CPU more per truth and 24 h (module docs of
        :mod:`thermrs.design.proof`).
    seed
        Seed of the proof's simulations.
    workdir
        Where the forecasts and proofs are simulated (default: a temporary folder).
    diagnosis
        The diagnosis of these runs already made (a :class:`thermrs.diagnose.Diagnosis` or
        its JSON document): used as it is, so the design and the diagnosis agree to the last
        digit (default: the runs are diagnosed here).
    progress
        Called with a short message at each stage.
    jobs
        Threads the proof runs its truths on, side by side (default: the cores this process
        may use); the result is the same whatever it is.

    Returns
    -------
    DesignResult
        The ranking, the recommendation (or why none), the roles and the proof;
        :meth:`DesignResult.write` writes ``rig.toml``, ``scenario.toml`` and ``design.json``.

    Raises
    ------
    InputError
        Bad runs (as :func:`~thermrs.diagnose.diagnose`), ``--between`` effects that are not
        effects or were not fitted, a budget below one hour.

    Examples
    --------
    >>> import thermrs
    >>> # r = thermrs.design.design([run1], [run2, run3], thermrs.load_rig(), budget_h=24)
    >>> # r.write("design-out"); r.to_json()["proof"]["matrix"]
    """
    from thermrs.rig import as_rig

    rig = as_rig(rig)
    lim = tuple(limits_deg) if limits_deg is not None else DEFAULT_LIMITS_DEG
    _check_options(rig, budget_h=budget_h, between=between, limits=lim)
    say = progress or (lambda _m: None)
    t0 = time.perf_counter()
    doc, exclude = _the_diagnosis(train, holdout, rig, diagnosis, exclude=exclude, say=say)
    result = _start(
        doc,
        rig,
        between,
        budget_h=budget_h,
        limits_deg=lim,
        limits_source="given" if limits_deg is not None else "default (KUKA KR 15/2 axis ranges)",
        cycle_s=cycle_s,
        recorded_proof=recorded_proof,
    )
    if result.confounded:
        _search_and_prove(result, train, holdout, exclude, workdir, seed, prove_it, say, jobs)
    result.seconds = time.perf_counter() - t0
    return result


def _check_options(
    rig: Rig,
    *,
    budget_h: float,
    between: Sequence[str] | None,
    limits: tuple[tuple[float, float], ...],
) -> None:
    """What :func:`design` can refuse before the runs are diagnosed.

    Raises
    ------
    InputError
        A budget below one hour; a ROI the simulator has no thermal node for; a ``between``
        name that is not an effect; joint limits not one range per joint.
    """
    if not budget_h >= 1.0:
        raise InputError(f"--budget-h {budget_h}: at least 1 hour of recording is needed")
    from thermrs.simulate import DEFAULT_NODES

    uncovered = [r.name for r in rig.rois if r.name not in DEFAULT_NODES]
    if uncovered:
        raise InputError(
            f"rig {Path(rig.source).name}: thermrs design forecasts the links' temperatures "
            f"with the simulator's calibrated thermal nodes ({', '.join(DEFAULT_NODES)}), and "
            f"the ROI(s) {', '.join(uncovered)} have none: a ROI on link 2, link 3 or the base "
            "is forecast when it bears that name"
        )
    if between:
        from thermrs.effects import effect_classes

        known = effect_classes()
        for name in between:
            if name not in known:  # said before the runs are diagnosed, not after
                raise InputError(f"--between {name!r}: not an effect (known: {', '.join(known)})")
    if len(limits) != len(rig.joint_names):
        raise InputError(f"joint limits: {len(limits)} ranges given, the robot has 6 joints")


def _the_diagnosis(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    rig: Rig,
    diagnosis: Any | None,
    *,
    exclude: Sequence[str],
    say: Callable[[str], object],
) -> tuple[dict[str, Any], list[str]]:
    """The diagnosis :func:`design` starts from (``diagnosis`` checked against the runs, or
    the runs diagnosed here) as its JSON document, and the effects it excluded.

    Raises
    ------
    InputError
        A diagnosis of other runs or another rig; ``exclude`` other than the diagnosis's.
    """
    if diagnosis is None:
        from thermrs.diagnose import diagnose as run_diagnosis

        say("diagnosing the given runs")
        doc = run_diagnosis(
            train,
            holdout,
            rig,
            exclude=list(exclude),
            progress=lambda m: say(f"diagnosing the given runs: {m}"),
        ).to_json()
        return doc, list(exclude)
    from thermrs.diagnose import Diagnosis

    given = diagnosis if isinstance(diagnosis, Diagnosis) else Diagnosis.from_json(diagnosis)
    given.check_runs(
        [str(n) for t in train for n in t["run"].unique().to_list()],
        [str(n) for t in holdout for n in t["run"].unique().to_list()],
        tables=[*train, *holdout],
        rig=rig,
    )
    if exclude and sorted(exclude) != sorted(given.excluded):
        raise InputError(
            f"--exclude {' '.join(exclude)}: the diagnosis was made excluding "
            f"{', '.join(given.excluded) or 'nothing'}"
        )
    return given.to_json(), list(given.excluded)


def _start(
    doc: dict[str, Any],
    rig: Rig,
    between: Sequence[str] | None,
    *,
    budget_h: float,
    limits_deg: tuple[tuple[float, float], ...],
    limits_source: str,
    cycle_s: float,
    recorded_proof: bool,
) -> DesignResult:
    """The result before the search: the diagnosis, the effects to separate (``between``, or
    the diagnosis's confounded set) and their rivals, or why there are none."""
    names = _confounded(doc, between)
    result = DesignResult(
        diagnosis=doc,
        confounded=names,
        budget_h=budget_h,
        limits_deg=limits_deg,
        limits_source=limits_source,
        rig=rig,
        cycle_s=cycle_s,
        recorded_proof=recorded_proof,
        between=names if between else None,
    )
    if not names:
        result.why_not = (
            f"the diagnosis is {doc['verdict']['status']}, not ambiguous: there are no "
            "confounded effects to separate (give --between to separate chosen effects)"
        )
    else:
        result.rivals = rivals_from(doc, names, rig)
    return result


def _search_and_prove(
    result: DesignResult,
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    exclude: Sequence[str],
    workdir: str | Path | None,
    seed: int,
    prove_it: bool,
    say: Callable[[str], object],
    jobs: int | None,
) -> None:
    """The search, then the proof of the best candidates, in ``workdir`` (default: a temporary
    folder), the proof's truths on ``jobs`` threads (default: the cores this process may use)."""
    from threadpoolctl import threadpool_limits  # type: ignore[import-untyped]

    with tempfile.TemporaryDirectory(prefix="thermrs-design-") as tmp:
        wd = Path(workdir) if workdir is not None else Path(tmp)
        wd.mkdir(parents=True, exist_ok=True)
        n_jobs = jobs if jobs is not None else len(os.sched_getaffinity(0))
        user_runs = {str(n) for t in [*train, *holdout] for n in t["run"].unique().to_list()}
        with threadpool_limits(limits=1, user_api="blas"):
            found = search(
                [*train, *holdout],
                result.rig,
                result.rivals,
                float(result.diagnosis["noise_floor_um"]),
                budget_h=result.budget_h,
                cycle_s=result.cycle_s,
                limits_deg=result.limits_deg,
                workdir=wd,
                taken=user_runs,
                progress=say,
            )
        result.now = found.now
        result.ranked = [c for c, _ in found.ranked]
        order = found.proof_order
        result.best = order[0] if order else None
        if not order or found.why_not:
            result.why_not = found.why_not or "no candidate fits the budget and joint limits"
        elif not prove_it:
            result.why_not = "not proved (the proof was not asked for): nothing recommended"
        else:
            _prove(result, order, train, holdout, exclude, wd, seed, say, n_jobs)


def _prove(
    result: DesignResult,
    order: Sequence[Candidate],
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    exclude: Sequence[str],
    wd: Path,
    seed: int,
    say: Callable[[str], object],
    jobs: int,
) -> None:
    from thermrs.design.proof import calibrate_noise, prove

    floor = float(result.diagnosis["noise_floor_um"])
    say("calibrating the simulator's noise to the runs' noise floor")
    result.noise = calibrate_noise(
        result.rig, order[0], floor, cycle_s=result.cycle_s, workdir=wd, seed=seed
    )
    for cand in order[:PROOF_TRIES]:
        p = prove(
            result.rig,
            cand,
            result.rivals,
            train,
            holdout,
            repeatability_urad=result.noise["repeatability_urad"],
            exclude=exclude,
            cycle_s=result.cycle_s,
            workdir=wd,
            seed=seed,
            progress=say,
            jobs=jobs,
            recorded=result.recorded_proof,
        )
        result.proofs.append(p)
        if p["all_right"]:
            result.best = cand
            rank = next((i for i, c in enumerate(result.ranked) if c["label"] == cand.label), None)
            result.recommended = {
                **cand.to_json(),
                "rank": rank,
                "separation": result.ranked[rank]["separation"] if rank is not None else None,
                "min_z": result.ranked[rank]["min_z"] if rank is not None else None,
            }
            return
    tried = result.proofs_tried()
    said = "; ".join(
        f"{t['candidate']} (rank {t['rank']}): {', '.join(t['wrong']) or 'no verdict wrong'}"
        for t in tried
    )
    result.why_not = (
        f"none of the {len(tried)} candidates proved (tried in that order: first those whose "
        f"least z reaches {Z_TARGET:g}, the least overlapping signatures first) passed its "
        f"proof within {result.budget_h:g} h: {said}"
    )


def rival_drift(result: DesignResult, *, workdir: str | Path | None = None) -> pl.DataFrame:
    """Each rival's predicted drift on the recommended (or best) candidate's new measurement:
    per run of the scenario, per camera it adds (or every camera, for runs only), per visit
    forecast by the simulator's thermal model: ``effect``, ``run``, ``camera``, ``t_h`` (hours
    since the scenario began), ``drift_u_um``, ``drift_v_um`` (from the run's first visit).

    Parameters
    ----------
    result
        A design (:func:`design`).
    workdir
        Where the forecast is simulated (default: a temporary folder).

    Returns
    -------
    polars.DataFrame
        Empty when there is no candidate.

    Examples
    --------
    >>> # rival_drift(thermrs.design.design(train, holdout, rig)).group_by("effect").len()
    """
    from thermrs.design.forecast import forecast_tables, protocol_samples
    from thermrs.signatures import VisitSet

    cand = result.best
    if cand is None or not result.rivals:
        return pl.DataFrame()
    with tempfile.TemporaryDirectory(prefix="thermrs-design-") as tmp:
        wd = Path(workdir) if workdir is not None else Path(tmp)
        vis, samp = protocol_samples(result.rig, cand.protocol, cycle_s=result.cycle_s,
                                     workdir=wd)  # fmt: skip
    _, new = rig_toml(result.rig, cand)
    like = cand.detail.get("from_camera")
    cam = cand.camera["name"] if cand.camera is not None else None
    tables = forecast_tables(new, vis, samp, new_camera=cam, like_camera=like)
    if cam is not None:
        tables = [t.filter(pl.col("camera") == cam) for t in tables]
    vs = VisitSet(tables, new)
    t0 = int(vs.table["t_ns"].min())  # type: ignore[arg-type]
    frames = []
    for r in result.rivals:
        p = vs.positions(effects=[r.truth], alpha_per_k=r.alpha_per_k)
        df = vs.table.select("run", "camera", "t_ns").with_columns(
            effect=pl.lit(r.effect), u=pl.Series(p[: vs.n]), v=pl.Series(p[vs.n :])
        )
        frames.append(df)
    out = pl.concat(frames).sort("effect", "run", "camera", "t_ns")
    key = ["effect", "run", "camera"]
    return out.select(
        "effect",
        "run",
        "camera",
        t_h=(pl.col("t_ns") - t0) / 3.6e12,
        drift_u_um=pl.col("u") - pl.col("u").first().over(key),
        drift_v_um=pl.col("v") - pl.col("v").first().over(key),
    )
