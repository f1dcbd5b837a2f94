"""Diagnose the sim-to-real gap: where the nominal model's residual lies, which unmodelled
effect (SPEC §6) causes it, and how far it shrinks once that effect is added — scored on runs
the fits never saw.

The procedure, one module a step (see ``shared/notes/diagnosis.md`` for the field's tools and
their traps):

1. **Baseline** (:mod:`.family_fit`): α and the per-(run, camera, axis) offsets of the nominal
   model fitted on the training runs; the held-out runs get only their offsets.
2. **Floor** (:mod:`.floor`): what is noise by physics — the centroid's scatter within a visit,
   the visit-to-visit repeatability at lags short against the runs' own thermal time
   constants, a pose error correlated only over a tenth of the shortest of them. Each held-out
   run has its own.
3. **Where** (:mod:`.location`): the residual by run, camera, chip axis and phase, the drivers
   it follows, whether it is white.
4. **Candidates and null** (:mod:`.selection`, :mod:`.null`): every family of the effect
   library (:meth:`thermrs.effects.Effect.families`, without the excluded effects) added to the
   model so far and scored on the held-out runs, against a parametric bootstrap of the whole
   pipeline in a world where the model so far is the truth: that null decides whether the
   residual is at the floor, white at the thermal time scales, and whether a candidate's gain
   is significant. Effects are added by forward selection.
5. **Resampling and evidence** (:mod:`.resample`, :mod:`.candidates`): each effect's best
   family refined, with a block bootstrap of whole cycles, ΔAICc, placebo, stability,
   plausibility.
6. **Confounding** (:mod:`.confounding`): which candidates these runs cannot tell apart.
7. **Verdict** (:mod:`.verdict`): ``identified``, ``ambiguous``, ``partially explained``,
   ``unexplained`` or ``none``; every threshold is a test at ``level`` (default 5 %).
8. **How far**: held-out rms and maximum before and after; the share of the gap above the
   floor that is closed.

Example
-------
>>> import thermrs
>>> from thermrs.diagnose import diagnose
>>> # d = diagnose([train_table], [holdout_table], thermrs.load_rig())
>>> # d.verdict["status"], d.to_json()["ranking"][0]["effect"]
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.diagnose.accuracy import NOISE_DRAWS
from thermrs.diagnose.candidates import Candidate, plausibility, score
from thermrs.diagnose.closing import closing_interval
from thermrs.diagnose.confounding import confounded_pairs
from thermrs.diagnose.family_fit import DesignMatrix, Fit
from thermrs.diagnose.final_model import alternative_fits, final_model
from thermrs.diagnose.floor import SCALE_SEPARATION, NoiseFloor, noise_floor, thermal_time_scales
from thermrs.diagnose.guard import GUARD_SCALE, rig_excess_guard
from thermrs.diagnose.input_checks import check_inputs, smooth_temperatures
from thermrs.diagnose.location import drivers, location_table, phases, whiteness
from thermrs.diagnose.null import Batch, draw_noise
from thermrs.diagnose.reading_noise import reading_noise_k, thermometer_floor
from thermrs.diagnose.resample import cycle_units
from thermrs.diagnose.result import Diagnosis, assemble
from thermrs.diagnose.selection import FamilyGrid, Step, build_grids, forward_selection
from thermrs.diagnose.tolerance_scale import tolerance_scale
from thermrs.diagnose.tolerances import nuisance_signatures
from thermrs.diagnose.verdict import decide
from thermrs.effects import Effect, Family, is_instrument
from thermrs.memo import DiskCache
from thermrs.rig import Rig
from thermrs.signatures import VisitSet
from thermrs.stats import effective_sample_size

__all__ = ["LEVEL", "Diagnosis", "diagnose", "noise_floor_um"]

FloatArray = npt.NDArray[np.float64]

#: The level of the diagnoser's tests: a run without a gap is called otherwise at most this
#: often (the four tests `none` must pass are each at a quarter of it).
LEVEL = 0.05
#: The default practical margin is the held-out floor's standard error (what the held-out
#: runs resolve; it shrinks as they grow longer), not a share of the floor: a fixed share made
#: every effect under a third of the floor unnameable at any run length. ``margin_um`` states
#: a practical threshold of the user's own instead.
#: Replicates of the parametric bootstrap (the null world) per selection step.
NULL_DRAWS = 199


def diagnose(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    rig: Rig | str | os.PathLike[str],
    *,
    exclude: Sequence[str] = (),
    library: Sequence[type[Effect]] | None = None,
    bootstrap: int = 30,
    seed: int = 0,
    level: float = LEVEL,
    null_draws: int = NULL_DRAWS,
    margin_um: float | None = None,
    progress: Callable[[str], object] | None = None,
) -> Diagnosis:
    """Diagnose the nominal model's gap on ``holdout`` runs after fitting on ``train`` runs.

    Parameters
    ----------
    train, holdout
        Run tables (:func:`thermrs.fit.load_run_table`); at least one of each, with distinct
        ``run`` names. Fits use only ``train``; ``holdout`` runs contribute only their own
        offsets (unknown mountings).
    rig
        The rig (nominal model), or the path of its file.
    exclude
        SPEC §6 effect names removed from the library: the diagnoser never names them. An
        excluded effect that explains the gap as well as the one selected, and that the data
        cannot reject as the truth, stops that one from being called the cause: the verdict
        is then ``partially explained``, the selected effect a stand-in (a withheld-effect
        check cannot be passed by a look-alike).
    library
        Effect classes to consider (default: every registered one,
        :func:`thermrs.effects.effect_classes`).
    bootstrap
        Block resamples of the training cycles for the stability score.
    seed
        Seed of every random draw.
    level
        The level of the tests (module docs of :mod:`thermrs.diagnose.verdict`).
    null_draws
        Replicates of the parametric bootstrap per selection step.
    margin_um
        The practical margin: an effect is named only if it takes at least this much off the
        held-out rms (µm), beyond being significant against the null (default: the held-out
        noise floor's standard error, what the held-out runs resolve).
    progress
        Called with a short message at each stage.

    Returns
    -------
    Diagnosis
        Kept on disk by the content of the runs, the rig, the options and thermrs's own
        files (:class:`thermrs.memo.DiskCache`, ``THERMRS_CACHE_DIR``; not with a
        ``library`` given): the same inputs again are read back, ``progress`` told so.

    Raises
    ------
    InputError
        No training or no held-out run, a run used twice, a run without visits, an unknown
        effect name in ``exclude``.
    """
    from threadpoolctl import threadpool_limits  # type: ignore[import-untyped]

    from thermrs.rig import as_rig

    rig = as_rig(rig)
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be between 0 and 1, got {level}")
    if margin_um is not None and not (np.isfinite(margin_um) and margin_um >= 0):
        raise ValueError(f"margin_um must be a finite number of µm, 0 or more, got {margin_um}")
    say = progress or (lambda _m: None)

    def compute() -> Diagnosis:
        # Thousands of small least-squares problems: one BLAS thread each is several times
        # faster than a pool that spins (and fights other processes for the cores).
        with threadpool_limits(limits=1, user_api="blas"):
            d = _diagnose(
                train,
                holdout,
                rig,
                exclude=exclude,
                library=library,
                bootstrap=bootstrap,
                seed=seed,
                level=level,
                null_draws=null_draws,
                margin_um=margin_um,
                say=say,
            )
        return _with_identity(train, holdout, rig, d)

    if library is not None:  # classes of the caller's: not keyed by content
        return compute()
    options = (sorted(exclude), bootstrap, seed, level, null_draws, margin_um)
    try:
        key = _inputs_key(train, holdout, rig, options)
    except Exception:  # inputs that are not tables: diagnose says what is wrong with them
        return compute()
    return _DIAGNOSES.get(key, compute, on_hit=lambda f: say(f"reused from the cache ({f.parent})"))


def _with_identity(
    train: Sequence[pl.DataFrame], holdout: Sequence[pl.DataFrame], rig: Rig, d: Diagnosis
) -> Diagnosis:
    """``d`` with what it belongs to: its runs' content digests and its rig's identity."""
    from thermrs.identity import rig_identity, run_digests

    d.run_digests = run_digests([*train, *holdout])
    d.rig = rig_identity(rig)
    return d


#: Diagnoses kept on disk by the content of their runs, rig and options
#: (:class:`thermrs.memo.DiskCache`): diagnose, design and report on the same runs diagnose
#: them once.
_DIAGNOSES: DiskCache[Diagnosis] = DiskCache("diagnoses")


def _inputs_key(
    train: Sequence[pl.DataFrame], holdout: Sequence[pl.DataFrame], rig: Rig, options: object
) -> bytes:
    """The digest of a diagnosis's inputs: the code, the rig, the options, every run table
    (Arrow IPC bytes: columns, types and values)."""
    from thermrs.memo import code_identity, content_key

    def ipc(t: pl.DataFrame) -> bytes:
        return t.write_ipc(None).getvalue()

    return content_key(
        code_identity(),
        rig.source,
        rig.to_dict(),
        options,
        len(train),
        *(ipc(t) for t in (*train, *holdout)),
    )


def noise_floor_um(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    rig: Rig | str | os.PathLike[str],
) -> float:
    """The noise floor of the nominal model's residual on these runs, computed as
    :func:`diagnose` does without selecting effects (its ``noise_floor_um`` where it names
    none; with effects named it estimates the floor again on their model's residual): what
    calibrating a simulation's noise needs.

    Parameters
    ----------
    train, holdout
        Run tables, as for :func:`diagnose`.
    rig
        The rig they were recorded on.

    Returns
    -------
    float
        The held-out runs' noise floor (µm rms).

    Raises
    ------
    InputError
        Bad runs, as :func:`diagnose`.
    """
    from threadpoolctl import threadpool_limits

    from thermrs.rig import as_rig

    rig = as_rig(rig)
    with threadpool_limits(limits=1, user_api="blas"):
        tr, ho, names_t, _ = check_inputs(train, holdout, rig, (), None)
        return float(_baseline(tr, ho, names_t, rig).floor.holdout_um)


@dataclass
class _Base:
    """What every later step shares: the de-noised run tables, the visits, the design, the
    nominal fit and the floor."""

    tables: list[pl.DataFrame]
    vs: VisitSet
    design: DesignMatrix
    base: Fit
    floor: NoiseFloor
    role_visit: npt.NDArray[np.str_]
    groups3: npt.NDArray[np.str_]
    #: The readings' smoother's half-width (s) and each ROI's reading noise (K) it left out.
    smooth_s: float = 0.0
    reading_k: dict[str, float] = field(default_factory=dict)


def _baseline(
    tr: list[pl.DataFrame], ho: list[pl.DataFrame], names_t: list[str], rig: Rig
) -> _Base:
    raw = [*tr, *ho]
    raw_vs = VisitSet(raw, rig)
    taus, _ = thermal_time_scales(raw_vs, rig.mapped_temperatures)
    # Reading noise out of the temperatures: a symmetric smoother over ± two allowed noise
    # correlation times (a fifth of the shortest thermal time constant).
    smooth_s = 2.0 * min(taus.values()) * 60.0 / SCALE_SEPARATION
    tables = smooth_temperatures(raw, smooth_s)
    vs = VisitSet(tables, rig)
    design = DesignMatrix(vs, set(names_t))
    base = design.fit(None, {}, label="nominal")
    holdout_runs = set(vs.run.tolist()) - set(names_t)
    floor = noise_floor(vs, base.residual, holdout_runs, rig.mapped_temperatures)
    design.min_tau_min = floor.tau_c_max_s / 60.0
    reading_k = reading_noise_k(raw_vs, vs, smooth_s, np.random.default_rng(48))
    design.reading_noise_k = max(reading_k.values()) if reading_k else None
    design.nuisance, design.nuisance_names, design.model_nuisance = nuisance_signatures(
        vs, rig, base.alpha, floor_um=floor.holdout_um
    )
    return _Base(
        tables=tables,
        vs=vs,
        design=design,
        base=base,
        floor=floor,
        role_visit=np.where(np.isin(vs.run, names_t), "train", "holdout"),
        groups3=np.char.add(np.char.add(design.series, "/"), vs.axis),
        smooth_s=smooth_s,
        reading_k=reading_k,
    )


def _where(b: _Base, rig: Rig) -> dict[str, Any]:
    hold = b.design.hold
    phase = phases(b.vs, rig.mapped_temperatures)
    return {
        "phase": phase,
        "loc": location_table(b.vs, b.base.residual, phase, b.role_visit),
        "drv": drivers(b.vs, b.base.residual),
        "white": whiteness(b.base.residual[hold], b.groups3[hold], b.design.order[hold]),
    }


def _diagnose(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    rig: Rig,
    *,
    exclude: Sequence[str],
    library: Sequence[type[Effect]] | None,
    bootstrap: int,
    seed: int,
    level: float,
    null_draws: int,
    margin_um: float | None,
    say: Callable[[str], object],
) -> Diagnosis:
    tr, ho, names_t, classes = check_inputs(train, holdout, rig, exclude, library)
    rng = np.random.default_rng(seed)
    say("baseline and floor")
    b = _baseline(tr, ho, names_t, rig)
    say("where")
    where = _where(b, rig)
    say("candidates")
    margin: float | None = None if margin_um is None else float(margin_um)
    outside = _outside(exclude, library)
    grids, steps, batch = _select(
        b,
        classes,
        rig,
        outside=outside,
        level=level,
        null_draws=null_draws,
        margin_um=margin,
        rng=rng,
        scale_rng=np.random.default_rng([seed % 2**63, 45]),
        guard_rng=np.random.default_rng([seed % 2**63, 46]),
        say=say,
    )
    margin = steps[0].margin_um
    say("evidence")
    cands, n_eff_train = _evidence(b, grids, steps, rig, bootstrap=bootstrap, rng=rng)
    say("confounding")
    confounded = _confounded(b, cands)
    final, selected = final_model(b.design, steps, n_eff_train)
    if final is not None:
        _floor_of_final_model(b, final, rig)
        if final.columns is not None:
            _with_final_model(b, batch, final.columns, seed, final.extra.get("nuisance"))
    _thermometers(b, final, seed)
    first = steps[0]
    if first.significant or min(first.p_at_floor, first.p_low, first.p_floor_contradicted) < (
        level / 4.0
    ):
        # At the verdict's own level: an effect of the robot is named only if the selection
        # and this test both find it (intersection–union), so the share of effect-free runs on
        # a rig erring by up to GUARD_SCALE× its statement that name one is at most `level`.
        _test_at_tolerance_scale(
            b, batch, grids, steps, rig, level=level, draws=null_draws, rng=rng, say=say
        )
    say("verdict")
    status, reason, rivals = decide(
        steps,
        level=level,
        base_rms=b.base.holdout_rms_um,
        floor_um=b.floor.holdout_um,
        margin_um=margin,
        floor_se_um=b.floor.holdout_se_um,
        tolerances_stated=rig.tolerances_stated,
    )
    alternatives = {s.chosen.label: s.alternatives for s in steps if s.chosen is not None}
    for sel in selected:
        sel["alternatives"] = alternatives.get(sel["family"], [])
    if selected and selected[0]["alternatives"]:
        # What the law of the verdict's effect must span: each choice the data cannot tell
        # from the one named, fitted in its place.
        selected[0]["alternative_fits"] = alternative_fits(
            b.design, steps, n_eff_train, grids, selected[0]["alternatives"]
        )
    _agree(confounded, steps)
    return assemble(
        vs=b.vs,
        base=b.base,
        floor=b.floor,
        final=final,
        selected=selected,
        steps=steps,
        cands=cands,
        verdict=(status, reason, rivals),
        level=level,
        where={**where, "confounded": confounded},
        role_visit=b.role_visit,
        library=(sorted(classes), sorted(exclude)),
        n_eff_train=n_eff_train,
        margin_um=margin,
        tolerances=(rig.tolerances, b.design.nuisance_names, rig.tolerances_stated),
    )


def _agree(confounded: list[dict[str, Any]], steps: list[Step]) -> None:
    """One statement per pair: where the rival test rejected one of a confounded pair (their
    signatures nearly parallel, yet the held-out data tell them apart), the pair says so
    instead of "nothing separates them"."""
    from thermrs.diagnose.null import format_p

    chosen = {s.chosen.effect for s in steps if s.chosen is not None}
    for c in confounded:
        for mine, other in (c["effects"], c["effects"][::-1]):
            st = next((s for s in steps if other in s.rival_p), None)
            if mine not in chosen or st is None:
                continue
            p = format_p(st.rival_p[other], st.rival_draws)
            if other in st.rivals:
                c["rival_test"] = {"kept": other, "p": st.rival_p[other]}
            else:
                c["rival_test"] = {"rejected": other, "p": st.rival_p[other]}
                c["separate_by"] = (
                    f"their signatures are nearly parallel on these runs, yet the held-out "
                    f"data reject {other} as the truth (rival test p {p}); `thermrs design` "
                    "computes the measurement that would separate them by their signatures too"
                )


def _outside(
    exclude: Sequence[str], library: Sequence[type[Effect]] | None
) -> dict[str, type[Effect]]:
    """The excluded effects the diagnoser knows the physics of: rivals it may not name."""
    from thermrs.effects import effect_classes

    known = dict(effect_classes()) if library is None else {c.name: c for c in library}
    return {e: known[e] for e in exclude if e in known}


def _select(
    b: _Base,
    classes: dict[str, type[Effect]],
    rig: Rig,
    *,
    outside: dict[str, type[Effect]],
    level: float,
    null_draws: int,
    margin_um: float | None,
    rng: np.random.Generator,
    scale_rng: np.random.Generator,
    guard_rng: np.random.Generator,
    say: Callable[[str], object],
) -> tuple[list[FamilyGrid], list[Step], Batch]:
    """Every family of the library on these runs, and the forward selection among them
    (each step at level / 4: Bonferroni over the four tests `none` must pass), and how far
    the rig's errors exceed what it states on the nominal residual (:mod:`.tolerance_scale`);
    the batch of held-out fits they used."""
    fams: list[Family] = []
    for cls in classes.values():
        fams.extend(cls.families(rig, b.vs))
    grids = build_grids(fams, b.vs, b.design)
    others: list[Family] = []
    for cls in outside.values():
        others.extend(cls.families(rig, b.vs))
    grids += build_grids(others, b.vs, b.design, nameable=False)
    batch = Batch(b.design, window_s=3.0 * b.floor.tau_c_max_s)

    def guard(given: FloatArray | None, skip: frozenset[str]) -> dict[str, Any]:
        # On its own generator; the nominal model's once, which the verdict's test reuses.
        if given is not None:
            return _guard(b, grids, level, null_draws, guard_rng, given=given, skip=skip)
        if "tolerance_excess" not in b.floor.extra:
            b.floor.extra["tolerance_excess"] = _guard(b, grids, level, null_draws, guard_rng)
        out: dict[str, Any] = b.floor.extra["tolerance_excess"]
        return out

    steps = forward_selection(
        batch,
        b.design,
        b.floor,
        grids,
        level=level / 4.0,
        gap_level=level,
        guard=guard,
        draws=null_draws,
        margin_um=margin_um,
        rng=rng,
        plausible=plausibility(b.design, rig),
        say=say,
    )
    # How far the rig's errors exceed what it states, from the nominal residual (its own
    # generator: the rest of the diagnosis draws what it drew before).
    ts = tolerance_scale(batch, b.design, b.floor, scale_rng)
    b.floor.extra["tolerance_scale"] = None if ts is None else ts.to_json()
    return [g for g in grids if g.nameable], steps, batch


def _test_at_tolerance_scale(
    b: _Base,
    batch: Batch,
    grids: list[FamilyGrid],
    steps: list[Step],
    rig: Rig,
    *,
    level: float,
    draws: int,
    rng: np.random.Generator,
    say: Callable[[str], object],
) -> None:
    """Where the first step found something: whether the effects of the robot the verdict
    would name (selected, or their rivals) stand out of a rig erring by up to
    :data:`.guard.GUARD_SCALE` times its stated tolerances (:mod:`.guard`); ``explains`` is
    true where none of them does (where it would name none: where no family of the robot
    does).

    The factor the data give (:mod:`.tolerance_scale`, ``tests.tolerance_scale``) is reported
    and said in the verdict, but the test does not take its upper bound: with the effects
    selected fitted, an effect the library's form fits only in part reads as rig error (the
    bound reached 3.6–15.5× on joint offsets and non-linear α the stated tolerances name
    rightly)."""
    named = {st.chosen.effect for st in steps if st.chosen is not None}
    named |= {r for st in steps for r in st.rivals}
    robot = sorted(e for e in named if not is_instrument(e))
    say(f"the effects against a rig erring by up to {GUARD_SCALE:g}× its tolerances")
    out = b.floor.extra.get("tolerance_excess") or _guard(b, grids, level, draws, rng)
    if out.get("tested"):
        still = set(out["significant_effects"])
        out["explains"] = bool(not set(robot) & still) if robot else not still
    b.floor.extra["tolerance_excess"] = out


def _guard(
    b: _Base,
    grids: list[FamilyGrid],
    level: float,
    draws: int,
    rng: np.random.Generator,
    *,
    given: FloatArray | None = None,
    skip: frozenset[str] = frozenset(),
) -> dict[str, Any]:
    """The guard's test (:mod:`.guard`) of the library's families on these runs, given the
    effects' columns ``given`` (their effects ``skip``ped)."""
    if b.design.nuisance.shape[1] == 0:
        return {"scale": GUARD_SCALE, "tested": False}
    nameable = [g for g in grids if g.nameable]
    return rig_excess_guard(
        b.design, b.floor, nameable, level=level, draws=draws, rng=rng, given=given, skip=skip
    )


def _evidence(
    b: _Base,
    grids: list[FamilyGrid],
    steps: list[Step],
    rig: Rig,
    *,
    bootstrap: int,
    rng: np.random.Generator,
) -> tuple[list[Candidate], float]:
    """Each family's evidence (:func:`score`), and the training runs' effective sample size
    behind it."""
    n_eff_train = float(
        sum(
            effective_sample_size(b.base.residual[(b.groups3 == g)], method="ar1")
            for g in np.unique(b.groups3[b.design.train])
        )
    )
    cands = score(
        b.design,
        b.base,
        grids,
        steps[0].gain_p,
        set(steps[0].significant),
        rig=rig,
        floor_um=b.floor.holdout_um,
        n_eff_train=n_eff_train,
        units=cycle_units(b.vs),
        placebo=VisitSet(b.tables, rig, shift_drivers=True),
        bootstrap=bootstrap,
        rng=rng,
        # A child stream: the draws after it are those they were without it.
        noise=draw_noise(b.design, b.floor, NOISE_DRAWS, rng.spawn(1)[0])[
            np.flatnonzero(b.design.hold)
        ],
    )
    return cands, n_eff_train


def _confounded(b: _Base, cands: list[Candidate]) -> list[dict[str, Any]]:
    """Pairs of the significant families (else the three best) the design cannot separate."""
    pool = [c for c in cands if c.significant] or cands[:3]
    return confounded_pairs(
        b.design,
        [(c.effect, c.family.label, c.fit.columns) for c in pool if c.fit.columns is not None],
    )


def _floor_of_final_model(b: _Base, final: Fit, rig: Rig) -> None:
    """The noise floor estimated again on the residual of the model with its effects: a gap
    left in the nominal residual leaks into its variogram (its slow increments read as noise),
    so with effects named the floor of the nominal residual reads high. The held-out runs'
    residual is the model's prediction error (α and the effects from the training runs), so
    it is not fitted to them. The interval keeps the estimator's spread measured in the null
    world (:func:`.selection._floor_uncertainty`), centred on the new estimate; the
    nominal residual's floor is kept as ``nominal_holdout_um``."""
    holdout_runs = set(b.vs.run.tolist()) - set(np.unique(b.vs.run[b.role_visit == "train"]))
    new = noise_floor(b.vs, final.residual, holdout_runs, rig.mapped_temperatures)
    if not np.isfinite(new.holdout_um):
        return
    fl = b.floor
    fl.extra["nominal_holdout_um"] = fl.holdout_um
    fl.extra["estimated_on"] = (
        "the residual of the model with the effects named (the nominal residual's floor, "
        "nominal_holdout_um, counts part of the gap as noise)"
    )
    fl.series = new.series
    fl.per_run_um = new.per_run_um
    fl.holdout_um = new.holdout_um
    fl.train_um = new.train_um
    if fl.holdout_se_um is not None:
        se = fl.holdout_se_um
        fl.holdout_ci95 = (max(fl.holdout_um - 1.96 * se, 0.0), fl.holdout_um + 1.96 * se)


def _thermometers(b: _Base, final: Fit | None, seed: int) -> None:
    """The thermal camera's reading noise's share of the held-out floor, through the final
    model (the nominal one where there is none): :mod:`.reading_noise`."""
    nuisance = b.design.model_nuisance
    if nuisance is None or not b.reading_k:
        return
    terms = [] if final is None else final.extra.get("terms", [])
    coef = (
        np.array([b.base.alpha])
        if final is None or "terms" not in final.extra
        else np.concatenate([[final.alpha], final.beta])
    )
    holdout_runs = set(b.vs.run.tolist()) - set(np.unique(b.vs.run[b.role_visit == "train"]))
    got = thermometer_floor(
        b.vs,
        nuisance,
        terms,
        coef,
        b.reading_k,
        b.floor,
        holdout_runs,
        b.smooth_s,
        np.random.default_rng([seed % 2**63, 49]),
    )
    if got is not None:
        b.floor.extra["thermometers"] = got


def _with_final_model(
    b: _Base, batch: Batch, columns: FloatArray, seed: int, nuisance: FloatArray | None
) -> None:
    """What the final model (its effect ``columns``) adds to the floor's record: the share of
    the gap it closes with its interval (:mod:`.closing`), and how far the rig's errors
    exceed its statement once the effects are fitted (:mod:`.tolerance_scale`; the estimate
    on the nominal residual counts an effect along the tolerances' signatures as the
    rig's; fitted with them, what they absorb of the tolerances' signatures is counted,
    so the estimate holds whether they are real or not). Each from its own generator: the
    rest of the diagnosis draws what it drew."""
    b.floor.extra["closing"] = closing_interval(
        batch,
        b.design,
        b.floor,
        columns,
        np.random.default_rng([seed % 2**63, 47]),
        nuisance=nuisance,
    )
    ts = b.floor.extra.get("tolerance_scale")
    if ts is not None:
        after = tolerance_scale(
            batch, b.design, b.floor, np.random.default_rng([seed % 2**63, 46]), columns=columns
        )
        ts["with_effects"] = None if after is None else after.to_json()


def __getattr__(name: str) -> Any:
    """The paper's diagnosis and the steps (``thermrs.diagnose.paper``, ``.tolerances``, …),
    and ``.bench`` (moved to :mod:`thermrs.bench` until 0.2.0), imported on first use."""
    import importlib

    if name in ("bench", "paper", "tolerances", "floor", "selection"):
        return importlib.import_module(f"thermrs.diagnose.{name}")
    raise AttributeError(f"module 'thermrs.diagnose' has no attribute {name!r}")
