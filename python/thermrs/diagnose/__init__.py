"""Diagnose the sim-to-real gap: where the nominal model's residual lies, which unmodelled
effect (SPEC §6) causes it, and how far it shrinks once that effect is added — scored on runs
the fits never saw.

The procedure, one module a step (see ``shared/notes/diagnosis.md`` for the field's tools and
their traps):

1. **Baseline** (:mod:`.engine`): α and the per-(run, camera, axis) offsets of the nominal
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

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.diagnose.candidates import Candidate, plausibility, score
from thermrs.diagnose.confounding import confounded_pairs
from thermrs.diagnose.engine import Design, Fit
from thermrs.diagnose.floor import SCALE_SEPARATION, NoiseFloor, noise_floor, thermal_time_scales
from thermrs.diagnose.inputs import check_inputs, smooth_temperatures
from thermrs.diagnose.location import drivers, location_table, phases, whiteness
from thermrs.diagnose.null import Batch
from thermrs.diagnose.resample import cycle_units
from thermrs.diagnose.selection import Step, build_grids, forward_selection
from thermrs.diagnose.verdict import decide, format_params, summary
from thermrs.effects import Effect, Family
from thermrs.rig import Rig
from thermrs.signatures import VisitSet
from thermrs.stats import effective_sample_size

__all__ = ["LEVEL", "Diagnosis", "diagnose"]

FloatArray = npt.NDArray[np.float64]

#: The level of the diagnoser's tests: a run without a gap is called otherwise at most this
#: often (the three tests `none` must pass are each at a third of it).
LEVEL = 0.05
#: Replicates of the parametric bootstrap (the null world) per selection step.
NULL_DRAWS = 199

_fmt_params = format_params  # the CLI's formatter (kept under its old name)


@dataclass
class Diagnosis:
    """The result of :func:`diagnose`: see :meth:`to_json` for every field (SPEC §7)."""

    noise_floor_um: float
    baseline: dict[str, Any]
    location: list[dict[str, Any]]
    drivers: list[dict[str, Any]]
    whiteness: dict[str, Any]
    ranking: list[dict[str, Any]]
    confounded: list[dict[str, Any]]
    verdict: dict[str, Any]
    how_far: dict[str, Any]
    selected: list[dict[str, Any]]
    library: list[str]
    excluded: list[str]
    summary: str
    residuals: pl.DataFrame = field(repr=False)
    noise_floor: dict[str, Any] = field(default_factory=dict)
    tests: dict[str, Any] = field(default_factory=dict)

    @property
    def status(self) -> str:
        """The verdict: ``identified``, ``ambiguous``, ``partially explained``,
        ``unexplained`` or ``none``."""
        return str(self.verdict["status"])

    def to_json(self) -> dict[str, Any]:
        """The SPEC §7 ``thermrs diagnose --json`` document (extended)."""
        return {
            "noise_floor_um": self.noise_floor_um,
            "noise_floor": self.noise_floor,
            "baseline": self.baseline,
            "location": self.location,
            "drivers": self.drivers,
            "whiteness": self.whiteness,
            "ranking": self.ranking,
            "confounded": self.confounded,
            "selected": self.selected,
            "tests": self.tests,
            "verdict": self.verdict,
            "how_far": self.how_far,
            "library": self.library,
            "excluded": self.excluded,
            "summary": self.summary,
        }


def diagnose(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    rig: Rig,
    *,
    exclude: Sequence[str] = (),
    library: Sequence[type[Effect]] | None = None,
    bootstrap: int = 30,
    seed: int = 0,
    level: float = LEVEL,
    null_draws: int = NULL_DRAWS,
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
        The rig (nominal model).
    exclude
        SPEC §6 effect names removed from the library (a withheld-effect check: the
        diagnoser can neither name them nor hold them up as rivals).
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
    progress
        Called with a short message at each stage.

    Returns
    -------
    Diagnosis

    Raises
    ------
    InputError
        No training or no held-out run, a run used twice, a run without visits, an unknown
        effect name in ``exclude``.
    """
    from threadpoolctl import threadpool_limits  # type: ignore[import-untyped]

    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be between 0 and 1, got {level}")
    # Thousands of small least-squares problems: one BLAS thread each is several times faster
    # than a pool that spins (and fights other processes for the cores).
    with threadpool_limits(limits=1, user_api="blas"):
        return _diagnose(
            train,
            holdout,
            rig,
            exclude=exclude,
            library=library,
            bootstrap=bootstrap,
            seed=seed,
            level=level,
            null_draws=null_draws,
            say=progress or (lambda _m: None),
        )


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
    say: Callable[[str], object],
) -> Diagnosis:
    tr, ho, names_t, classes = check_inputs(train, holdout, rig, exclude, library)
    rng = np.random.default_rng(seed)

    say("baseline")
    raw = [*tr, *ho]
    taus, _ = thermal_time_scales(VisitSet(raw, rig), rig.mapped_temperatures)
    # Reading noise out of the temperatures: a symmetric smoother over ± two allowed noise
    # correlation times (a fifth of the shortest thermal time constant).
    tables = smooth_temperatures(raw, 2.0 * min(taus.values()) * 60.0 / SCALE_SEPARATION)
    vs = VisitSet(tables, rig)
    design = Design(vs, set(names_t))
    base = design.fit(None, {}, label="nominal")
    role_visit = np.where(np.isin(vs.run, names_t), "train", "holdout")

    say("floor")
    holdout_runs = set(vs.run.tolist()) - set(names_t)
    floor = noise_floor(vs, base.residual, holdout_runs, rig.mapped_temperatures)
    design.min_tau_min = floor.tau_c_max_s / 60.0

    say("where")
    phase = phases(vs, rig.mapped_temperatures)
    groups3 = np.char.add(np.char.add(design.series, "/"), vs.axis)
    hold = design.hold
    loc = location_table(vs, base.residual, phase, role_visit)
    drv = drivers(vs, base.residual)
    white = whiteness(base.residual[hold], groups3[hold], design.order[hold])

    say("candidates")
    fams: list[Family] = []
    for cls in classes.values():
        fams.extend(cls.families(rig, vs))
    grids = build_grids(fams, vs, design)
    batch = Batch(design, window_s=3.0 * floor.tau_c_max_s)
    steps = forward_selection(
        batch,
        design,
        floor,
        grids,
        level=level / 3.0,
        draws=null_draws,
        rng=rng,
        plausible=plausibility(design, rig),
        say=say,
    )

    say("evidence")
    units = cycle_units(vs)
    n_eff_train = float(
        sum(
            effective_sample_size(base.residual[(groups3 == g)], method="ar1")
            for g in np.unique(groups3[design.train])
        )
    )
    cands = score(
        design,
        base,
        grids,
        steps[0].gain_p,
        set(steps[0].significant),
        rig=rig,
        floor_um=floor.holdout_um,
        n_eff_train=n_eff_train,
        units=units,
        placebo=VisitSet(tables, rig, shift_drivers=True),
        bootstrap=bootstrap,
        rng=rng,
    )

    say("confounding")
    pool = [c for c in cands if c.significant] or cands[:3]
    confounded = confounded_pairs(
        design,
        [(c.effect, c.family.label, c.fit.columns) for c in pool if c.fit.columns is not None],
    )

    say("verdict")
    status, reason, rivals = decide(
        steps, level=level, base_rms=base.holdout_rms_um, floor_um=floor.holdout_um
    )
    final, selected = _final_model(design, steps, rig)
    return _assemble(
        vs=vs,
        design=design,
        base=base,
        floor=floor,
        final=final,
        selected=selected,
        steps=steps,
        cands=cands,
        status=status,
        reason=reason,
        rivals=rivals,
        level=level,
        loc=loc,
        drv=drv,
        white=white,
        confounded=confounded,
        phase=phase,
        role_visit=role_visit,
        classes=sorted(classes),
        exclude=sorted(exclude),
        n_eff_train=n_eff_train,
    )


def _final_model(
    design: Design, steps: list[Step], rig: Rig
) -> tuple[Fit | None, list[dict[str, Any]]]:
    """The selected effects fitted together (non-linear parameters refined one by one), with
    each effect's parameters from the joint fit."""
    chosen = [s.chosen for s in steps if s.chosen is not None]
    if not chosen:
        return None, []
    cols: list[FloatArray] = []
    eta: dict[str, float] = {}
    sel: list[dict[str, Any]] = []
    for ch in chosen:
        fam = ch.grid.family
        fixed = np.column_stack(cols) if cols else None
        best = design.profile(fam, prefix=fixed)
        use_eta = best.eta if best is not None else ch.eta
        c = fam.columns(design.vs, use_eta)
        cols.append(c)
        eta.update({f"{fam.effect}.{k}": v for k, v in use_eta.items()})
        sel.append({"family": fam, "eta": use_eta, "width": c.shape[1]})
    x = np.column_stack(cols)
    f = design.fit(x, eta, label=" + ".join(s["family"].label for s in sel))
    out = []
    first = 0
    for s in sel:
        fam = s["family"]
        k = s["width"]
        idx = [0, *range(1 + first, 1 + first + k)]
        params, ci = fam.params(
            s["eta"], f.alpha, f.beta[first : first + k], f.cov[np.ix_(idx, idx)]
        )
        out.append({"effect": fam.effect, "family": fam.label, "params": params, "params_ci95": ci})
        first += k
    return f, out


def _ranking_row(c: Candidate, base_rms: float, n_eff_train: float) -> dict[str, Any]:
    f = c.fit
    ci = dict(c.ci)
    prof = f.extra.get("profile") or []
    if c.family.refine and prof:
        key = c.family.refine[0]
        best_rss = min(r for _, r in prof)
        lim = best_rss * (1.0 + 3.84 / max(n_eff_train, 1.0))
        ok = [e[key] for e, r in prof if r <= lim] + [f.eta[key]]
        ci[key] = [float(min(ok)), float(max(ok))]
    return {
        "effect": c.effect,
        "family": c.family.label,
        "params": c.params,
        "params_ci95": ci,
        "alpha_per_k": f.alpha,
        "train_rms_um": f.train_rms_um,
        "holdout_rms_um": f.holdout_rms_um,
        "holdout_max_um": f.holdout_max_um,
        "shrink": 1.0 - f.holdout_rms_um / base_rms if base_rms > 0 else 0.0,
        "evidence": {
            "gain_p": c.gain_p,
            "gain_z": c.gain_z,
            "gap_closed": c.closed,
            "gap_closed_raw": c.closed_raw,
            "delta_aicc": c.d_aicc,
            "n_eff": n_eff_train,
            "stability": c.stability,
            "placebo_holdout_rms_um": c.placebo_rms,
            "placebo_beaten": c.placebo_beaten,
            "plausible": c.plausible,
            "identifiable": c.identifiable,
            "qualifies": c.significant and c.plausible,
        },
    }


def _tests(steps: list[Step], level: float) -> dict[str, Any]:
    return {
        "level": level,
        "per_test_level": level / 3.0,
        "method": "parametric bootstrap of the whole pipeline in a world where the model of "
        "each step is the truth (its fit plus the floor's noise model per series); "
        "Bonferroni over the three tests that `none` must pass",
        "steps": [
            {
                "model": [c.label for c in s.model],
                "holdout_rms_um": float(np.sqrt(s.hold_ms)),
                "null_holdout_rms_um_95": float(np.sqrt(np.quantile(s.null_hold_ms, 0.95)))
                if len(s.null_hold_ms)
                else None,
                "p_at_floor": s.p_at_floor,
                "p_white_at_thermal_scales": s.p_low,
                "p_best_gain": s.p_gain,
                "p_floor_contradicted": s.p_floor_contradicted,
                "gain_threshold_um2": s.threshold,
                "significant": s.significant,
                "chosen": None if s.chosen is None else s.chosen.label,
                "rivals": s.rivals,
                "rival_p": s.rival_p,
            }
            for s in steps
        ],
    }


def _assemble(
    *,
    vs: VisitSet,
    design: Design,
    base: Fit,
    floor: NoiseFloor,
    final: Fit | None,
    selected: list[dict[str, Any]],
    steps: list[Step],
    cands: list[Candidate],
    status: str,
    reason: str,
    rivals: list[str],
    level: float,
    loc: list[dict[str, Any]],
    drv: list[dict[str, Any]],
    white: dict[str, Any],
    confounded: list[dict[str, Any]],
    phase: npt.NDArray[np.str_],
    role_visit: npt.NDArray[np.str_],
    classes: list[str],
    exclude: list[str],
    n_eff_train: float,
) -> Diagnosis:
    base_rms = base.holdout_rms_um
    fl = floor.holdout_um
    ranking = [_ranking_row(c, base_rms, n_eff_train) for c in cands]
    after = final if final is not None else base
    gap = base_rms - fl
    raw = (base_rms - after.holdout_rms_um) / gap if gap > 0 and final is not None else None
    how_far = {
        "holdout_rms_before_um": base_rms,
        "holdout_rms_after_um": after.holdout_rms_um,
        "holdout_max_before_um": base.holdout_max_um,
        "holdout_max_after_um": after.holdout_max_um,
        "noise_floor_um": fl,
        "gap_closed": None if raw is None else min(raw, 1.0),
        "gap_closed_raw": raw,
        "gap_closed_note": (
            "the effects remove more than the gap above the floor: the floor is an estimate "
            "and reads high here"
            if raw is not None and raw > 1.0
            else None
        ),
    }
    first = selected[0] if selected else None
    verdict = {
        "status": status,
        "effect": None if first is None or status == "unexplained" else first["effect"],
        "effects": [s["effect"] for s in selected],
        "params": {} if first is None else first["params"],
        "params_ci95": {} if first is None else first["params_ci95"],
        "confounded_with": rivals if status == "ambiguous" else [],
        "holdout_rms_um": after.holdout_rms_um,
        "reason": reason,
    }
    baseline = {
        "alpha_per_k": {
            "value": base.alpha,
            "ci95": list(base.lsq.interval(0) if base.lsq is not None else (np.nan, np.nan)),
        },
        "train_rms_um": base.train_rms_um,
        "holdout_rms_um": base_rms,
        "holdout_max_um": base.holdout_max_um,
        "per_run": _per_run(vs, base.residual, role_visit),
    }
    t_h = (np.concatenate([vs.t_since_start, vs.t_since_start])) / 3600.0
    residuals = pl.DataFrame(
        {
            "run": np.concatenate([vs.run, vs.run]),
            "role": np.concatenate([role_visit, role_visit]),
            "camera": np.concatenate([vs.camera, vs.camera]),
            "axis": vs.axis,
            "t_ns": np.concatenate([vs.table["t_ns"].to_numpy()] * 2),
            "t_h": t_h,
            "phase": np.concatenate([phase, phase]),
            "baseline_um": base.residual,
            "after_um": final.residual if final is not None else np.full(2 * vs.n, np.nan),
        }
    ).with_columns(pl.col("after_um").fill_nan(None))
    d = Diagnosis(
        noise_floor_um=fl,
        baseline=baseline,
        location=loc,
        drivers=drv[:20],
        whiteness=white,
        ranking=ranking,
        confounded=confounded,
        verdict=verdict,
        how_far=how_far,
        selected=[{k: s[k] for k in ("effect", "family", "params")} for s in selected],
        library=classes,
        excluded=exclude,
        summary="",
        residuals=residuals,
        noise_floor=floor.to_json(),
        tests=_tests(steps, level),
    )
    d.summary = summary(d)
    return d


def _per_run(
    vs: VisitSet, residual: FloatArray, role: npt.NDArray[np.str_]
) -> list[dict[str, Any]]:
    out = []
    run2 = np.concatenate([vs.run, vs.run])
    cam2 = np.concatenate([vs.camera, vs.camera])
    for r in dict.fromkeys(vs.run.tolist()):
        for c in dict.fromkeys(vs.camera.tolist()):
            for ax in ("u", "v"):
                m = (run2 == r) & (cam2 == c) & (vs.axis == ax)
                if m.any():
                    out.append(
                        {
                            "run": r,
                            "role": str(role[vs.run == r][0]),
                            "camera": c,
                            "axis": ax,
                            "rms_um": float(np.sqrt(np.mean(residual[m] ** 2))),
                        }
                    )
    return out
